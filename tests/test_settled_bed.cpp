// A settled bed in a box with frictionless side walls: the floor carries the
// whole weight, and the cell grid's vertical stress (paper Eq. 8) in the bottom
// layer of cells matches weight / area.
#include <gtest/gtest.h>

#include <numeric>

#include "scene_support.hpp"

using namespace mlcg;
using namespace mlcg::test;

TEST(SettledBed, FloorCarriesTheWeightAndGridStressMatchesWeightOverArea) {
  auto cs = load("settled_bed/box.toml");
  const double settle_end = cs.time.end;
  cs.grids[0].output_interval = 10.0;  // the test takes the averages itself
  Level level(cs, quiet());
  while (level.time() < settle_end) level.step_once();

  const auto& p = level.particles();
  double weight = 0.0;
  for (size_t i = 0; i < p.n_local(); ++i) weight += p.mass[i] * 9.81;
  ASSERT_EQ(p.n_local(), 4000u);

  // The settled bed still sways as a whole (period about 0.2 s, +-0.5 % of the
  // weight), so average over 0.2 s. Force balance holds exactly at any time:
  // floor force - weight = rate of change of the bed's momentum.
  const int floor = level.walls().find("floor");
  auto momentum = [&] {
    double s = 0.0;
    for (size_t i = 0; i < p.n_local(); ++i) s += p.mass[i] * p.v[i].z;
    return s;
  };
  level.take_grid_averages(0);
  const double p0 = momentum();
  double floor_force = 0.0;
  const int n = static_cast<int>(0.2 / level.dt());
  for (int k = 0; k < n; ++k) {
    level.step_once();
    floor_force += -level.wall_forces()[static_cast<size_t>(floor)].z;  // force on the floor points down
  }
  floor_force /= n;
  const double dpdt = (momentum() - p0) / (n * level.dt());
  EXPECT_NEAR((floor_force - weight) / weight, dpdt / weight, 1e-6);
  std::printf("weight %.6f N, floor force %.6f N (%.3f %%)\n", weight, floor_force,
              100.0 * (floor_force / weight - 1.0));
  EXPECT_NEAR(floor_force / weight, 1.0, 0.005);

  const GridAverages a = level.take_grid_averages(0);
  const double h = cs.grids[0].cell_size;
  const int nx = 3, ny = 3;  // 25.2 mm / 8.4 mm
  double szz = 0.0;
  for (int c = 0; c < nx * ny; ++c) szz += a.stress6[6 * static_cast<size_t>(c) + 2];
  szz /= nx * ny;
  const double area = (nx * h) * (ny * h);
  std::printf("bottom cells sigma_zz %.3f Pa, weight/area %.3f Pa (%.2f %%)\n", szz, weight / area,
              100.0 * (szz / (weight / area) - 1.0));
  EXPECT_NEAR(szz / (weight / area), 1.0, 0.05);
}
