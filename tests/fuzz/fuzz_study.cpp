// Fuzz target: the study file of `mlcg study` (launcher::load_study), read in a copy of the quickstart
// case folder so that its variants and sweeps find real cases. Seeds: every shipped study.toml.
// Bad input must come back as a StudyError naming file, line and key.
#include <cstddef>
#include <cstdint>
#include <filesystem>

#include "fuzz_support.hpp"
#include "study/study_file.hpp"

namespace fs = std::filesystem;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const fs::path dir = [] {
    const fs::path d = mlcg::fuzz::scratch("study");
    for (const char* f : {"case.toml", "cg2.toml", "mlcg.toml", "mlcg3.toml"})
      fs::copy_file(mlcg::fuzz::source("cases/quickstart") / f, d / f, fs::copy_options::overwrite_existing);
    // The hopper studies compare against reference.toml.
    fs::copy_file(d / "case.toml", d / "reference.toml", fs::copy_options::overwrite_existing);
    return d;
  }();
  const fs::path file = dir / "study.toml";
  mlcg::fuzz::write_file(file, data, size);
  try {
    mlcg::launcher::load_study(dir, file.string(), true, (dir / "out").string());
  } catch (const mlcg::launcher::StudyError&) {
  }
  return 0;
}
