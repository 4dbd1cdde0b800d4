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
  if (rebuild_pending_) rebuild();  // the lists must match the particles (e.g. before step 1)
  double e[4] = {0.0, 0.0, 0.0, 0.0};  // kinetic, potential, elastic, rotational
  const size_t n = p_.n_local();
  for (size_t i = 0; i < n; ++i) {
    e[0] += 0.5 * p_.mass[i] * norm2(p_.v[i]);
    e[3] += 0.5 / p_.inv_inertia[i] * norm2(p_.omega[i]);
    e[1] -= p_.mass[i] * dot(gravity_, p_.x[i]);
  }
  const bool hist = keep_history_ && nl_.hist.size() == nl_.neigh.size();
  for (size_t i = 0; i < n; ++i)
    for (int32_t k = nl_.first[i]; k < nl_.first[i + 1]; ++k) {
      const auto j = static_cast<size_t>(nl_.neigh[static_cast<size_t>(k)]);
      const double ri = p_.radius[i], rj = p_.radius[j];
      const double delta = ri + rj - norm(p_.x[i] - p_.x[j]);
      if (delta <= 0.0) continue;
      const Vec3 h = hist ? nl_.hist[static_cast<size_t>(k)] : Vec3{};
      // A pair across a rank border is held by both ranks (newton off): half each.
      const double share = j < n ? 1.0 : 0.5;
      e[2] += share * contact_energy(mt_.pair(p_.material[i], p_.material[j]), ri * rj / (ri + rj), delta, h);
    }
  const bool whist = keep_history_ && walls_.hist.size() == walls_.prim.size();
  constexpr int kMax = 16;
  TriangleMesh::Contact mc[kMax];
  std::vector<int32_t> tris;
  for (size_t i = 0; i < n; ++i) {
    const double r = p_.radius[i];
    for (int32_t k = walls_.first[i]; k < walls_.first[i + 1]; ++k) {
      const int32_t prim = walls_.prim[static_cast<size_t>(k)];
      const auto w = static_cast<size_t>(walls_.wall_of_prim(prim));
      const auto& info = walls_.info(w);
      const PairCoeffs& c = mt_.pair(p_.material[i], info.material);
      if (!info.is_mesh) {
        WallGeom g;
        if (info.active && walls_.analytic(prim).closest(p_.x[i], g) && g.dist < r)
          e[2] += contact_energy(c, r, r - g.dist, whist ? walls_.hist[static_cast<size_t>(k)] : Vec3{});
        continue;
      }
      // A mesh's candidates are contiguous; its contacts are the kernel's (one per distance minimum).
      int32_t stop = k;
      tris.clear();
      while (stop < walls_.first[i + 1] && walls_.prim[static_cast<size_t>(stop)] >= info.prim_begin &&
             walls_.prim[static_cast<size_t>(stop)] < info.prim_end)
        tris.push_back(walls_.prim[static_cast<size_t>(stop++)] - info.prim_begin);
      const int nc =
          info.active ? walls_.mesh(info.mesh).contacts(p_.x[i], r, tris.data(), static_cast<int>(tris.size()), mc, kMax)
                      : 0;
      for (int q = 0; q < nc; ++q)
        e[2] += contact_energy(c, r, r - mc[q].dist, whist ? walls_.hist[static_cast<size_t>(k + mc[q].owner)] : Vec3{});
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
