#pragma once
// What the tests of the level's side of the coupling share: a coupling grid of whole active boxes, particles
// placed by hand, and a drift of their positions (test_grid_link.cpp, test_coupling_client.cpp).
#include <cstdint>
#include <vector>

#include "core/particles.hpp"
#include "mlcg/bus.pb.h"

namespace mlcg::test {

inline constexpr double kRho = 1000.0;

inline mlcg::bus::CouplingGrid make_grid(Vec3 o, double h, uint32_t nx, uint32_t ny, uint32_t nz,
                                         std::vector<double> bins = {}) {
  mlcg::bus::CouplingGrid g;
  g.set_ox(o.x);
  g.set_oy(o.y);
  g.set_oz(o.z);
  g.set_cell_size(h);
  g.set_nx(nx);
  g.set_ny(ny);
  g.set_nz(nz);
  for (uint32_t c = 0; c < nx * ny * nz; ++c) g.add_cells(c);
  for (double b : bins) g.add_radius_bins(b);
  return g;
}

inline void add(Particles& p, Vec3 x, double r, Vec3 v = {}) {
  ParticleInit pi;
  pi.id = static_cast<int64_t>(p.size());
  pi.radius = r;
  pi.density = kRho;
  pi.x = x;
  pi.v = v;
  p.add(pi);
}

inline void drift(Particles& p, double dt) {
  for (size_t i = 0; i < p.n_local(); ++i) p.x[i] += dt * p.v[i];
}

}  // namespace mlcg::test
