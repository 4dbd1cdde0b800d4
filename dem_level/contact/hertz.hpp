#pragma once
// Hertz normal force with the damping of the paper (Tsuji 1992 / Antypov &
// Elliott 2011), DESIGN.md §2:
//   k_n = 4/3 E* sqrt(R* d),  gamma_n = -beta sqrt(5 m* k_n),
//   F_n = k_n d - gamma_n v_n      (v_n < 0 while approaching)
// The force is not clamped at zero by default: it turns slightly attractive at
// the end of a damped contact, as in LIGGGHTS, which makes the restitution
// equal e for this damping law. Clamp = true gives the clamped variant.
#include <algorithm>
#include <cmath>

#include "contact/inline.hpp"
#include "core/material.hpp"

namespace mlcg {

template <bool Clamp>
struct HertzNormal {
  static constexpr bool clamps = Clamp;

  struct Result {
    double fn;       // signed normal force along n (positive = repulsive)
    double sqrt_rd;  // sqrt(R* d), reused by the tangential model
    double q;        // sqrt(m* sqrt(R* d)): gamma = prefactor * q (see PairCoeffs)
  };

  static MLCG_INLINE Result eval(const PairCoeffs& c, double delta, double r_eff, double m_eff, double vn) {
    const double sqrt_rd = std::sqrt(r_eff * delta);
    const double q = std::sqrt(m_eff * sqrt_rd);
    const double kn = (4.0 / 3.0) * c.e_star * sqrt_rd;
    double fn = kn * delta - c.gn * q * vn;
    if constexpr (Clamp) fn = std::max(fn, 0.0);
    return {fn, sqrt_rd, q};
  }
};

}  // namespace mlcg
