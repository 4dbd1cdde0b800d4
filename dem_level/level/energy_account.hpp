#pragma once
// A level's energy account ([output] energy_interval > 0): what the level's
// mechanical energy E = kinetic + rotational + potential + elastic did, against
// what crossed its borders, so that a gain the physics cannot explain shows:
//
//   gain(t) = E(t) - E(t0) - W_controller - W_walls - E_inserted + E_removed
//
// measured, not assumed. t0 is the first sample (the end of this process's first
// step). W_controller is the coupler's forces' work, sum F_c . v dt with v the
// full-step velocity after the second half kick (in velocity Verlet exactly the
// forces' share of the kinetic change between half steps). A particle carries in
// its kinetic, rotational and potential energy when it is added, and out the energy
// it held at the last step boundary when it is removed (removal comes after the
// drift: that state is taken back from the half step with gravity as the force of
// the step before, exact for a particle in free flight; a contact force on it costs
// that force x its half-step displacement). W_walls is what moving walls (a belt, a drum) put in: the sum
// of each contact's force on the particle times the wall surface's velocity there, times dt. The elastic
// energy of an overlap an insertion creates is not carried in: it shows as gain,
// which is what an insertion into a dense stream must be checked for. Damping,
// friction and a removed wall only lower the account; an instability raises it.
//
// Every method but sample() works on this rank's particles; sample() is
// collective and sums the ranks' shares. Off (no account) the level pays nothing.
#include <cstdint>
#include <string>
#include <vector>

#include "core/particles.hpp"
#include "parallel/comm.hpp"

namespace mlcg {

struct EnergyParts {
  double kinetic = 0.0, rotational = 0.0, potential = 0.0, elastic = 0.0;
  double total() const { return kinetic + rotational + potential + elastic; }
};

struct EnergyTotals {        // the account over this process's run, summed over the ranks [J]
  uint64_t samples = 0;
  double start = 0.0;        // E(t0)
  double controller_work = 0.0, inserted = 0.0, removed = 0.0;
  double wall_work = 0.0;    // by moving walls
  double max_gain = 0.0;     // largest gain(t) over the samples (>= 0: t0 has gain 0)
  double max_gain_time = 0.0;
  // Largest rise of gain(t) over any earlier sample: what a damped run's losses cannot hide
  // (gain(t) is cumulative, so losses early would mask an injection later; a rise does not).
  double max_rise = 0.0;
  double max_rise_time = 0.0;
  double in_motion = 0.0;    // largest kinetic + rotational + elastic seen: the scale of a gain
  double end_gain = 0.0;     // gain at the last sample
};

class EnergyAccount {
 public:
  EnergyAccount(uint64_t every_steps, const Vec3& gravity, double dt) : every_(every_steps), g_(gravity), dt_(dt) {}

  // At a step boundary (insertion).
  void carried_in(const Particles& p, size_t i) { in_ += own_energy(p.mass[i], p.inv_inertia[i], p.x[i], p.v[i], p.omega[i]); }
  // After the drift, before the step's forces (the rebuild's removal).
  void carried_out(const Particles& p, size_t i);
  // Around the controller forces: keep the forces before, then turn them into the controller's share.
  void before_controller(const Particles& p);
  void after_controller(const Particles& p);
  // After the second half kick: the controller forces' work over this step.
  void controller_work(const Particles& p, double dt);
  // After the forces: the moving walls' work over this step (their contacts' power, ContactStats::wall_power).
  void wall_work(double power, double dt) { walls_ += power * dt; }

  bool due(uint64_t step) const { return step >= next_; }
  // Collective: one row of the account at step `step` (time t) from the level's energy now.
  void sample(uint64_t step, double t, const EnergyParts& e, const Comm& comm);

  const EnergyTotals& totals() const { return tot_; }
  std::string csv() const;  // energy.csv: a header and one row per sample

 private:
  double own_energy(double m, double inv_inertia, const Vec3& x, const Vec3& v, const Vec3& omega) const;
  uint64_t every_, next_ = 0;
  Vec3 g_;
  double dt_;
  double in_ = 0.0, out_ = 0.0, work_ = 0.0, walls_ = 0.0;  // this rank's, since the last sample
  std::vector<Vec3> f_;                       // controller forces of this step (local particles)
  bool have_controller_ = false;
  EnergyTotals tot_;
  double min_gain_ = 0.0;  // the lowest gain so far
  std::vector<std::string> rows_;
};

}  // namespace mlcg
