#pragma once
// Whether a time step divides a coupling interval, in one place for the case
// parser, the coupler and the levels.
#include <cmath>
#include <cstdint>

namespace mlcg {

// Steps of length dt in `interval` when dt divides it (interval / dt is a whole
// number from 1 to 2^63 within 1e-9 relative), else 0. (A coupler's Welcome may
// carry any interval: beyond 2^63 steps the conversion would be undefined.)
inline uint64_t whole_steps(double interval, double dt) {
  if (!(dt > 0.0) || !(interval > 0.0)) return 0;
  const double r = interval / dt, k = std::round(r);
  return k >= 1.0 && k <= 0x1p63 && std::fabs(r - k) <= 1e-9 * r ? static_cast<uint64_t>(k) : 0;
}

}  // namespace mlcg
