// The half Verlet list holds exactly the pairs within r_i + r_j + skin, each
// once; contact history survives a rebuild with reordering and removal.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <set>

#include "level/force_dispatch.hpp"
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

// Particles the coupler inserts join the list without a rebuild (NeighborList::append): the list then holds the
// build's pairs and every pair of a new particle within r_i + r_j + 1.5 skin, each once, however the old
// particles moved within their half skin.
TEST(NeighborList, AppendedParticlesGetEveryPairWithinASkinAndAHalf) {
  const double skin = 0.4e-3;
  Particles p = random_particles(2000, 7, 0.04);
  NeighborList nl;
  nl.set_skin(skin);
  nl.build(p, true);
  std::set<std::pair<int64_t, int64_t>> expected;
  for (size_t i = 0; i < p.size(); ++i)
    for (size_t j = i + 1; j < p.size(); ++j) {
      const double cut = p.radius[i] + p.radius[j] + skin;
      if (norm2(p.x[i] - p.x[j]) < cut * cut) expected.insert({p.id[i], p.id[j]});
    }
  std::mt19937_64 rng(8);
  std::uniform_real_distribution<double> u(-0.11e-3, 0.11e-3);  // |d| < 0.48 skin
  for (size_t i = 0; i < p.size(); ++i) p.x[i] += Vec3{u(rng), u(rng), u(rng)};
  ASSERT_FALSE(nl.needs_rebuild(p));
  const size_t first_new = p.size();
  const Particles extra = random_particles(300, 9, 0.04);
  for (size_t k = 0; k < extra.size(); ++k) {
    ParticleInit pi;
    pi.id = 100000 + static_cast<int64_t>(k);
    pi.radius = extra.radius[k];
    pi.density = 1000.0;
    pi.x = extra.x[k];
    p.add(pi);
  }
  nl.append(p, first_new, true);
  for (size_t k = first_new; k < p.size(); ++k)
    for (size_t j = 0; j < p.size(); ++j) {
      const double cut = p.radius[k] + p.radius[j] + 1.5 * skin;
      if (j != k && norm2(p.x[k] - p.x[j]) < cut * cut)
        expected.insert({std::min(p.id[k], p.id[j]), std::max(p.id[k], p.id[j])});
    }
  EXPECT_GT(expected.size(), 1500u);
  EXPECT_EQ(list_pairs(nl, p), expected);
  EXPECT_EQ(nl.hist.size(), nl.neigh.size());
  EXPECT_FALSE(nl.needs_rebuild(p));  // the new particles' reference is where they were inserted
}

// The worst case the 1.5 skin is for: an old particle inserted beside while it stood half a skin away from
// where it was at the build, then moving half a skin the other way toward the new one, which moves half a
// skin toward it. Neither triggers a rebuild, and they touch: the pair must be listed.
TEST(NeighborList, AppendedPairsStayValidUntilTheNextRebuild) {
  const double skin = 1e-3, r = 1e-3;
  Particles p;
  ParticleInit a;
  a.id = 1;
  a.radius = r;
  a.density = 1000.0;
  p.add(a);
  NeighborList nl;
  nl.set_skin(skin);
  nl.build(p, false);
  p.x[0].x = -0.49 * skin;
  ParticleInit b = a;
  b.id = 2;
  b.x = {p.x[0].x + 2.0 * r + 1.4 * skin, 0.0, 0.0};
  p.add(b);
  nl.append(p, 1, false);
  p.x[0].x = 0.49 * skin;
  p.x[1].x -= 0.49 * skin;
  ASSERT_FALSE(nl.needs_rebuild(p));
  ASSERT_LT(norm(p.x[1] - p.x[0]), 2.0 * r);  // touching
  EXPECT_EQ(list_pairs(nl, p).count({1, 2}), 1u);
}

