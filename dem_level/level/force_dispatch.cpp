#include "level/force_dispatch.hpp"

#include <algorithm>

#include "forces/pair_kernel.hpp"
#include "forces/wall_kernel.hpp"

namespace mlcg {

namespace {

template <class Model>
void compute(ForceContext& c, bool with_stress) {
  c.stats = ContactStats{};
  if (with_stress) {
    c.stress6.assign(6 * c.p.size(), 0.0);
    pair_forces<Model, true>(c.p, c.nl, c.mt, c.dt, c.stress6.data(), c.stats);
    wall_forces<Model, true>(c.p, c.walls, c.mt, c.dt, c.stress6.data(), c.wall_force, c.stats);
  } else {
    pair_forces<Model, false>(c.p, c.nl, c.mt, c.dt, nullptr, c.stats);
    wall_forces<Model, false>(c.p, c.walls, c.mt, c.dt, nullptr, c.wall_force, c.stats);
  }
}

template <bool Clamp, class Tangential>
ForceRoutine pick_rolling(bool cdt) {
  if (cdt) return &compute<ContactModel<HertzNormal<Clamp>, Tangential, RollingCDT>>;
  return &compute<ContactModel<HertzNormal<Clamp>, Tangential, NoRolling>>;
}

template <bool Clamp>
ForceRoutine pick_tangential(const ContactChoice& c) {
  if (c.tangential_history) return pick_rolling<Clamp, TangentialHistory>(c.rolling_cdt);
  return pick_rolling<Clamp, NoTangential>(c.rolling_cdt);
}

}  // namespace

ForceRoutine select_force_routine(const ContactChoice& c) {
  return c.clamp_normal ? pick_tangential<true>(c) : pick_tangential<false>(c);
}

bool model_keeps_history(const ContactChoice& c) { return c.tangential_history; }

}  // namespace mlcg
