// The brick decomposition: default grids, ownership at and beyond the
// boundaries, distances to boxes, and balancing the boundaries to the
// particles' quantiles.
#include <gtest/gtest.h>

#include <random>

#include "parallel/decomposition.hpp"

using namespace mlcg;

TEST(Decomposition, DefaultGridCutsAcrossGravityForASiloAndAlongALongBox) {
  const Vec3 g{0, 0, -9.81};
  EXPECT_EQ(Decomposition::default_grid(4, {-0.14, -0.14, -0.05}, {0.14, 0.14, 0.41}, g), (std::array<int, 3>{2, 2, 1}));
  const auto two = Decomposition::default_grid(2, {-0.14, -0.14, -0.05}, {0.14, 0.14, 0.41}, g);
  EXPECT_EQ(two[2], 1) << "a silo is cut vertically";
  EXPECT_EQ(Decomposition::default_grid(2, {0, 0, 0}, {1.0, 0.1, 0.1}, g), (std::array<int, 3>{2, 1, 1}));
  EXPECT_EQ(Decomposition::default_grid(6, {0, 0, 0}, {3.0, 2.0, 0.1}, g), (std::array<int, 3>{3, 2, 1}));
}

TEST(Decomposition, OwnersCoverTheDomainAndBeyond) {
  Decomposition d({2, 3, 1}, {0, 0, 0}, {2, 3, 1});
  EXPECT_EQ(d.owner({0.5, 0.5, 0.5}), d.rank_of(0, 0, 0));
  EXPECT_EQ(d.owner({1.0, 0.5, 0.5}), d.rank_of(1, 0, 0)) << "a boundary belongs to the upper box";
  EXPECT_EQ(d.owner({1.5, 2.5, 0.5}), d.rank_of(1, 2, 0));
  EXPECT_EQ(d.owner({-5.0, 9.0, 7.0}), d.rank_of(0, 2, 0)) << "outside the domain: the edge box";
  for (int r = 0; r < d.ranks(); ++r) {
    const Vec3 c = 0.5 * (d.box_lo(r) + d.box_hi(r));
    EXPECT_EQ(d.owner(c), r);
    EXPECT_EQ(d.distance_to_box(r, c), 0.0);
  }
  EXPECT_NEAR(d.distance_to_box(d.rank_of(1, 0, 0), {0.9, 0.5, 0.5}), 0.1, 1e-15);
  EXPECT_NEAR(d.distance_to_box(d.rank_of(1, 1, 0), {0.7, 0.6, 0.5}), std::hypot(0.3, 0.4), 1e-15);
  EXPECT_EQ(d.distance_to_box(d.rank_of(1, 2, 0), {1.5, 9.0, 0.5}), 0.0) << "edge boxes extend outward";
}

TEST(Decomposition, BalanceMovesTheCutToTheMedian) {
  Comm serial;
  Decomposition d({2, 1, 1}, {0, 0, 0}, {1, 1, 1});
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<Vec3> x;
  for (int i = 0; i < 20000; ++i) x.push_back({0.2 * u(rng) * u(rng) * 4.0 < 1.0 ? 0.1 * u(rng) : 0.9 * u(rng), u(rng), u(rng)});
  std::sort(x.begin(), x.end(), [](const Vec3& a, const Vec3& b) { return a.x < b.x; });
  const double median = 0.5 * (x[9999].x + x[10000].x);
  d.balance(serial, x, x.size());
  EXPECT_NEAR(d.cuts()[0][1], median, 1e-3);
  size_t left = 0;
  for (const auto& p : x) left += d.owner(p) == 0 ? 1 : 0;
  EXPECT_NEAR(static_cast<double>(left), 10000.0, 60.0);
}
