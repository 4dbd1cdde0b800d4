#include "measure/cell_grid.hpp"

#include <algorithm>
#include <cmath>

#include "core/spheres.hpp"
#include "forces/contact_stats.hpp"

namespace mlcg {

CellGrid::CellGrid(GridParams prm) : prm_(std::move(prm)) {
  const size_t n = prm_.cells();
  st_.phi.assign(n, 0.0);
  st_.mass.assign(n, 0.0);
  st_.max_speed.assign(n, 0.0);
  st_.stress6.assign(6 * n, 0.0);
  st_.count.assign(n, 0.0);
  st_.momentum.assign(n, Vec3{});
}

void CellGrid::local_sample(const Particles& p, const std::vector<double>& stress6, std::vector<double>& sums,
                            std::vector<double>& max_speed, const std::vector<uint32_t>* only) const {
  const size_t nc = prm_.cells();
  sums.assign(kSums * nc, 0.0);
  max_speed.assign(nc, 0.0);
  const size_t m = only ? only->size() : p.n_local();
  for (size_t q = 0; q < m; ++q) {
    const size_t i = only ? (*only)[q] : q;
    const int c = cell_of(p.x[i]);
    if (c < 0) continue;
    double* s = &sums[kSums * static_cast<size_t>(c)];
    const double m = p.mass[i], r = p.radius[i];
    const Vec3& v = p.v[i];
    s[0] += m;
    s[1] += sphere_volume(r);
    s[2] += 1.0;
    s[3] += m * v.x;
    s[4] += m * v.y;
    s[5] += m * v.z;
    add_dyad(s + 6, m * v, v);
    if (!stress6.empty())
      for (size_t k = 0; k < 6; ++k) s[12 + k] += stress6[6 * i + k];
    max_speed[static_cast<size_t>(c)] = std::max(max_speed[static_cast<size_t>(c)], norm2(v));
  }
  // The square root of the largest square is the largest speed to the last bit (sqrt is monotone and
  // correctly rounded): one root per cell instead of one per particle.
  for (double& s : max_speed) s = std::sqrt(s);
}

void CellGrid::add_sample(const std::vector<double>& sums, const std::vector<double>& max_speed) {
  const size_t nc = prm_.cells();
  const double vcell = prm_.h * prm_.h * prm_.h;
  for (size_t c = 0; c < nc; ++c) {
    const double* s = &sums[kSums * c];
    const double m = s[0];
    const Vec3 mom{s[3], s[4], s[5]};
    st_.mass[c] += m;
    st_.phi[c] += s[1] / vcell;
    st_.count[c] += s[2];
    st_.momentum[c] += mom;
    st_.max_speed[c] = std::max(st_.max_speed[c], max_speed[c]);
    // Kinetic part about the cell's mean velocity u: sum m v v - M u u.
    double kin[6] = {s[6], s[7], s[8], s[9], s[10], s[11]};
    if (m > 0.0) {
      const Vec3 u = mom * (1.0 / m);
      double uu[6] = {0, 0, 0, 0, 0, 0};
      add_dyad(uu, m * u, u);
      for (int k = 0; k < 6; ++k) kin[k] -= uu[k];
    }
    for (size_t k = 0; k < 6; ++k) st_.stress6[6 * c + k] += (s[12 + k] + kin[k]) / vcell;
  }
  ++st_.samples;
}

GridAverages CellGrid::take_averages() {
  const size_t nc = prm_.cells();
  GridAverages a;
  const double inv = st_.samples > 0 ? 1.0 / static_cast<double>(st_.samples) : 0.0;
  a.volume_fraction.resize(nc);
  a.max_speed = st_.max_speed;
  a.count.resize(nc);
  a.stress6.resize(6 * nc);
  a.mean_velocity.resize(nc);
  for (size_t c = 0; c < nc; ++c) {
    a.volume_fraction[c] = st_.phi[c] * inv;
    a.count[c] = st_.count[c] * inv;
    a.mean_velocity[c] = st_.mass[c] > 0.0 ? st_.momentum[c] * (1.0 / st_.mass[c]) : Vec3{};
    for (size_t k = 0; k < 6; ++k) a.stress6[6 * c + k] = st_.stress6[6 * c + k] * inv;
  }
  const GridParams prm = prm_;
  *this = CellGrid(prm);
  return a;
}

}  // namespace mlcg
