#pragma once
// Helpers shared by the validation tests: load a case from cases/, run a level
// in memory (no run folder) and measure simple collisions.
#include <cmath>
#include <cstdint>
#include <string>

#include "config/case_parser.hpp"
#include "core/material.hpp"
#include "level/level.hpp"

namespace mlcg::test {

inline config::CaseSpec load(const std::string& rel) {
  return config::load_case(std::string(MLCG_SOURCE_DIR) + "/cases/" + rel);
}

// The quickstart hopper with `count` particles, its lid opened at `open_at` s whatever the bed does by then,
// and no snapshots: a short discharge whose events fall at known times.
inline config::CaseSpec timed_hopper(int64_t count, double open_at = 0.05) {
  auto cs = load("quickstart/case.toml");
  cs.insertions[0].count = count;
  cs.events[0].after_insertion = false;
  cs.events[0].mean_speed_below = -1.0;
  cs.events[0].at = open_at;
  cs.output.snapshot_interval = 0.0;
  return cs;
}

inline LevelOptions quiet() {
  LevelOptions o;
  o.quiet = true;
  return o;
}

// Undamped Hertz contact duration (the formula).
inline double hertz_time(double m_eff, double r_eff, double e_star, double v) {
  return 2.868 * std::pow(m_eff * m_eff / (r_eff * e_star * e_star * v), 0.2);
}

struct Impact {
  double restitution = 0.0;   // normal rebound speed / approach speed
  double contact_time = 0.0;  // interpolated from the gap crossing zero
  double ke_before = 0.0, ke_after = 0.0;
  bool separated = false;
};

// Steps `level` until a contact has started and ended. gap(level) is the surface
// distance (negative while overlapping); vn(level) the normal approach velocity (> 0 approaching).
template <class Gap, class Vn>
Impact measure_impact(Level& level, Gap gap, Vn vn, int max_steps = 200000) {
  Impact im;
  im.ke_before = level.kinetic_energy();
  const double v0 = vn(level);
  double g_prev = gap(level), t_prev = level.time();
  double t_start = -1.0;
  for (int s = 0; s < max_steps; ++s) {
    level.step_once();
    const double g = gap(level), t = level.time();
    if (t_start < 0.0 && g_prev >= 0.0 && g < 0.0) t_start = t_prev + (t - t_prev) * g_prev / (g_prev - g);
    if (t_start >= 0.0 && g_prev < 0.0 && g >= 0.0) {
      const double t_end = t_prev + (t - t_prev) * (-g_prev) / (g - g_prev);
      im.contact_time = t_end - t_start;
      im.separated = true;
      im.restitution = -vn(level) / v0;
      im.ke_after = level.kinetic_energy();
      return im;
    }
    g_prev = g;
    t_prev = t;
  }
  return im;
}

}  // namespace mlcg::test
