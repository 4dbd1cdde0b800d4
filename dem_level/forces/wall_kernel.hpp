#pragma once
// Particle-wall forces over each particle's wall candidates. A wall has
// R = m = infinity, so R* = r and m* = m. Analytic walls give at most one
// contact each; a mesh gives one per local minimum of the distance (see
// TriangleMesh::contacts), so a sphere rolling over a flat triangulated floor
// feels one contact, and its tangential history follows it from triangle to
// triangle.
#include <algorithm>
#include <cmath>
#include <vector>

#include "contact/model.hpp"
#include "core/material.hpp"
#include "core/particles.hpp"
#include "forces/contact_stats.hpp"
#include "walls/wall_set.hpp"

namespace mlcg {

namespace detail {

// v_wall: the wall surface's velocity at the contact point; null for a wall at rest, which then costs nothing.
template <class Model, bool Stress>
inline void wall_contact(size_t i, const Particles& p, const Vec3& point, const Vec3& n, double dist,
                         const PairCoeffs& c, double dt, const Vec3* v_wall, Vec3& hist, Vec3& fi, Vec3& ti,
                         Vec3& wall_force, double* stress6, ContactStats& st) {
  const double ri = p.radius[i];
  ContactInput in;
  in.n = n;
  in.delta = ri - dist;
  in.r_eff = ri;
  in.m_eff = p.mass[i];
  in.v_rel = p.v[i] - ri * cross(p.omega[i], n);
  if (v_wall) in.v_rel -= *v_wall;
  if constexpr (Model::has_rolling) in.w_rel = p.omega[i];
  const ContactForce cf = Model::eval(c, dt, in, hist);
  fi += cf.force;
  ti -= ri * cross(n, cf.ft);
  if constexpr (Model::has_rolling) ti += cf.roll;
  wall_force -= cf.force;
  if (v_wall) st.wall_power += dot(cf.force, *v_wall);
  if (in.delta > st.max_overlap_ratio * ri) {  // divide only for a new largest overlap
    st.max_overlap_ratio = in.delta / ri;
    st.worst_particle = static_cast<int32_t>(i);
  }
  ++st.wall_contacts;
  if constexpr (Stress) add_dyad(stress6 + 6 * i, p.x[i] - point, cf.force);
}

// A mesh contact keeps its overlap in its owner's slot (of the particle's `slots` candidate triangles of
// that mesh, from `hist` on); a contact whose owner slot is empty inherits a slot that lost its contact
// (the particle moved on to a neighbouring triangle or feature); slots without a contact are cleared.
template <int kMaxContacts>
inline void hand_over_mesh_history(Vec3* hist, int slots, const TriangleMesh::Contact* mc, int nc) {
  bool owner[kMaxContacts * 4] = {};
  const int span = std::min<int>(slots, kMaxContacts * 4);
  for (int c = 0; c < nc; ++c)
    if (mc[c].owner < span) owner[mc[c].owner] = true;
  for (int c = 0; c < nc; ++c) {
    Vec3& slot = hist[mc[c].owner];
    if (!(slot == Vec3{})) continue;
    for (int s = 0; s < span; ++s) {
      Vec3& other = hist[s];
      if (!owner[s] && !(other == Vec3{})) {
        slot = other;
        other = Vec3{};
        break;
      }
    }
  }
  for (int s = 0; s < slots; ++s)
    if (s >= span || !owner[s]) hist[s] = Vec3{};
}

}  // namespace detail

// wall_force: one entry per wall, receives the total force the particles exert on it.
template <class Model, bool Stress>
void wall_forces(Particles& p, WallSet& ws, const MaterialTable& mt, double dt, double* stress6,
                 std::vector<Vec3>& wall_force, ContactStats& st) {
  constexpr int kMaxMeshContacts = 16;
  wall_force.assign(ws.walls(), Vec3{});
  const int32_t n_analytic = ws.analytic_count();
  Vec3 dummy{};
  static thread_local std::vector<int32_t> tris;
  TriangleMesh::Contact mc[kMaxMeshContacts];

  for (const int32_t near : ws.near) {
    const auto i = static_cast<size_t>(near);
    const int32_t begin = ws.first[i], end = ws.first[i + 1];
    const Vec3 xi = p.x[i];
    const double ri = p.radius[i];
    const int mi = p.material[i];
    Vec3 fi{}, ti{};
    for (int32_t k = begin; k < end; ++k) {
      const int32_t prim = ws.prim[static_cast<size_t>(k)];
      Vec3& h = Model::has_history ? ws.hist[static_cast<size_t>(k)] : dummy;
      if (prim < n_analytic) {
        const int w = ws.wall_of_prim(prim);
        WallGeom g;
        if (!ws.active(static_cast<size_t>(w)) || !ws.analytic(prim).closest(xi, g) || g.dist >= ri) {
          h = Vec3{};
          continue;
        }
        const auto& info = ws.info(static_cast<size_t>(w));
        const Vec3 vw = info.moving ? ws.velocity_at(static_cast<size_t>(w), g.point) : Vec3{};
        detail::wall_contact<Model, Stress>(i, p, g.point, g.n, g.dist, mt.pair(mi, info.material), dt,
                                            info.moving ? &vw : nullptr, h, fi, ti, wall_force[static_cast<size_t>(w)],
                                            stress6, st);
        continue;
      }
      // A mesh: its candidate triangles for this particle are contiguous.
      const int w = ws.wall_of_prim(prim);
      const auto& info = ws.info(static_cast<size_t>(w));
      int32_t stop = k;
      tris.clear();
      while (stop < end && ws.prim[static_cast<size_t>(stop)] >= info.prim_begin &&
             ws.prim[static_cast<size_t>(stop)] < info.prim_end) {
        tris.push_back(ws.prim[static_cast<size_t>(stop)] - info.prim_begin);
        ++stop;
      }
      // A rigidly moving mesh: the contacts are found in its own frame, then turned back.
      const int nc = info.active ? ws.mesh(info.mesh).contacts(info.to_body(xi), ri, tris.data(),
                                                               static_cast<int>(tris.size()), mc, kMaxMeshContacts)
                                 : 0;
      if (info.rigid)
        for (int q = 0; q < nc; ++q) {
          mc[q].point = info.to_world(mc[q].point);
          mc[q].normal = info.turn(mc[q].normal);
        }
      if constexpr (Model::has_history) detail::hand_over_mesh_history<kMaxMeshContacts>(ws.hist.data() + k, stop - k, mc, nc);
      const PairCoeffs& c = mt.pair(mi, info.material);
      for (int q = 0; q < nc; ++q) {
        Vec3& hq = Model::has_history ? ws.hist[static_cast<size_t>(k + mc[q].owner)] : dummy;
        const Vec3 vw = info.moving ? ws.velocity_at(static_cast<size_t>(w), mc[q].point) : Vec3{};
        detail::wall_contact<Model, Stress>(i, p, mc[q].point, mc[q].normal, mc[q].dist, c, dt,
                                            info.moving ? &vw : nullptr, hq, fi, ti, wall_force[static_cast<size_t>(w)],
                                            stress6, st);
      }
      k = stop - 1;
    }
    p.f[i] += fi;
    p.torque[i] += ti;
  }
}

}  // namespace mlcg
