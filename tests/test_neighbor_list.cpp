// The half Verlet list holds exactly the pairs within r_i + r_j + skin, each
// once; contact history survives a rebuild with reordering and removal.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <set>

#include "neighbor/neighbor_list.hpp"

using namespace mlcg;

namespace {

Particles random_particles(size_t n, uint64_t seed, double box) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, box), ur(0.5e-3, 2e-3);
  Particles p;
  for (size_t i = 0; i < n; ++i) {
    ParticleInit pi;
    pi.id = static_cast<int64_t>(1000 + i);
    pi.radius = ur(rng);
    pi.density = 1000.0;
    pi.x = {u(rng), u(rng), u(rng)};
    p.add(pi);
  }
  return p;
}

std::set<std::pair<int64_t, int64_t>> list_pairs(const NeighborList& nl, const Particles& p) {
  std::set<std::pair<int64_t, int64_t>> s;
  for (size_t i = 0; i + 1 < nl.first.size(); ++i)
    for (int32_t k = nl.first[i]; k < nl.first[i + 1]; ++k) {
      const int64_t a = p.id[i], b = p.id[static_cast<size_t>(nl.neigh[static_cast<size_t>(k)])];
      const bool fresh = s.insert({std::min(a, b), std::max(a, b)}).second;
      EXPECT_TRUE(fresh) << "pair listed twice";
    }
  return s;
}

}  // namespace

TEST(NeighborList, HalfListEqualsBruteForce) {
  const Particles p = random_particles(3000, 1, 0.05);
  NeighborList nl;
  nl.set_skin(0.4e-3);
  nl.build(p, false);
  std::set<std::pair<int64_t, int64_t>> brute;
  for (size_t i = 0; i < p.size(); ++i)
    for (size_t j = i + 1; j < p.size(); ++j) {
      const double cut = p.radius[i] + p.radius[j] + 0.4e-3;
      if (norm2(p.x[i] - p.x[j]) < cut * cut) brute.insert({p.id[i], p.id[j]});
    }
  EXPECT_GT(brute.size(), 1000u);
  EXPECT_EQ(list_pairs(nl, p), brute);
}

TEST(NeighborList, RebuildTriggersOnlyAfterHalfTheSkin) {
  Particles p = random_particles(100, 2, 0.02);
  NeighborList nl;
  nl.set_skin(1e-3);
  nl.build(p, false);
  p.x[17].x += 0.49e-3;
  EXPECT_FALSE(nl.needs_rebuild(p));
  p.x[17].x += 0.02e-3;
  EXPECT_TRUE(nl.needs_rebuild(p));
}

TEST(NeighborList, HistorySurvivesReorderingAndRemoval) {
  Particles p = random_particles(2000, 3, 0.04);
  NeighborList nl;
  nl.set_skin(0.5e-3);
  nl.build(p, true);
  // Give every listed pair a history value that encodes its ids (from i's side).
  for (size_t i = 0; i + 1 < nl.first.size(); ++i)
    for (int32_t k = nl.first[i]; k < nl.first[i + 1]; ++k) {
      const auto j = static_cast<size_t>(nl.neigh[static_cast<size_t>(k)]);
      nl.hist[static_cast<size_t>(k)] = Vec3f({static_cast<double>(p.id[i]), static_cast<double>(p.id[j]), 1.0});
    }
  ContactHistory h;
  nl.save_history(p, h);

  // Shuffle and drop every fifth particle.
  std::vector<int32_t> order(p.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = static_cast<int32_t>(i);
  std::shuffle(order.begin(), order.end(), std::mt19937_64(9));
  std::vector<int32_t> keep;
  for (size_t k = 0; k < order.size(); ++k)
    if (k % 5 != 0) keep.push_back(order[k]);
  p.permute(keep);
  h.permute(keep, p.size());

  nl.build(p, true);
  nl.load_history(p, h);
  size_t checked = 0;
  for (size_t i = 0; i + 1 < nl.first.size(); ++i)
    for (int32_t k = nl.first[i]; k < nl.first[i + 1]; ++k) {
      const auto j = static_cast<size_t>(nl.neigh[static_cast<size_t>(k)]);
      const Vec3 v = nl.hist[static_cast<size_t>(k)];
      // Seen from (i, j): +(id_i, id_j, 1) if i owned the pair before, -(id_j, id_i, 1) if j did.
      const bool same = v == Vec3{static_cast<double>(p.id[i]), static_cast<double>(p.id[j]), 1.0};
      const bool flipped = v == Vec3{-static_cast<double>(p.id[j]), -static_cast<double>(p.id[i]), -1.0};
      EXPECT_TRUE(same || flipped) << "pair " << p.id[i] << "-" << p.id[j];
      ++checked;
    }
  EXPECT_GT(checked, 1000u);
}

// The pair kernel holds one coefficient set when every particle of the list has the same material;
// a single ghost of another material must take that away.
TEST(NeighborList, SingleMaterialSeesGhostsToo) {
  Particles p = random_particles(50, 4, 0.02);
  for (auto& m : p.material) m = 2;
  NeighborList nl;
  nl.set_skin(1e-3);
  nl.build(p, false);
  EXPECT_EQ(nl.single_material(), 2);
  p.add_ghost({0.01, 0.01, 0.01}, {}, {}, 1e-3, 1e-6, 9999, 2);
  nl.build(p, false);
  EXPECT_EQ(nl.single_material(), 2);
  p.add_ghost({0.011, 0.01, 0.01}, {}, {}, 1e-3, 1e-6, 10000, 0);
  nl.build(p, false);
  EXPECT_EQ(nl.single_material(), -1);
  p.drop_ghosts();
  p.material[7] = 1;
  nl.build(p, false);
  EXPECT_EQ(nl.single_material(), -1);
}
