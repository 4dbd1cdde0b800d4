// Issue 6, scene 11: particles on the border between 2 MPI ranks (centres
// exactly on it, one straddling it, a head-on pair meeting on it). The energy
// summed over both ranks stays bounded and equals the same scene on one rank:
// a border contact is neither lost nor counted twice.
#include <gtest/gtest.h>
#include <mpi.h>

#include "stability_support.hpp"

using namespace mlcg;
using namespace mlcg::test;

TEST(RankBorder, ParticlesOnTheBorderKeepTheEnergyBoundedAndMatchOneRank) {
  int size = 0;
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  ASSERT_EQ(size, 2);
  auto cs = load("stability/rank_border.toml");
  Level two(cs, quiet());
  EXPECT_GT(two.particles().n_local(), 0u);  // both ranks hold particles
  const EnergyRun r2 = run_measuring_energy(two);

  cs.levels[0].processors.clear();
  LevelOptions o = quiet();
  o.single_rank = true;
  Level one(cs, o);
  const EnergyRun r1 = run_measuring_energy(one);

  for (const EnergyRun* r : {&r1, &r2}) {
    EXPECT_TRUE(r->finite);
    EXPECT_EQ(r->stop, "");
    EXPECT_EQ(r->particles, 6);
    EXPECT_EQ(r->particles_end, 6);
    EXPECT_GT(r->scale, 0.0);
    EXPECT_LE(r->gain(), 1e-9);  // measured 0 (damped): the rounding floor of test_stability.cpp's bounds
  }
  // Same physics up to summation order.
  EXPECT_EQ(r1.steps, r2.steps);
  EXPECT_NEAR(r2.e_ref, r1.e_ref, 1e-9 * r1.scale);
  EXPECT_NEAR(r2.e_end, r1.e_end, 1e-6 * r1.scale);
  int rank = 0;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  if (rank == 0)
    std::cout << "[stability] stability/rank_border.toml on 2 ranks: " << r2.steps
              << " steps, largest energy gain / energy in motion = " << r2.gain() << " (1 rank: " << r1.gain()
              << "), end energy 2 ranks - 1 rank = " << (r2.e_end - r1.e_end) / r1.scale << "\n";
}
