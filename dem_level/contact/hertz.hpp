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

#include "core/material.hpp"

namespace mlcg {

template <bool Clamp>
struct HertzNormal {
  static constexpr bool clamps = Clamp;

  struct Result {
    double fn;       // signed normal force along n (positive = repulsive)
    double sqrt_rd;  // sqrt(R* d), reused by the tangential model
  };

  static inline Result eval(const PairCoeffs& c, double delta, double r_eff, double m_eff, double vn) {
    const double sqrt_rd = std::sqrt(r_eff * delta);
    const double kn = (4.0 / 3.0) * c.e_star * sqrt_rd;
    const double gamma_n = -c.beta * std::sqrt(5.0 * m_eff * kn);
    double fn = kn * delta - gamma_n * vn;
    if constexpr (Clamp) fn = std::max(fn, 0.0);
    return {fn, sqrt_rd};
  }
};

}  // namespace mlcg
