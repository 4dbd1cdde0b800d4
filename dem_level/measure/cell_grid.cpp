#include "measure/cell_grid.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "core/spheres.hpp"
#include "forces/contact_stats.hpp"

namespace mlcg {
namespace {

// The sums are written with the multiply-adds GCC formed (-ffp-contract=fast) in the particle-at-a-time
// loop they replace, so that they stay the same to the last bit whatever the compiler does with the new
// loop; without FMA instructions nothing was fused.
inline double madd(double a, double b, double c) {
#ifdef __FMA__
  return std::fma(a, b, c);
#else
  return a * b + c;
#endif
}

}  // namespace

CellGrid::CellGrid(GridParams prm) : prm_(std::move(prm)) {
  const size_t n = prm_.cells();
  st_.phi.assign(n, 0.0);
  st_.mass.assign(n, 0.0);
  st_.max_speed.assign(n, 0.0);
  st_.stress6.assign(6 * n, 0.0);
  st_.count.assign(n, 0.0);
  st_.momentum.assign(n, Vec3{});
}

void CellGrid::set_stress_cells(std::vector<char> wanted) {
  if (!wanted.empty() && wanted.size() != prm_.cells())
    throw std::invalid_argument("cell grid '" + prm_.name + "': stress mask of " + std::to_string(wanted.size()) +
                                " cells for " + std::to_string(prm_.cells()));
  stress_cells_ = std::move(wanted);
}

void CellGrid::local_sample(const Particles& p, const std::vector<double>& stress6, std::vector<double>& sums,
                            std::vector<double>& max_speed, const std::vector<uint32_t>* only) const {
  const size_t nc = prm_.cells();
  sums.assign(kSums * nc, 0.0);
  max_speed.assign(nc, 0.0);
  const size_t n = only ? only->size() : p.n_local();
  const bool contacts = !stress6.empty();
  // The sums of the cell the last particle fell in, held in registers while the next ones fall in it too
  // (the particles are sorted in space, so they come in runs): each cell's sums are added to in the same
  // order as one particle at a time through memory, so they are the same to the last bit.
  double acc[kSums];
  double vmax2 = 0.0;
  int cur = -1;
  bool stress_here = true;
  const auto store = [&] {
    if (cur < 0) return;
    double* s = &sums[kSums * static_cast<size_t>(cur)];
    for (size_t k = 0; k < kSums; ++k) s[k] = acc[k];
    max_speed[static_cast<size_t>(cur)] = vmax2;
  };
  for (size_t q = 0; q < n; ++q) {
    const size_t i = only ? (*only)[q] : q;
    const int c = cell_of(p.x[i]);
    if (c < 0) continue;
    if (c != cur) {
      store();
      cur = c;
      const double* s = &sums[kSums * static_cast<size_t>(c)];
      for (size_t k = 0; k < kSums; ++k) acc[k] = s[k];
      vmax2 = max_speed[static_cast<size_t>(c)];
      stress_here = stress_cells_.empty() || stress_cells_[static_cast<size_t>(c)] != 0;
    }
    const double m = p.mass[i], r = p.radius[i];
    const Vec3& v = p.v[i];
    const double mvx = m * v.x, mvy = m * v.y, mvz = m * v.z;
    acc[0] += m;
    acc[1] = madd(kSphereVolumeFactor * r * r, r, acc[1]);
    acc[2] += 1.0;
    acc[3] = madd(m, v.x, acc[3]);
    acc[4] = madd(m, v.y, acc[4]);
    acc[5] = madd(m, v.z, acc[5]);
    if (stress_here) {  // sum m v (x) v, as xx yy zz xy xz yz, and the contacts' dyads
      acc[6] = madd(mvx, v.x, acc[6]);
      acc[7] = madd(mvy, v.y, acc[7]);
      acc[8] = madd(mvz, v.z, acc[8]);
      acc[9] = madd(0.5, madd(mvx, v.y, mvy * v.x), acc[9]);
      acc[10] = madd(0.5, madd(mvx, v.z, mvz * v.x), acc[10]);
      acc[11] = madd(0.5, madd(mvy, v.z, mvz * v.y), acc[11]);
      if (contacts)
        for (size_t k = 0; k < 6; ++k) acc[12 + k] += stress6[6 * i + k];
    }
    vmax2 = std::max(vmax2, madd(v.z, v.z, madd(v.x, v.x, v.y * v.y)));
  }
  store();
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
    if (!stress_cells_.empty() && stress_cells_[c] == 0) continue;  // no stress asked for here: it stays 0
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
  st_ = CellGrid(prm_).st_;
  return a;
}

}  // namespace mlcg
