#include "level/energy_account.hpp"

#include <algorithm>

#include <fmt/format.h>

namespace mlcg {

double EnergyAccount::own_energy(double m, double inv_inertia, const Vec3& x, const Vec3& v, const Vec3& omega) const {
  return 0.5 * m * norm2(v) + 0.5 / inv_inertia * norm2(omega) - m * dot(g_, x);
}

void EnergyAccount::carried_out(const Particles& p, size_t i) {
  // Back from (x(t+dt), v(t+dt/2)) to (x(t), v(t)): the drift and the first half kick undone, the kick
  // with gravity alone (the first half kick has already replaced the contact forces by gravity).
  const Vec3 v = p.v[i] - (0.5 * dt_) * g_;
  out_ += own_energy(p.mass[i], p.inv_inertia[i], p.x[i] - dt_ * p.v[i], v, p.omega[i]);
}

void EnergyAccount::before_controller(const Particles& p) {
  f_.assign(p.f.begin(), p.f.begin() + static_cast<std::ptrdiff_t>(p.n_local()));
}

void EnergyAccount::after_controller(const Particles& p) {
  for (size_t i = 0; i < f_.size(); ++i) f_[i] = p.f[i] - f_[i];
  have_controller_ = true;
}

void EnergyAccount::controller_work(const Particles& p, double dt) {
  if (!have_controller_) return;
  double w = 0.0;
  for (size_t i = 0; i < f_.size(); ++i) w += dot(f_[i], p.v[i]);
  work_ += w * dt;
  have_controller_ = false;
}

void EnergyAccount::sample(uint64_t step, double t, const EnergyParts& e, const Comm& comm) {
  next_ = step + every_;
  double flows[4] = {work_, in_, out_, walls_};
  comm.sum_in_place(flows, 4);
  work_ = in_ = out_ = walls_ = 0.0;
  if (tot_.samples == 0) {
    tot_.start = e.total();  // what flowed during the first step is inside E(t0)
  } else {
    tot_.controller_work += flows[0];
    tot_.inserted += flows[1];
    tot_.removed += flows[2];
    tot_.wall_work += flows[3];
  }
  ++tot_.samples;
  const double gain = e.total() - tot_.start - tot_.controller_work - tot_.wall_work - tot_.inserted + tot_.removed;
  if (gain > tot_.max_gain) {
    tot_.max_gain = gain;
    tot_.max_gain_time = t;
  }
  min_gain_ = std::min(min_gain_, gain);
  if (gain - min_gain_ > tot_.max_rise) {
    tot_.max_rise = gain - min_gain_;
    tot_.max_rise_time = t;
  }
  tot_.in_motion = std::max(tot_.in_motion, e.kinetic + e.rotational + e.elastic);
  tot_.end_gain = gain;
  rows_.push_back(fmt::format("{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g}", t, e.kinetic,
                              e.rotational, e.potential, e.elastic, tot_.controller_work, tot_.inserted, tot_.removed,
                              gain, tot_.wall_work));
}

std::string EnergyAccount::csv() const {
  std::string s = "t,kinetic_J,rotational_J,potential_J,elastic_J,controller_work_J,inserted_J,removed_J,gain_J,wall_work_J\n";
  for (const auto& r : rows_) s += r + "\n";
  return s;
}

}  // namespace mlcg
