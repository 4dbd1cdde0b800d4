// Fuzz target: the `[initial] file` of a case (an HDF5 particle snapshot), read as dem_level reads it
// when it sets up the quickstart hopper with it, then two steps run, so that particles the checks let
// through are used. The input is the snapshot's HDF5 content (fuzz_support.hpp), written by H5Writer.
// Seeds: snapshots of the quickstart hopper while it fills (fuzz_seeds). Bad input must come back as a
// std::runtime_error naming the file.
#include <cstddef>
#include <cstdint>

#include "fuzz_support.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const auto file = mlcg::fuzz::scratch() / "initial.h5";
  static const auto cs = [] {
    auto c = mlcg::fuzz::shipped_case("cases/quickstart/case.toml");
    c.initial = mlcg::config::InitialSpec{file.string(), "beads", {"cases/quickstart/case.toml", 1}};
    return c;
  }();
  mlcg::fuzz::write_h5_content(file, data, size);
  mlcg::fuzz::run_level(cs);
  return 0;
}
