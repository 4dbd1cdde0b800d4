// A level on 2 MPI ranks: contacts across a rank border give the same physics
// as one rank (bit for bit where nothing but the split differs), particles
// migrate with their contact history, ghosts never touch walls twice,
// reductions report the whole system, a discharge does not depend on the
// rank count beyond its noise, and checkpoints move between rank counts.
#include <gtest/gtest.h>
#include <mpi.h>

#include <cstring>
#include <filesystem>
#include <map>
#include <numbers>
#include <random>

#include "parallel/exchange.hpp"

#include "scene_support.hpp"

using namespace mlcg;
using namespace mlcg::test;
namespace fs = std::filesystem;

namespace {

int rank() {
  int r = 0;
  MPI_Comm_rank(MPI_COMM_WORLD, &r);
  return r;
}

struct State {
  Vec3 x, v, omega;
};

// Every particle of the level, gathered from all ranks, by id.
std::map<int64_t, State> gather(const Level& level) {
  const auto& p = level.particles();
  std::vector<double> mine;
  for (size_t i = 0; i < p.n_local(); ++i) {
    mine.push_back(static_cast<double>(p.id[i]));
    for (const Vec3* q : {&p.x[i], &p.v[i], &p.omega[i]}) mine.insert(mine.end(), {q->x, q->y, q->z});
  }
  int n = static_cast<int>(mine.size()), size = 0;
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  std::vector<int> counts(static_cast<size_t>(size)), disp(static_cast<size_t>(size));
  MPI_Allgather(&n, 1, MPI_INT, counts.data(), 1, MPI_INT, MPI_COMM_WORLD);
  int total = 0;
  for (int r = 0; r < size; ++r) {
    disp[static_cast<size_t>(r)] = total;
    total += counts[static_cast<size_t>(r)];
  }
  std::vector<double> all(static_cast<size_t>(total));
  MPI_Allgatherv(mine.data(), n, MPI_DOUBLE, all.data(), counts.data(), disp.data(), MPI_DOUBLE, MPI_COMM_WORLD);
  std::map<int64_t, State> out;
  for (size_t k = 0; k < all.size(); k += 10)
    out[static_cast<int64_t>(all[k])] = {{all[k + 1], all[k + 2], all[k + 3]},
                                          {all[k + 4], all[k + 5], all[k + 6]},
                                          {all[k + 7], all[k + 8], all[k + 9]}};
  return out;
}

std::map<int64_t, State> local_all(const Level& level) {
  const auto& p = level.particles();
  std::map<int64_t, State> out;
  for (size_t i = 0; i < p.n_local(); ++i) out[p.id[i]] = {p.x[i], p.v[i], p.omega[i]};
  return out;
}

// Which rank holds each particle now.
std::map<int64_t, int> owners(const Level& level) {
  const auto& p = level.particles();
  std::vector<int64_t> mine(p.id.begin(), p.id.begin() + static_cast<long>(p.n_local()));
  std::map<int64_t, int> out;
  int size = 0;
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  for (int r = 0; r < size; ++r) {
    int n = static_cast<int>(mine.size());
    MPI_Bcast(&n, 1, MPI_INT, r, MPI_COMM_WORLD);
    std::vector<int64_t> ids = r == rank() ? mine : std::vector<int64_t>(static_cast<size_t>(n));
    MPI_Bcast(ids.data(), n, MPI_INT64_T, r, MPI_COMM_WORLD);
    for (int64_t id : ids) out[id] = r;
  }
  return out;
}

struct SplitResult {
  double worst = 0.0;         // largest difference of any coordinate, 2 ranks vs 1
  int min_local = 0;          // fewest particles a rank held at any step
  int migrated = 0;           // particles whose rank changed
  double max_spin = 0.0;      // largest |omega| at the end (friction acted)
};

// The same case on 2 ranks (split across x at the middle) and on one rank, stepped together.
SplitResult split_vs_single(config::CaseSpec cs, uint64_t steps) {
  cs.levels[0].ranks = 2;
  cs.levels[0].processors = {2, 1, 1};
  cs.levels[0].balance = false;
  Level two(cs, quiet());
  LevelOptions solo = quiet();
  solo.single_rank = true;
  auto cs1 = cs;
  cs1.levels[0].ranks = 1;
  cs1.levels[0].processors.clear();
  Level one(cs1, solo);
  SplitResult r;
  two.step_once();
  one.step_once();
  const auto start = owners(two);
  r.min_local = 1 << 30;
  for (uint64_t s = 1; s < steps; ++s) {
    two.step_once();
    one.step_once();
    int local = static_cast<int>(two.particles().n_local());
    MPI_Allreduce(MPI_IN_PLACE, &local, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
    r.min_local = std::min(r.min_local, local);
  }
  const auto end = owners(two);
  for (const auto& [id, o] : start) r.migrated += end.at(id) != o ? 1 : 0;
  const auto a = gather(two), b = local_all(one);
  EXPECT_EQ(a.size(), b.size());
  for (const auto& [id, s] : b) {
    const auto it = a.find(id);
    if (it == a.end()) {
      r.worst = 1e300;
      return r;
    }
    r.max_spin = std::max(r.max_spin, norm(s.omega));
    for (int k = 0; k < 3; ++k) {
      r.worst = std::max(r.worst, std::fabs(it->second.x[k] - s.x[k]));
      r.worst = std::max(r.worst, std::fabs(it->second.v[k] - s.v[k]));
      r.worst = std::max(r.worst, std::fabs(it->second.omega[k] - s.omega[k]));
    }
  }
  return r;
}

}  // namespace

TEST(TwoRanks, ObliqueCollisionAcrossTheBorderMatchesOneRankBitForBit) {
  // Particle 0 on rank 0, particle 1 on rank 1 (the border is x = 0); offset
  // centres and friction make the tangential history matter. Each rank sees
  // the other particle as a ghost and keeps the history of its own.
  auto cs = load("collision/head_on.toml");
  cs.particles[0].position = {-0.0015, 0.0007, 0.0};
  cs.particles[1].position = {0.0015, 0.0, 0.0};
  cs.levels[0].dt = 1e-7;
  const auto r = split_vs_single(cs, 3000);
  EXPECT_EQ(r.worst, 0.0);
  EXPECT_EQ(r.min_local, 1) << "each rank must hold one particle throughout";
  EXPECT_EQ(r.migrated, 0);
  EXPECT_GT(r.max_spin, 1.0) << "the collision must be oblique with friction (spin in rad/s)";
}

// Gravity tilted by 20 degrees about y: the floor becomes an incline. A sphere
// released on it rolls without slipping (mu = 0.2 > 2/7 tan 20), held by a
// static friction of 2/7 m g sin 20 that only the tangential spring provides.
config::CaseSpec incline(double border_x) {
  auto cs = load("collision/sliding.toml");
  const double th = 20.0 * std::numbers::pi / 180.0;
  cs.gravity = {9.81 * std::sin(th), 0.0, -9.81 * std::cos(th)};
  cs.particles[0].velocity = {};
  cs.particles[0].position.z = 1.4e-3 - 2.9e-7;  // about the equilibrium overlap
  cs.domain.max.x = 2.0 * border_x - cs.domain.min.x;  // the uniform cut lies at border_x
  cs.stability.max_impact_speed = 1.0;
  return cs;
}

TEST(TwoRanks, SphereRollingDownAnInclineAcrossTheBorderKeepsItsTangentialSpring) {
  auto cs = incline(0.03);
  const uint64_t steps = 85000;  // 0.17 s; the sphere crosses x = 0.03 m at about 0.158 s
  const auto r = split_vs_single(cs, steps);
  EXPECT_EQ(r.worst, 0.0);
  EXPECT_EQ(r.migrated, 1);
  // and it rolled as theory says: x = 1/2 (5/7) g sin(20) t^2
  const auto a = [&] {
    auto c = cs;
    c.levels[0].ranks = 2;
    c.levels[0].processors = {2, 1, 1};
    c.levels[0].balance = false;
    Level two(c, quiet());
    for (uint64_t k = 0; k < steps; ++k) two.step_once();
    return gather(two).at(0).x.x;
  }();
  const double t = static_cast<double>(steps) * cs.levels[0].dt;
  const double theory = 0.5 * 5.0 / 7.0 * 9.81 * std::sin(20.0 * std::numbers::pi / 180.0) * t * t;
  EXPECT_NEAR(a / theory, 1.0, 0.01);
}

TEST(TwoRanks, MigrationCarriesEveryParticleWithItsPairAndWallHistory) {
  // Synthetic particles whose history entries encode their own id: after a
  // migration each particle must sit on its owner with exactly its entries,
  // and its force, torque and mass values.
  Comm comm;
  const Vec3 lo{0, 0, 0}, hi{1, 1, 1};
  Decomposition dec({2, 1, 1}, lo, hi);
  Particles p;
  ContactHistory pair, wall;
  pair.clear(0);
  wall.clear(0);
  std::mt19937_64 rng(static_cast<uint64_t>(17 + rank()));
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const int n = 500;
  auto entries = [](int64_t id, bool walls) { return static_cast<size_t>((id * 7 + (walls ? 3 : 0)) % 5); };
  for (int k = 0; k < n; ++k) {
    ParticleInit pi;
    pi.id = rank() * 100000 + k;
    pi.radius = 1e-3 * (1.0 + u(rng));
    pi.density = 1000.0;
    pi.x = {u(rng), u(rng), u(rng)};
    pi.v = {u(rng), 0.0, 0.0};
    p.add(pi);
    p.f.back() = {static_cast<double>(pi.id), 1.0, 2.0};
    p.torque.back() = {3.0, static_cast<double>(pi.id), 4.0};
    for (ContactHistory* h : {&pair, &wall}) {
      const bool walls = h == &wall;
      std::vector<int64_t> keys;
      std::vector<Vec3> vals;
      for (size_t e = 0; e < entries(pi.id, walls); ++e) {
        keys.push_back(walls ? -1 - static_cast<int64_t>(e) : pi.id + 1 + static_cast<int64_t>(e));
        vals.push_back({static_cast<double>(pi.id), static_cast<double>(e), walls ? -1.0 : 1.0});
      }
      h->append(keys.data(), vals.data(), keys.size());
    }
  }
  migrate(comm, dec, p, pair, wall);
  size_t total = p.n_local();
  MPI_Allreduce(MPI_IN_PLACE, &total, 1, MPI_UNSIGNED_LONG, MPI_SUM, MPI_COMM_WORLD);
  EXPECT_EQ(total, 2u * n);
  ASSERT_EQ(pair.particles(), p.n_local());
  ASSERT_EQ(wall.particles(), p.n_local());
  int arrived = 0;
  for (size_t i = 0; i < p.n_local(); ++i) {
    const int64_t id = p.id[i];
    arrived += (id / 100000) != rank() ? 1 : 0;
    EXPECT_EQ(dec.owner(p.x[i]), rank());
    EXPECT_EQ(p.f[i].x, static_cast<double>(id));
    EXPECT_EQ(p.torque[i].y, static_cast<double>(id));
    for (ContactHistory* h : {&pair, &wall}) {
      const bool walls = h == &wall;
      ASSERT_EQ(static_cast<size_t>(h->first[i + 1] - h->first[i]), entries(id, walls)) << id;
      for (int32_t e = h->first[i]; e < h->first[i + 1]; ++e) {
        const auto q = static_cast<size_t>(e - h->first[i]);
        EXPECT_EQ(h->key[static_cast<size_t>(e)],
                  walls ? -1 - static_cast<int64_t>(q) : id + 1 + static_cast<int64_t>(q));
        EXPECT_EQ(h->value[static_cast<size_t>(e)],
                  (Vec3{static_cast<double>(id), static_cast<double>(q), walls ? -1.0 : 1.0}));
      }
    }
  }
  EXPECT_GT(arrived, 100) << "about half of the other rank's particles should have arrived";
}

TEST(TwoRanks, SettledBedFloorForceCountsEveryParticleOnce) {
  // Ghosts near the border also lie on the floor: only owners may touch walls.
  auto cs = load("settled_bed/box.toml");
  cs.insertions[0].count = 600;
  cs.time.end = 0.12;
  cs.levels[0].ranks = 2;
  cs.levels[0].processors = {2, 1, 1};
  Level level(cs, quiet());
  while (level.time() < cs.time.end) level.step_once();
  // Average the floor force over 0.05 s (it sways); compare with the weight.
  const int floor = level.walls().find("floor");
  double f = 0.0;
  const int n = static_cast<int>(0.05 / level.dt());
  for (int k = 0; k < n; ++k) {
    level.step_once();
    double fz = -level.wall_forces()[static_cast<size_t>(floor)].z;
    MPI_Allreduce(MPI_IN_PLACE, &fz, 1, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
    f += fz;
  }
  f /= n;
  const auto b = level.mass_balance();
  EXPECT_EQ(b.present, 600);
  const double weight = b.present_mass * 9.81;
  EXPECT_NEAR(f / weight, 1.0, 0.01);
  int local = static_cast<int>(level.particles().n_local());
  MPI_Allreduce(MPI_IN_PLACE, &local, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
  EXPECT_GT(local, 200) << "the balanced split should give each rank a share";
}

TEST(TwoRanks, SmallDischargeDoesNotDependOnTheRankCount) {
  auto cs = load("quickstart/case.toml");
  cs.insertions[0].count = 1200;
  cs.time.end_plus = 0.4;
  cs.probes[0].window_start = 0.1;
  cs.probes[0].window_end = 0.4;
  cs.output.snapshot_interval = 0.0;
  cs.levels[0].ranks = 2;
  Level two(cs, quiet());
  two.run();
  const auto w2 = two.probes()[0].window_stats();
  const auto b2 = two.mass_balance();
  EXPECT_EQ(b2.inserted, b2.present + b2.removed);
  EXPECT_EQ(b2.inserted, 1200);
  if (rank() == 0) {
    auto cs1 = cs;
    cs1.levels[0].ranks = 1;
    LevelOptions solo = quiet();
    solo.single_rank = true;
    Level one(cs1, solo);
    one.run();
    const auto w1 = one.probes()[0].window_stats();
    std::printf("discharge: 1 rank %.4f +- %.4f kg/s, 2 ranks %.4f +- %.4f kg/s\n", w1.mean, w1.stddev, w2.mean,
                w2.stddev);
    EXPECT_GT(w2.samples, 20u);
    EXPECT_LT(std::fabs(w1.mean - w2.mean), std::max(w1.stddev, w2.stddev));
  }
  MPI_Barrier(MPI_COMM_WORLD);
}

TEST(TwoRanks, CheckpointWrittenOnTwoRanksContinuesBitForBitOnTwoAndRestartsOnOne) {
  auto cs = timed_hopper(600);
  cs.levels[0].ranks = 2;
  const uint64_t n = 6000;
  cs.output.checkpoint_interval = static_cast<double>(n) * cs.levels[0].dt;
  const fs::path base = fs::temp_directory_path() / "mlcg_mpi_ckpt";
  const fs::path straight = base / "straight", split = base / "split", single = base / "single";
  if (rank() == 0) fs::remove_all(base);
  MPI_Barrier(MPI_COMM_WORLD);
  std::map<int64_t, State> ref;
  {
    LevelOptions o = quiet();
    o.out_dir = straight;
    o.max_steps = 2 * n;
    Level level(cs, o);
    level.run();
    ref = gather(level);
  }
  {
    LevelOptions o = quiet();
    o.out_dir = split;
    o.max_steps = n;
    Level level(cs, o);
    level.run();
  }
  {
    LevelOptions o = quiet();
    o.out_dir = split;
    o.restart = split / "checkpoint.h5";
    o.max_steps = n;
    Level level(cs, o);
    level.run();
    const auto again = gather(level);
    ASSERT_EQ(again.size(), ref.size());
    bool identical = true;
    for (const auto& [id, s] : ref) {
      const auto& q = again.at(id);
      identical = identical && std::memcmp(&q, &s, sizeof(State)) == 0;
    }
    EXPECT_TRUE(identical) << "2 ranks: N + restart + N differs from 2N";
  }
  if (rank() == 0) {  // the 2-rank checkpoint, continued on one rank
    auto cs1 = cs;
    cs1.levels[0].ranks = 1;
    LevelOptions o = quiet();
    o.single_rank = true;
    o.out_dir = single;
    o.restart = split / "checkpoint.h5";
    o.max_steps = 0;
    Level level(cs1, o);
    EXPECT_EQ(level.step(), 2 * n);
    const auto loaded = local_all(level);
    EXPECT_EQ(loaded.size(), ref.size());
    bool identical = loaded.size() == ref.size();
    for (const auto& [id, s] : ref) identical = identical && loaded.count(id) && loaded.at(id).x == s.x;
    EXPECT_TRUE(identical) << "one rank must load every particle of the 2-rank checkpoint";
    o.max_steps = 2000;
    Level cont(cs1, o);
    EXPECT_EQ(cont.run(), RunStatus::StepLimit);
    const auto b = cont.mass_balance();
    EXPECT_EQ(b.inserted, b.present + b.removed);
    EXPECT_EQ(b.inserted, 600);
  }
  MPI_Barrier(MPI_COMM_WORLD);
  if (rank() == 0) fs::remove_all(base);
}
