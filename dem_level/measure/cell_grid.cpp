#include "measure/cell_grid.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

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

int CellGrid::cell_of(const Vec3& x) const {
  const Vec3 r = (x - prm_.origin) * (1.0 / prm_.h);
  const int ix = static_cast<int>(std::floor(r.x));
  const int iy = static_cast<int>(std::floor(r.y));
  const int iz = static_cast<int>(std::floor(r.z));
  if (ix < 0 || iy < 0 || iz < 0 || ix >= prm_.nx || iy >= prm_.ny || iz >= prm_.nz) return -1;
  return (iz * prm_.ny + iy) * prm_.nx + ix;
}

void CellGrid::sample(const Particles& p, const std::vector<double>& stress6) {
  const size_t nc = prm_.cells();
  const size_t n = p.n_local();
  const double vcell = prm_.h * prm_.h * prm_.h;
  cell_.resize(n);
  m_.assign(nc, 0.0);
  vol_.assign(nc, 0.0);
  p_.assign(nc, Vec3{});
  std::vector<double> sig(6 * nc, 0.0);
  for (size_t i = 0; i < n; ++i) {
    const int c = cell_of(p.x[i]);
    cell_[i] = c;
    if (c < 0) continue;
    const auto cc = static_cast<size_t>(c);
    const double r = p.radius[i];
    m_[cc] += p.mass[i];
    vol_[cc] += 4.0 / 3.0 * std::numbers::pi * r * r * r;
    p_[cc] += p.mass[i] * p.v[i];
    st_.count[cc] += 1.0;
    st_.max_speed[cc] = std::max(st_.max_speed[cc], norm(p.v[i]));
    if (!stress6.empty())
      for (int k = 0; k < 6; ++k) sig[6 * cc + static_cast<size_t>(k)] += stress6[6 * i + static_cast<size_t>(k)];
  }
  for (size_t i = 0; i < n; ++i) {
    if (cell_[i] < 0) continue;
    const auto cc = static_cast<size_t>(cell_[i]);
    const Vec3 u = p_[cc] * (1.0 / m_[cc]);
    const Vec3 vp = p.v[i] - u;
    add_dyad(&sig[6 * cc], p.mass[i] * vp, vp);
  }
  for (size_t c = 0; c < nc; ++c) {
    st_.phi[c] += vol_[c] / vcell;
    st_.mass[c] += m_[c];
    st_.momentum[c] += p_[c];
    for (size_t k = 0; k < 6; ++k) st_.stress6[6 * c + k] += sig[6 * c + k] / vcell;
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
