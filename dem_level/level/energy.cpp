// The level's mechanical energy, for stability tests and the energy account
// (called by the time loop only when [output] energy_interval asks): kinetic,
// rotational, gravitational potential -m g.x, and the elastic energy stored in
// the contacts, so that "no energy gain beyond the work of gravity" can be
// measured on any scene.
#include <cmath>

#include "level/level.hpp"

namespace mlcg {

namespace {

// Work stored in one contact: the Hertz spring, the integral of 4/3 E* sqrt(R*) d^(3/2)
// = 8/15 E* sqrt(R*) d^(5/2), and the tangential spring 1/2 k_t |h|^2 with k_t = 8 G* sqrt(R* d).
double contact_energy(const PairCoeffs& c, double r_eff, double delta, const Vec3& h) {
  const double sqrt_rd = std::sqrt(r_eff * delta);
  return (8.0 / 15.0) * c.e_star * sqrt_rd * delta * delta + 4.0 * c.g_star * sqrt_rd * norm2(h);
}

}  // namespace

Level::Energy Level::energy() {
  if (stepper_.rebuild_pending) rebuild();  // the lists must match the particles (e.g. before step 1)
  const Particles& p = state_.p;
  const NeighborList& nl = state_.nl;
  const WallSet& walls = state_.walls;
  double e[4] = {0.0, 0.0, 0.0, 0.0};  // kinetic, potential, elastic, rotational
  const size_t n = p.n_local();
  for (size_t i = 0; i < n; ++i) {
    e[0] += 0.5 * p.mass[i] * norm2(p.v[i]);
    e[3] += 0.5 / p.inv_inertia[i] * norm2(p.omega[i]);
    e[1] -= p.mass[i] * dot(physics_.gravity, p.x[i]);
  }
  const bool hist = stepper_.keep_history && nl.hist.size() == nl.neigh.size();
  for (size_t i = 0; i < n; ++i)
    for (int32_t k = nl.first[i]; k < nl.first[i + 1]; ++k) {
      const auto j = static_cast<size_t>(nl.neigh[static_cast<size_t>(k)]);
      const double ri = p.radius[i], rj = p.radius[j];
      const double delta = ri + rj - norm(p.x[i] - p.x[j]);
      if (delta <= 0.0) continue;
      const Vec3 h = hist ? nl.hist[static_cast<size_t>(k)] : Vec3{};
      // A pair across a rank border is held by both ranks (newton off): half each.
      const double share = j < n ? 1.0 : 0.5;
      e[2] += share * contact_energy(physics_.mt.pair(p.material[i], p.material[j]), ri * rj / (ri + rj), delta, h);
    }
  const bool whist = stepper_.keep_history && walls.hist.size() == walls.prim.size();
  constexpr int kMax = 16;
  TriangleMesh::Contact mc[kMax];
  std::vector<int32_t> tris;
  for (size_t i = 0; i < n; ++i) {
    const double r = p.radius[i];
    for (int32_t k = walls.first[i]; k < walls.first[i + 1]; ++k) {
      const int32_t prim = walls.prim[static_cast<size_t>(k)];
      const auto w = static_cast<size_t>(walls.wall_of_prim(prim));
      const auto& info = walls.info(w);
      const PairCoeffs& c = physics_.mt.pair(p.material[i], info.material);
      if (!info.is_mesh) {
        WallGeom g;
        if (info.active && walls.analytic(prim).closest(p.x[i], g) && g.dist < r)
          e[2] += contact_energy(c, r, r - g.dist, whist ? walls.hist[static_cast<size_t>(k)] : Vec3{});
        continue;
      }
      // A mesh's candidates are contiguous; its contacts are the kernel's (one per distance minimum).
      int32_t stop = k;
      tris.clear();
      while (stop < walls.first[i + 1] && walls.prim[static_cast<size_t>(stop)] >= info.prim_begin &&
             walls.prim[static_cast<size_t>(stop)] < info.prim_end)
        tris.push_back(walls.prim[static_cast<size_t>(stop++)] - info.prim_begin);
      const int nc =
          info.active ? walls.mesh(info.mesh).contacts(p.x[i], r, tris.data(), static_cast<int>(tris.size()), mc, kMax)
                      : 0;
      for (int q = 0; q < nc; ++q)
        e[2] += contact_energy(c, r, r - mc[q].dist, whist ? walls.hist[static_cast<size_t>(k + mc[q].owner)] : Vec3{});
      k = stop - 1;
    }
  }
  comm_.sum_in_place(e, 4);
  Energy out;
  out.kinetic = e[0];
  out.rotational = e[3];
  out.potential = e[1];
  out.elastic = e[2];
  return out;
}

}  // namespace mlcg
