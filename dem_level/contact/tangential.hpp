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
    // length: project, then scale by sqrt(1 + e), e = (h.n)^2 / |h_t|^2. The
    // plane turns by ~1e-4 rad per step, so e is tiny and three terms of the
    // series are exact in double precision.
    Vec3 h = hist;
    const double hn = dot(h, n);
    if (hn != 0.0) {
      h -= hn * n;
      const double after = norm2(h);
      if (after > 0.0) {
        const double e = hn * hn / after;
        h *= e < 1e-6 ? 1.0 + e * (0.5 - 0.125 * e) : std::sqrt(1.0 + e);
      }
    }
    h += vt * dt;

    const double kt = 8.0 * c.g_star * sqrt_rd;
    Vec3 ft = -kt * h;
    const double fs2 = kt * kt * norm2(h);
    const double f_max = c.mu * std::fabs(fn);
    if (fs2 > f_max * f_max) {  // sliding: truncate the stored overlap
      const double ratio = f_max / std::sqrt(fs2);
      h *= ratio;
      ft *= ratio;
    } else {
      ft -= (c.gt * q) * vt;
    }
    hist = h;
    return ft;
  }
};

}  // namespace mlcg
