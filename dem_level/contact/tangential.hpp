#pragma once
// Tangential sub-models. Each exposes has_history and
//   eval(coeffs, dt, n, vt, sqrt_rd, m_eff, fn, hist&) -> tangential force on i
// TangentialHistory: spring on the accumulated tangential overlap, rotated into
// the current contact plane every step, with damping while sticking; when the
// spring force exceeds mu|F_n| the stored overlap itself is truncated (Coulomb),
// as LIGGGHTS' `tangential_model history` does.
#include <cmath>

#include "core/material.hpp"
#include "core/vec3.hpp"

namespace mlcg {

struct NoTangential {
  static constexpr bool has_history = false;
  static constexpr const char* name = "none";
  static inline Vec3 eval(const PairCoeffs&, double, const Vec3&, const Vec3&, double, double, double, Vec3&) {
    return {};
  }
};

struct TangentialHistory {
  static constexpr bool has_history = true;
  static constexpr const char* name = "history";

  static inline Vec3 eval(const PairCoeffs& c, double dt, const Vec3& n, const Vec3& vt, double sqrt_rd,
                          double m_eff, double fn, Vec3& hist) {
    // Rotate the stored overlap into the current tangent plane, keeping its length.
    Vec3 h = hist;
    const double hn = dot(h, n);
    if (hn != 0.0) {
      const double before = norm2(h);
      h -= hn * n;
      const double after = norm2(h);
      if (after > 0.0) h *= std::sqrt(before / after);
    }
    h += vt * dt;

    const double kt = 8.0 * c.g_star * sqrt_rd;
    Vec3 ft = -kt * h;
    const double f_spring = kt * std::sqrt(norm2(h));
    const double f_max = c.mu * std::fabs(fn);
    if (f_spring > f_max) {
      const double ratio = f_max / f_spring;  // f_spring > 0 here
      h *= ratio;
      ft *= ratio;
    } else {
      const double gamma_t = -c.beta * std::sqrt((10.0 / 3.0) * m_eff * kt);
      ft -= gamma_t * vt;
    }
    hist = h;
    return ft;
  }
};

}  // namespace mlcg
