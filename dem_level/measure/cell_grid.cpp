#include "measure/cell_grid.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#if MLCG_VECTOR_SAMPLE
#include <immintrin.h>
#endif

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
  sample(p, stress6, sums, max_speed, only, MLCG_VECTOR_SAMPLE != 0);
}

void CellGrid::local_sample_scalar(const Particles& p, const std::vector<double>& stress6, std::vector<double>& sums,
                                   std::vector<double>& max_speed, const std::vector<uint32_t>* only) const {
  sample(p, stress6, sums, max_speed, only, false);
}

void CellGrid::sample(const Particles& p, const std::vector<double>& stress6, std::vector<double>& sums,
                      std::vector<double>& max_speed, const std::vector<uint32_t>* only, bool vector) const {
  sums.assign(kSums * prm_.cells(), 0.0);
  max_speed.assign(prm_.cells(), 0.0);
#if MLCG_VECTOR_SAMPLE
  if (vector) sum_vector(p, stress6, sums, max_speed, only);
  else sum_scalar(p, stress6, sums, max_speed, only);
#else
  (void)vector;
  sum_scalar(p, stress6, sums, max_speed, only);
#endif
  // The square root of the largest square is the largest speed to the last bit (sqrt is monotone and
  // correctly rounded): one root per cell instead of one per particle.
  for (double& s : max_speed) s = std::sqrt(s);
}

void CellGrid::sum_scalar(const Particles& p, const std::vector<double>& stress6, std::vector<double>& sums,
                          std::vector<double>& max_speed, const std::vector<uint32_t>* only) const {
  const size_t n = only ? only->size() : p.n_local();
  const bool contacts = !stress6.empty();
  // The sums of the cell the last particle fell in, kept while the next ones fall in it too (the particles
  // are sorted in space, so they come in runs): each cell's sums are added to in the same order as one
  // particle at a time through memory, so they are the same to the last bit.
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
      stress_here = stress_wanted(c);
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
}

#if MLCG_VECTOR_SAMPLE
void CellGrid::sum_vector(const Particles& p, const std::vector<double>& stress6, std::vector<double>& sums,
                          std::vector<double>& max_speed, const std::vector<uint32_t>* only) const {
  // sum_scalar() with the cell's sums in three vector registers (sums 0-7, 8-15, 16-19) instead of an array
  // the compiler keeps on the stack, one store and one load per sum and particle. Every lane is a
  // multiply-add of sum_scalar()'s operands, a plain sum as fma(term, 1, sum), which is exactly the
  // addition; a lane sum_scalar() leaves alone is masked out. So the sums are the same to the last bit
  // (ctest CellGrid.TheVectorSampleEqualsTheScalarOneToTheBit).
  const size_t n = only ? only->size() : p.n_local();
  const bool contacts = !stress6.empty();
  static constexpr double kNoContacts[6] = {0, 0, 0, 0, 0, 0};
  const __mmask8 contacts_b = contacts ? 0xFF : 0x0F, contacts_c = contacts ? 0x3 : 0x0;
  __m512d acc_a = _mm512_setzero_pd(), acc_b = _mm512_setzero_pd();
  __m256d acc_c = _mm256_setzero_pd();
  __mmask8 mask_a = 0xFF, mask_b = 0xFF, mask_c = 0x3;
  double vmax2 = 0.0;
  int cur = -1;
  // The accumulators go to the lambda by value: captured by reference, they would live on the stack.
  const auto store = [&sums, &max_speed](int cell, __m512d a, __m512d b, __m256d c, double vmax) {
    double* s = &sums[kSums * static_cast<size_t>(cell)];
    _mm512_storeu_pd(s, a);
    _mm512_storeu_pd(s + 8, b);
    _mm256_storeu_pd(s + 16, c);
    max_speed[static_cast<size_t>(cell)] = vmax;
  };
  for (size_t q = 0; q < n; ++q) {
    const size_t i = only ? (*only)[q] : q;
    const int c = cell_of(p.x[i]);
    if (c < 0) continue;
    if (c != cur) {
      if (cur >= 0) store(cur, acc_a, acc_b, acc_c, vmax2);
      cur = c;
      const double* s = &sums[kSums * static_cast<size_t>(c)];
      acc_a = _mm512_loadu_pd(s);
      acc_b = _mm512_loadu_pd(s + 8);
      acc_c = _mm256_loadu_pd(s + 16);
      vmax2 = max_speed[static_cast<size_t>(c)];
      const bool stress_here = stress_wanted(c);
      mask_a = stress_here ? 0xFF : 0x3F;
      mask_b = stress_here ? contacts_b : 0x00;
      mask_c = stress_here ? contacts_c : 0x00;
    }
    const double m = p.mass[i], r = p.radius[i];
    const Vec3& v = p.v[i];
    const double mvx = m * v.x, mvy = m * v.y, mvz = m * v.z;
    const double xy = madd(mvx, v.y, mvy * v.x), xz = madd(mvx, v.z, mvz * v.x), yz = madd(mvy, v.z, mvz * v.y);
    const double* st = contacts ? &stress6[6 * i] : kNoContacts;
    // sums 0-7: mass, volume, count, momentum, m vx vx, m vy vy; 8-15: m vz vz, the three off-diagonal
    // halves, contacts 0-3; 16-19: contacts 4-5 and two spare sums.
    const __m512d a_a = _mm512_setr_pd(m, kSphereVolumeFactor * r * r, 1.0, m, m, m, mvx, mvy);
    const __m512d b_a = _mm512_setr_pd(1.0, r, 1.0, v.x, v.y, v.z, v.x, v.y);
    const __m512d a_b = _mm512_setr_pd(mvz, 0.5, 0.5, 0.5, st[0], st[1], st[2], st[3]);
    const __m512d b_b = _mm512_setr_pd(v.z, xy, xz, yz, 1.0, 1.0, 1.0, 1.0);
    acc_a = _mm512_mask3_fmadd_pd(a_a, b_a, acc_a, mask_a);
    acc_b = _mm512_mask3_fmadd_pd(a_b, b_b, acc_b, mask_b);
    acc_c = _mm256_mask3_fmadd_pd(_mm256_setr_pd(st[4], st[5], 0.0, 0.0), _mm256_set1_pd(1.0), acc_c, mask_c);
    vmax2 = std::max(vmax2, madd(v.z, v.z, madd(v.x, v.x, v.y * v.y)));
  }
  if (cur >= 0) store(cur, acc_a, acc_b, acc_c, vmax2);
}
#endif

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
