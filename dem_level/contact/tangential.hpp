#pragma once
// Tangential sub-models. Each exposes has_history and
//   eval(coeffs, dt, n, vt, sqrt_rd, q, fn, hist&) -> tangential force on i
// TangentialHistory: spring on the accumulated tangential overlap, rotated into
// the current contact plane every step, with damping while sticking; when the
// spring force exceeds mu|F_n| the stored overlap itself is truncated (Coulomb),
// as LIGGGHTS' `tangential_model history` does.
#include <cmath>

#include "contact/inline.hpp"
#include "core/material.hpp"
#include "core/vec3.hpp"

namespace mlcg {

struct NoTangential {
  static constexpr bool has_history = false;
  static constexpr const char* name = "none";
  static MLCG_INLINE Vec3 eval(const PairCoeffs&, double, const Vec3&, const Vec3&, double, double, double, Vec3&) {
    return {};
  }
};

struct TangentialHistory {
  static constexpr bool has_history = true;
  static constexpr const char* name = "history";

  static MLCG_INLINE Vec3 eval(const PairCoeffs& c, double dt, const Vec3& n, const Vec3& vt, double sqrt_rd,
                               double q, double fn, Vec3& hist) {
    // Rotate the stored overlap into the current tangent plane, keeping its
    // length: project, then scale by sqrt(1 + (h.n)^2 / |h_t|^2). Selects
    // instead of branches, so that a loop over contacts vectorizes.
    Vec3 h = hist;
    const double hn = dot(h, n);
    h -= hn * n;
    const double after = norm2(h);
    h *= after > 0.0 ? std::sqrt(1.0 + hn * hn / after) : 1.0;
    h += vt * dt;

    const double kt = 8.0 * c.g_star * sqrt_rd;
    const double fs = kt * std::sqrt(norm2(h));
    const double f_max = c.mu * std::fabs(fn);
    // sliding: the stored overlap is truncated to the Coulomb limit, no damping;
    // sticking: spring plus damping (written as products with 0/1, which GCC vectorizes)
    const bool sliding = fs > f_max;
    const double ratio = sliding ? f_max / fs : 1.0;
    const double damp = c.gt * q * (sliding ? 0.0 : 1.0);
    h *= ratio;
    hist = h;
    return -kt * h - damp * vt;
  }
};

}  // namespace mlcg