// The force kernels take the appended rows (pairs listed under the later particle, j < i) as any other: the
// forces of a dense pack with a fifth of it appended equal those of a fresh build of all, pair for pair up to
// the order of the sums.
TEST(NeighborList, ForcesWithAppendedRowsEqualAFreshBuilds) {
  MaterialTable mt({Material{"glass", 2.5e7, 0.25, 2500.0}});
  mt.set_interaction(0, 0, {0.5, 0.5, 0.0});
  Particles p = random_particles(3000, 11, 0.02);  // radii 0.5-2 mm in 2 cm: many overlaps
  std::mt19937_64 rng(12);
  std::uniform_real_distribution<double> uv(-0.5, 0.5);
  for (size_t i = 0; i < p.size(); ++i) {
    p.v[i] = {uv(rng), uv(rng), uv(rng)};
    p.omega[i] = {100.0 * uv(rng), 100.0 * uv(rng), 100.0 * uv(rng)};
  }
  const auto forces = [&](Particles& q, NeighborList& nl) {
    WallSet walls;
    walls.build_candidates(q, nl.skin(), true);
    std::vector<double> stress6;
    std::vector<Vec3> wall_force;
    for (size_t i = 0; i < q.size(); ++i) q.f[i] = q.torque[i] = Vec3{};
    ForceContext ctx{q, nl, walls, mt, 1e-6, stress6, wall_force, {}};
    select_force_routine(ContactChoice{})(ctx, false);
    return ctx.stats.pair_contacts;
  };
  const size_t first_new = 2400;
  Particles appended = p;
  std::vector<int32_t> keep(first_new);
  for (size_t i = 0; i < first_new; ++i) keep[i] = static_cast<int32_t>(i);
  appended.permute(keep);
  NeighborList nl_a;
  nl_a.set_skin(0.2e-3);
  nl_a.build(appended, true);
  for (size_t i = first_new; i < p.size(); ++i) {
    ParticleInit pi;
    pi.id = p.id[i];
    pi.radius = p.radius[i];
    pi.density = 1000.0;
    pi.x = p.x[i];
    pi.v = p.v[i];
    pi.omega = p.omega[i];
    appended.add(pi);
  }
  nl_a.append(appended, first_new, true);
  NeighborList nl_b;
  nl_b.set_skin(0.2e-3);
  nl_b.build(p, true);
  const int64_t ca = forces(appended, nl_a), cb = forces(p, nl_b);
  EXPECT_GT(cb, 2000);
  EXPECT_EQ(ca, cb);
  double fmax = 0.0;
  for (size_t i = 0; i < p.size(); ++i) fmax = std::max(fmax, norm(p.f[i]));
  for (size_t i = 0; i < p.size(); ++i) {
    EXPECT_LE(norm(appended.f[i] - p.f[i]), 1e-12 * fmax) << "particle " << i;
    EXPECT_LE(norm(appended.torque[i] - p.torque[i]), 1e-12 * fmax * 2e-3) << "particle " << i;
  }
}

// The overlap hash behind the insertions (the coupler's planner, the level's SSI fill, appended
// pairs) against brute force, through several growths of its table and a refill after clear(),
// with spheres on both sides of zero and far outside; a cell's spheres come in the order stored.
TEST(SphereHash, FindsExactlyTheOverlapsBruteForceFindsThroughGrowthAndRefill) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-0.02, 0.02), ur(0.2e-3, 1e-3);
  SphereHash hash(2e-3);
  for (int round = 0; round < 2; ++round) {
    hash.clear();
    std::vector<Sphere> stored;
    for (int k = 0; k < 3000; ++k) stored.push_back({{u(rng), u(rng), u(rng)}, ur(rng)});
    stored.push_back({{1e3, -1e3, 5.0}, 1e-3});
    for (const auto& s : stored) hash.add(s);
    ASSERT_EQ(hash.size(), stored.size());
    int hits = 0;
    for (int q = 0; q < 3000; ++q) {
      const Vec3 x = q == 0 ? Vec3{1e3, -1e3, 5.0 + 1.5e-3} : Vec3{u(rng), u(rng), u(rng)};
      const double r = ur(rng);
      bool brute = false;
      for (const auto& s : stored) brute = brute || norm2(x - s.x) < (r + s.r) * (r + s.r);
      ASSERT_EQ(hash.overlaps(x, r), brute) << "query " << q << " of round " << round;
      hits += brute;
    }
    EXPECT_GT(hits, 300);  // both answers are exercised
    EXPECT_LT(hits, 2700);
  }
  SphereHash one(1.0);
  for (double z : {0.1, 0.5, 0.9}) one.add({0.5, 0.5, z}, 0.01);
  std::vector<size_t> order;
  one.find_near({0.5, 0.5, 0.5}, 0.01, [&](size_t k, const Vec3&, double) {
    order.push_back(k);
    return false;
  });
  EXPECT_EQ(order, (std::vector<size_t>{0, 1, 2}));
}
