// Fuzz target: the run folder's records that `mlcg resume` reads: checkpoints/manifest.json
// (launcher::read_manifest, then the checks of the set it names: launcher::damage_of and the advice
// for a damaged set) and launcher.json (launcher::read_run_info). The run folder holds two intact
// consistent sets, i1 and i2, as the coupler leaves them. Seeds: manifests as the coupler writes them
// (fuzz_seeds). Bad input must come back as a std::runtime_error naming the file and field.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <stdexcept>

#include "bus/checkpoint_file.hpp"
#include "run/checkpoints.hpp"
#include "fuzz_support.hpp"
#include "io/atomic_file.hpp"
#include "io/h5.hpp"

namespace fs = std::filesystem;

namespace {

fs::path make_run() {
  using namespace mlcg;
  const fs::path run = fuzz::scratch("run");
  const auto coupler = fuzz::quickstart_coupler().make();
  for (uint64_t k : {1, 2}) {
    const fs::path set = run / "checkpoints" / ("i" + std::to_string(k));
    fs::create_directories(set);
    for (const auto& l : coupler->config().levels) {
      io::H5Writer w(set / (l.name + ".h5"));
      w.set_attr("/", "format", "mlcg-level-checkpoint");
      w.commit();
    }
    bus::CouplerCheckpoint c;
    c.set_interval(k);
    c.set_case_hash("0123456789abcdef");
    coupler->save(c);
    io::write_file_atomic(set / "coupler.pb", c.SerializeAsString());
  }
  return run;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace mlcg;
  static const fs::path run = make_run();
  fuzz::write_file(run / "checkpoints" / "manifest.json", data, size);
  fuzz::write_file(run / "launcher.json", data, size);
  try {
    if (const auto set = launcher::read_manifest(run)) {
      const std::string damage = launcher::damage_of(*set);
      if (!damage.empty()) launcher::damaged_set_advice(*set, damage, run);
    }
  } catch (const std::runtime_error&) {
  }
  try {
    launcher::read_run_info(run);
  } catch (const std::runtime_error&) {
  }
  return 0;
}
