// Fuzz target: a level checkpoint, read as `dem_level --restart` reads it (Level::load_checkpoint through
// the Level's set-up) for the quickstart hopper, then two steps run from it, so that restored state the
// checks let through is used. The input is the checkpoint's HDF5 content (fuzz_support.hpp: datasets and
// attributes, their names, types, shapes and values), written by H5Writer. Seeds: checkpoints of the
// quickstart hopper written while it fills (fuzz_seeds). Bad input must come back as a std::runtime_error
// naming the file.
#include <cstddef>
#include <cstdint>

#include "fuzz_support.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const auto cs = mlcg::fuzz::shipped_case("cases/quickstart/case.toml");
  static const auto file = mlcg::fuzz::scratch() / "checkpoint.h5";
  mlcg::fuzz::write_h5_content(file, data, size);
  mlcg::fuzz::run_level(cs, file);
  return 0;
}
