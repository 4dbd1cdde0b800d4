#pragma once
// The two controllers of the MLCG coupling (paper section 2.3), one instance per
// coupling cell. Both are plain value types updated once per coupling interval.
#include <algorithm>
#include <cmath>

#include "core/vec3.hpp"

namespace mlcg::coupling {

// Discrete PI controller on a transition cell's normal stress along the
// boundary normal. Output: traction [Pa] pressed on the fine particles at the
// boundary surface, in [0, limit] (granular matter takes no tension, so the
// boundary only pushes). Anti-windup by conditional integration: the integral
// does not grow while the output is saturated in the error's direction.
struct PiController {
  double kp = 0.5, ki = 200.0, limit = 1e4;
  double integral = 0.0;  // Pa s
  double output = 0.0;    // Pa

  double update(double setpoint, double measured, double dt) {
    const double e = setpoint - measured;
    const double trial = integral + e * dt;
    const double u = kp * e + ki * trial;
    if (u > limit) {
      output = limit;
      if (e < 0.0) integral = trial;
    } else if (u < 0.0) {
      output = 0.0;
      if (e > 0.0) integral = trial;
    } else {
      output = u;
      integral = trial;
    }
    return output;
  }
  // An empty cell (no coarse setpoint or no fine particles to push) holds nothing.
  void hold() { integral = 0.0; output = 0.0; }
};

// PI controller pushing a coarse correction cell's mean velocity toward the
// target from the fine level. Output: an acceleration [m/s^2] the coarse level
// applies to every particle in the cell, |a| <= limit. The integral removes the
// lag a proportional term alone leaves where the coarse particles resist the
// correction (they jam at an orifice the fine ones pass: steep_cone -4.8 %
// without it, -1.0 % with it). The caller keeps one integral per cell; it does
// not grow while the output is saturated (anti-windup).
struct VelocityController {
  double gain = 500.0;   // 1/s
  double ki = 25000.0;   // 1/s^2; <= gain^2 / 4 keeps the loop on an integrator plant overdamped
  double limit = 49.05;  // m/s^2

  Vec3 update(const Vec3& target, const Vec3& coarse, Vec3& integral, double dt) const {
    const Vec3 e = target - coarse;
    const Vec3 trial = integral + e * dt;
    Vec3 a = gain * e + ki * trial;
    const double n = norm(a);
    if (n > limit) a = a * (limit / n);
    else integral = trial;
    return a;
  }
};

// Target velocity of a coarse correction cell: the fine Favre velocity, or,
// where the mass flow is corrected, that velocity times phi_fine / phi_coarse
// so that the coarse level carries the fine level's mass flux.
inline Vec3 correction_target(const Vec3& v_fine, double phi_fine, double phi_coarse, bool mass_flow) {
  if (!mass_flow || phi_coarse <= 0.0) return v_fine;
  return v_fine * (phi_fine / phi_coarse);
}

}  // namespace mlcg::coupling
