#pragma once
// A contact model is composed at compile time from sub-models, the way
// MercuryDPM composes Species<Normal, Friction, Adhesive>: the kernels are
// templates on the model, so a scene without rolling friction or without
// tangential history compiles to code that contains neither.
#include "contact/hertz.hpp"
#include "contact/rolling.hpp"
#include "contact/tangential.hpp"
#include "core/vec3.hpp"

namespace mlcg {

// Input of one contact, seen from particle i. n points from the partner to i.
struct ContactInput {
  Vec3 n;
  double delta;   // overlap > 0
  double r_eff;
  double m_eff;
  Vec3 v_rel;     // velocity of i's contact point minus the partner's
  Vec3 w_rel;     // omega_i - omega_partner (rolling models only)
};

struct ContactForce {
  Vec3 force;      // total force on i
  Vec3 ft;         // tangential part of it (for the torque)
  Vec3 roll;       // rolling torque on i (partner gets the opposite)
  double fn;       // signed normal force
};

template <class NormalT, class TangentialT, class RollingT>
struct ContactModel {
  using Normal = NormalT;
  using Tangential = TangentialT;
  using Rolling = RollingT;
  static constexpr bool has_history = Tangential::has_history;
  static constexpr bool has_rolling = Rolling::active;

  // The same law with the results written through references: a returned
  // aggregate keeps the compiler from vectorizing a loop over contacts.
  static MLCG_INLINE void eval_into(const PairCoeffs& c, double dt, const ContactInput& in, Vec3& hist, Vec3& force,
                                    Vec3& ft, Vec3& roll, double& fn) {
    const double vn = dot(in.v_rel, in.n);
    const auto nr = Normal::eval(c, in.delta, in.r_eff, in.m_eff, vn);
    const Vec3 vt = in.v_rel - vn * in.n;
    ft = Tangential::eval(c, dt, in.n, vt, nr.sqrt_rd, nr.q, nr.fn, hist);
    if constexpr (has_rolling) roll = Rolling::eval(c, in.r_eff, nr.fn, in.w_rel);
    force = nr.fn * in.n + ft;
    fn = nr.fn;
  }

  static MLCG_INLINE ContactForce eval(const PairCoeffs& c, double dt, const ContactInput& in, Vec3& hist) {
    ContactForce out{};
    eval_into(c, dt, in, hist, out.force, out.ft, out.roll, out.fn);
    return out;
  }
};

// The run-time choice a case makes; resolved once into one of the
// instantiations in level/force_dispatch.cpp.
struct ContactChoice {
  bool tangential_history = true;
  bool rolling_cdt = false;
  bool clamp_normal = false;
};

}  // namespace mlcg
