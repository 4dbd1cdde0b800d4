#pragma once
// Particle-particle forces over the half neighbour list. Instantiated once per
// contact model and per "accumulate stress" choice, so a step without
// measurements or a model without history/rolling carries none of that code.
#include <algorithm>
#include <cmath>

#include "contact/model.hpp"
#include "core/material.hpp"
#include "core/particles.hpp"
#include "forces/contact_stats.hpp"
#include "neighbor/neighbor_list.hpp"

namespace mlcg {

// stress6: 6 values per particle (only read when Stress), branch r_ij/2 per Eq. 8.
template <class Model, bool Stress>
void pair_forces(Particles& p, NeighborList& nl, const MaterialTable& mt, double dt, double* stress6,
                 ContactStats& st) {
  const size_t n = p.n_local();
  const Vec3* x = p.x.data();
  const Vec3* v = p.v.data();
  const Vec3* w = p.omega.data();
  const double* rad = p.radius.data();
  const double* mass = p.mass.data();
  const int32_t* mat = p.material.data();
  Vec3* f = p.f.data();
  Vec3* t = p.torque.data();
  const int32_t* neigh = nl.neigh.data();
  Vec3* hist = Model::has_history ? nl.hist.data() : nullptr;
  const int nmat = mt.size();
  const PairCoeffs* coeffs = mt.pairs().data();

  double worst = st.max_overlap_ratio;
  int32_t worst_i = st.worst_particle;
  int64_t contacts = 0;

  for (size_t i = 0; i < n; ++i) {
    const Vec3 xi = x[i], vi = v[i], wi = w[i];
    const double ri = rad[i], mi = mass[i];
    const PairCoeffs* row = coeffs + mat[i] * nmat;
    Vec3 fi{}, ti{};
    for (int32_t k = nl.first[i], end = nl.first[i + 1]; k < end; ++k) {
      const auto j = static_cast<size_t>(neigh[k]);
      const Vec3 d = xi - x[j];
      const double rsq = norm2(d);
      const double rj = rad[j];
      const double radsum = ri + rj;
      if (rsq >= radsum * radsum) {
        // Only pairs that touched last step hold history: avoid the store otherwise.
        if constexpr (Model::has_history)
          if (hist[k].x != 0.0 || hist[k].y != 0.0 || hist[k].z != 0.0) hist[k] = Vec3{};
        continue;
      }
      const double r = std::sqrt(rsq);
      ContactInput in;
      in.n = d * (1.0 / r);
      in.delta = radsum - r;
      const double mj = mass[j];
      in.m_eff = mi * mj / (mi + mj);
      in.r_eff = ri * rj / radsum;
      in.v_rel = vi - v[j] - cross(ri * wi + rj * w[j], in.n);
      if constexpr (Model::has_rolling) in.w_rel = wi - w[j];
      Vec3 dummy{};
      const ContactForce cf = Model::eval(row[mat[j]], dt, in, Model::has_history ? hist[k] : dummy);
      fi += cf.force;
      f[j] -= cf.force;
      const Vec3 tor = cross(in.n, cf.ft);
      ti -= ri * tor;
      t[j] -= rj * tor;
      if constexpr (Model::has_rolling) {
        ti += cf.roll;
        t[j] -= cf.roll;
      }
      const double rmin = std::min(ri, rj);
      if (in.delta > worst * rmin) {  // divide only for a new largest overlap
        worst = in.delta / rmin;
        worst_i = static_cast<int32_t>(i);
      }
      ++contacts;
      if constexpr (Stress) {
        const Vec3 half = 0.5 * d;
        add_dyad(stress6 + 6 * i, half, cf.force);
        add_dyad(stress6 + 6 * j, half, cf.force);  // (-d/2) x (-F)
      }
    }
    f[i] += fi;
    t[i] += ti;
  }
  st.max_overlap_ratio = worst;
  st.worst_particle = worst_i;
  st.pair_contacts += contacts;
}

}  // namespace mlcg
