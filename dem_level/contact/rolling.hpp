#pragma once
// Rolling-resistance sub-models. NoRolling computes nothing (and is the
// default); RollingCDT is the constant directional torque model of LIGGGHTS'
// `rolling_friction cdt`: M_r = -mu_r R* |F_n| w_rel / |w_rel| on particle i.
#include <cmath>

#include "contact/inline.hpp"
#include "core/material.hpp"
#include "core/vec3.hpp"

namespace mlcg {

struct NoRolling {
  static constexpr bool active = false;
  static constexpr const char* name = "none";
  static MLCG_INLINE Vec3 eval(const PairCoeffs&, double, double, const Vec3&) { return {}; }
};

struct RollingCDT {
  static constexpr bool active = true;
  static constexpr const char* name = "cdt";
  static MLCG_INLINE Vec3 eval(const PairCoeffs& c, double r_eff, double fn, const Vec3& w_rel) {
    const double wmag = std::sqrt(norm2(w_rel));
    const double spinning = wmag > 0.0 ? 1.0 : 0.0;  // a product with 0/1 vectorizes, a branch does not
    return w_rel * (-c.mu_roll * r_eff * std::fabs(fn) * spinning / (wmag + (1.0 - spinning)));
  }
};

}  // namespace mlcg
