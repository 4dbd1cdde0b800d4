#pragma once
// Running a stability scene while measuring its mechanical energy (kinetic +
// gravitational potential + elastic contact energy, Level::energy) after every
// step. Gravity is the only force doing work and its work is the drop of the
// potential, so the total must not grow: a gain is the integrator's error.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>

#include "scene_support.hpp"

namespace mlcg::test {

struct EnergyRun {
  double e_ref = 0.0;     // total energy once every particle is in (after the insertion at t = 0)
  double max_gain = 0.0;  // largest total(t) - e_ref
  double scale = 0.0;     // largest kinetic + elastic energy seen: the energy in motion
  double e_end = 0.0;
  bool finite = true;
  int64_t particles = 0;  // present after the last insertion
  int64_t particles_end = 0;
  uint64_t steps = 0;
  std::string stop;       // the guard's message if the run stopped
  double gain() const { return max_gain / scale; }
};

// Steps the level to its end time (at most max_steps), measuring after every step.
inline EnergyRun run_measuring_energy(Level& level, uint64_t max_steps = 200000) {
  EnergyRun r;
  const auto steps = std::min<uint64_t>(max_steps, static_cast<uint64_t>(std::llround(level.end_time() / level.dt())));
  bool have_ref = false;
  int64_t last_inserted = 0;
  double last_total = 0.0;
  for (uint64_t s = 0; s <= steps; ++s) {
    if (s > 0) {
      try {
        level.step_once();
      } catch (const GuardStop& e) {
        r.stop = e.what();
        break;
      }
    }
    const Level::Energy e = level.energy();
    const int64_t present = level.mass_balance().present;
    if (!std::isfinite(e.total())) {
      r.finite = false;
      break;
    }
    // Inserted particles bring their own energy: the reference moves by what the step of an
    // insertion added (the reference starts with the first particles).
    const int64_t inserted = level.mass_balance().inserted;
    if (!have_ref && (present > 0 || s == steps)) {
      have_ref = true;
      r.e_ref = e.total();
    } else if (have_ref && inserted != last_inserted) {
      r.e_ref += e.total() - last_total;
    }
    if (inserted != last_inserted) r.particles = present;
    last_inserted = inserted;
    last_total = e.total();
    r.max_gain = std::max(r.max_gain, e.total() - r.e_ref);
    r.scale = std::max(r.scale, e.kinetic + e.rotational + e.elastic);
    r.e_end = e.total();
    r.particles_end = present;
    r.steps = s;
  }
  return r;
}

}  // namespace mlcg::test
