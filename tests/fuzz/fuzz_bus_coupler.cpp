// Fuzz target: the coupler's side of the bus. One frame from "a level" is decoded as the coupler's
// channel decodes it (bus::decode); a registration is answered as Service::on_register answers it, and
// statistics are taken as the Service takes them: as that level's statistics of interval k, next to
// plausible ones of the other level, for three intervals of the quickstart MLCG case's coupler
// (Coupler::advance: grids checked, crossings planned into insertion lists, controllers updated).
// Seeds: the quickstart levels' registrations and statistics (fuzz_seeds). Bad input must be refused
// with std::invalid_argument / a decode error, never crash.
#include <cstddef>
#include <cstdint>
#include <stdexcept>

#include "bus/channel.hpp"
#include "fuzz_support.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace mlcg;
  const bus::Decoded d = bus::decode(data, size);
  if (!d.ok()) return 0;
  const auto coupler = fuzz::quickstart_coupler().make();
  if (d.env.has_register_level()) {
    const int l = coupler->level_index(d.env.register_level().level_name());
    if (l >= 0) coupler->welcome(static_cast<size_t>(l), d.env.register_level().start_interval());
    return 0;
  }
  const int l = coupler->level_index(d.env.sender());  // the Service knows the peer by its routing id
  if (!d.env.has_stats() || l < 0) return 0;
  try {
    for (uint64_t k = 0; k < 3; ++k) {
      auto stats = fuzz::plausible_stats(*coupler, k);
      stats[static_cast<size_t>(l)] = d.env.stats();
      stats[static_cast<size_t>(l)].set_interval(k);  // the Service refuses another interval before advancing
      coupler->advance(k, stats);
    }
  } catch (const std::invalid_argument&) {
  }
  return 0;
}
