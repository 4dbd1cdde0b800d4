// CellGrid's sample (paper Eq. 8) against the same statistics computed here cell by cell from their
// definitions: volume fraction sum V_p / V_cell, Favre velocity sum m v / sum m, and the stress as the
// contacts' dyads plus sum m (v - u) (x) (v - u) over V_cell (the grid sums m v v and subtracts M u u).
// The particles come in spatial runs, as a level's sorted arrays do, and the cells a stress mask leaves out
// carry no stress while their other statistics stay whole.
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <random>

#include "measure/cell_grid.hpp"

namespace {

using namespace mlcg;

constexpr double kPi = 3.14159265358979323846;

struct Bed {
  GridParams grid;
  Particles p;
  std::vector<double> stress6;
};

// n particles in a 3 x 3 x 3 grid of 1 cm cells (a few outside it), sorted by neighbour bins of 2.5 mm.
Bed make_bed(size_t n, uint64_t seed) {
  Bed b;
  b.grid.name = "test";
  b.grid.origin = {-0.01, 0.02, 0.0};
  b.grid.h = 0.01;
  b.grid.nx = b.grid.ny = b.grid.nz = 3;
  std::mt19937_64 g(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0), s(-1.0, 1.0);
  std::vector<Vec3> xs;
  for (size_t k = 0; k < n; ++k) xs.push_back(b.grid.origin + Vec3{0.032 * u(g), 0.032 * u(g), 0.032 * u(g)});
  const auto key = [](const Vec3& x) {
    return (std::floor(x.z / 0.0025) * 1000 + std::floor(x.y / 0.0025)) * 1000 + std::floor(x.x / 0.0025);
  };
  std::sort(xs.begin(), xs.end(), [&](const Vec3& a, const Vec3& c) { return key(a) < key(c); });
  for (size_t k = 0; k < n; ++k) {
    ParticleInit pi;
    pi.id = static_cast<int64_t>(k);
    pi.radius = 0.0004 + 0.0004 * u(g);
    pi.density = 2500.0;
    pi.x = xs[k];
    pi.v = {0.3 * s(g), 0.3 * s(g), -0.5 + 0.2 * s(g)};  // a mean flow and a spread about it
    b.p.add(pi);
  }
  b.stress6.resize(6 * n);
  for (double& v : b.stress6) v = 1e-6 * s(g);
  return b;
}

struct Expected {
  double phi = 0.0, mass = 0.0;
  Vec3 u;
  double stress[6] = {0, 0, 0, 0, 0, 0};
};

// Each cell's statistics from the definitions, two passes per cell: the mean velocity first, then the
// fluctuations about it.
std::vector<Expected> expected(const Bed& b) {
  const size_t nc = b.grid.cells();
  std::vector<Expected> e(nc);
  const double vcell = b.grid.h * b.grid.h * b.grid.h;
  const auto cell = [&](const Vec3& x) {
    const Vec3 r = (x - b.grid.origin) / b.grid.h;
    const int i = static_cast<int>(std::floor(r.x)), j = static_cast<int>(std::floor(r.y)),
              k = static_cast<int>(std::floor(r.z));
    if (i < 0 || j < 0 || k < 0 || i >= 3 || j >= 3 || k >= 3) return -1;
    return (k * 3 + j) * 3 + i;
  };
  std::vector<Vec3> mom(nc);
  for (size_t i = 0; i < b.p.n_local(); ++i) {
    const int c = cell(b.p.x[i]);
    if (c < 0) continue;
    const double r = b.p.radius[i];
    e[c].mass += b.p.mass[i];
    e[c].phi += 4.0 / 3.0 * kPi * r * r * r / vcell;
    mom[c] += b.p.mass[i] * b.p.v[i];
  }
  for (size_t c = 0; c < nc; ++c)
    if (e[c].mass > 0.0) e[c].u = mom[c] / e[c].mass;
  for (size_t i = 0; i < b.p.n_local(); ++i) {
    const int c = cell(b.p.x[i]);
    if (c < 0) continue;
    const Vec3 w = b.p.v[i] - e[c].u;
    const double m = b.p.mass[i];
    const double dyad[6] = {m * w.x * w.x, m * w.y * w.y, m * w.z * w.z, m * w.x * w.y, m * w.x * w.z, m * w.y * w.z};
    for (int k = 0; k < 6; ++k) e[c].stress[k] += (dyad[k] + b.stress6[6 * i + k]) / vcell;
  }
  return e;
}

void expect_close(double got, double want, double scale, const std::string& what) {
  EXPECT_NEAR(got, want, 1e-12 * scale) << what;
}

TEST(CellGrid, ASampleGivesEachCellsVolumeFractionVelocityAndStressAsDefined) {
  const Bed b = make_bed(3000, 11);
  const std::vector<Expected> e = expected(b);
  CellGrid g(b.grid);
  std::vector<double> sums, maxs;
  g.local_sample(b.p, b.stress6, sums, maxs);
  g.add_sample(sums, maxs);
  const GridAverages a = g.take_averages();
  double stress_scale = 0.0, filled = 0.0;
  for (const auto& c : e) {
    for (double s : c.stress) stress_scale = std::max(stress_scale, std::fabs(s));
    filled += c.mass > 0.0 ? 1.0 : 0.0;
  }
  ASSERT_EQ(filled, 27.0);  // every cell holds particles
  for (size_t c = 0; c < 27; ++c) {
    const std::string at = "cell " + std::to_string(c);
    expect_close(a.volume_fraction[c], e[c].phi, 1.0, at + " phi");
    for (int k = 0; k < 3; ++k) expect_close(a.mean_velocity[c][k], e[c].u[k], 1.0, at + " u");
    for (int k = 0; k < 6; ++k) expect_close(a.stress6[6 * c + k], e[c].stress[k], stress_scale, at + " stress");
  }
}

TEST(CellGrid, CellsLeftOutOfTheStressMaskCarryNoStressAndKeepTheirOtherStatistics) {
  const Bed b = make_bed(3000, 12);
  const std::vector<Expected> e = expected(b);
  CellGrid g(b.grid);
  std::vector<char> wanted(27, 0);
  for (size_t c = 18; c < 27; ++c) wanted[c] = 1;  // the top layer, as under a region's top faces
  g.set_stress_cells(wanted);
  double stress_scale = 0.0;
  for (const auto& c : e)
    for (double s : c.stress) stress_scale = std::max(stress_scale, std::fabs(s));
  std::vector<double> sums, maxs;
  for (int sample = 0; sample < 2; ++sample) {  // the mask holds across samples and averages
    g.local_sample(b.p, b.stress6, sums, maxs);
    g.add_sample(sums, maxs);
    const GridAverages a = g.take_averages();
    for (size_t c = 0; c < 27; ++c) {
      const std::string at = "sample " + std::to_string(sample) + " cell " + std::to_string(c);
      expect_close(a.volume_fraction[c], e[c].phi, 1.0, at + " phi");
      for (int k = 0; k < 3; ++k) expect_close(a.mean_velocity[c][k], e[c].u[k], 1.0, at + " u");
      for (int k = 0; k < 6; ++k) {
        if (wanted[c]) expect_close(a.stress6[6 * c + k], e[c].stress[k], stress_scale, at + " stress");
        else EXPECT_EQ(a.stress6[6 * c + k], 0.0) << at;
      }
    }
  }
  EXPECT_THROW(g.set_stress_cells(std::vector<char>(26, 1)), std::invalid_argument);
}

TEST(CellGrid, TheLargestSpeedAndTheCountAreEachCellsOwn) {
  Bed b = make_bed(2000, 13);
  CellGrid g(b.grid);
  std::vector<double> sums, maxs;
  g.local_sample(b.p, b.stress6, sums, maxs);
  std::vector<double> vmax(27, 0.0), count(27, 0.0);
  for (size_t i = 0; i < b.p.n_local(); ++i) {
    const int c = g.cell_of(b.p.x[i]);
    if (c < 0) continue;
    vmax[c] = std::max(vmax[c], std::sqrt(norm2(b.p.v[i])));
    count[c] += 1.0;
  }
  for (size_t c = 0; c < 27; ++c) {
    EXPECT_NEAR(maxs[c], vmax[c], 1e-15) << c;
    EXPECT_EQ(sums[CellGrid::kSums * c + 2], count[c]) << c;
  }
}

// The sample this build runs (in vector registers where it has AVX-512) against the scalar loop, bit for
// bit: with and without contacts, a stress mask, and a candidate list that leaves particles out. A build
// without AVX-512 runs the scalar loop in both.
TEST(CellGrid, TheVectorSampleEqualsTheScalarOneToTheBit) {
  const Bed b = make_bed(4000, 14);
  CellGrid g(b.grid);
  std::vector<char> wanted(27, 0);
  for (size_t c = 9; c < 27; c += 2) wanted[c] = 1;
  std::vector<uint32_t> only;
  for (uint32_t i = 0; i < b.p.n_local(); ++i)
    if (i % 7 != 3) only.push_back(i);
  for (int mask = 0; mask < 2; ++mask) {
    if (mask) g.set_stress_cells(wanted);
    for (const bool contacts : {true, false})
      for (const bool listed : {false, true}) {
        const std::vector<double> none;
        const auto& st = contacts ? b.stress6 : none;
        const auto* list = listed ? &only : nullptr;
        std::vector<double> sums, maxs, ref_sums, ref_maxs;
        g.local_sample(b.p, st, sums, maxs, list);
        g.local_sample_scalar(b.p, st, ref_sums, ref_maxs, list);
        ASSERT_EQ(sums.size(), ref_sums.size());
        const std::string at = "mask " + std::to_string(mask) + ", contacts " + std::to_string(contacts) +
                               ", listed " + std::to_string(listed);
        for (size_t k = 0; k < sums.size(); ++k)
          ASSERT_EQ(std::bit_cast<uint64_t>(sums[k]), std::bit_cast<uint64_t>(ref_sums[k]))
              << at << ": sum " << k % CellGrid::kSums << " of cell " << k / CellGrid::kSums;
        for (size_t c = 0; c < maxs.size(); ++c) ASSERT_EQ(maxs[c], ref_maxs[c]) << at << ": cell " << c;
      }
  }
}

}  // namespace

