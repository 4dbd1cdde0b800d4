// Fuzz target: the coupler's part of a consistent checkpoint (coupler.pb), read as coupler_service
// --resume and the launcher's checks read it (bus::read_coupler_checkpoint), restored into the
// quickstart MLCG case's coupler (Coupler::restore) with the Service's check of its commands, then run
// for two intervals of plausible statistics and ended, so that restored state the checks let through is used.
// Seeds: the coupler's own checkpoints after a few intervals (fuzz_seeds). Bad input must come back as
// std::runtime_error / std::invalid_argument naming the file or field.
#include <cstddef>
#include <cstdint>
#include <stdexcept>

#include "bus/checkpoint_file.hpp"
#include "fuzz_support.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace mlcg;
  static const auto file = fuzz::scratch() / "coupler.pb";
  fuzz::write_file(file, data, size);
  bus::CouplerCheckpoint c;
  try {
    c = bus::read_coupler_checkpoint(file);
  } catch (const std::runtime_error&) {
    return 0;
  }
  try {
    // A resumed run whose levels finish at once hands the restored insertion lists back to the faces.
    const auto ended = fuzz::quickstart_coupler().make();
    ended->restore(c);
    ended->cancel_last_insertions();
    const auto coupler = fuzz::quickstart_coupler().make();
    coupler->restore(c);
    if (static_cast<size_t>(c.commands_size()) != coupler->config().levels.size()) return 0;  // the Service refuses it
    for (uint64_t k = c.interval(); k < c.interval() + 2; ++k) coupler->advance(k, fuzz::plausible_stats(*coupler, k));
    coupler->cancel_last_insertions();
  } catch (const std::invalid_argument&) {
  }
  return 0;
}
