// Checkpoint and restart: N steps + restart + N steps equals 2N steps bit for
// bit (same binary), through the real code path (checkpoint files on disk,
// a new Level reading them), in a scene with insertion, an event, removal,
// a probe and a cell grid all active across the checkpoint. A checkpoint of
// another scene, or a damaged one, is refused before step 1 naming what differs. run() (whose steps
// leave their second half-kick to the next step's first half) and step_once() give the same state.
#include <gtest/gtest.h>

#include <hdf5.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <functional>
#include <sstream>
#include <string>
#include <type_traits>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "io/h5.hpp"
#include "files.hpp"
#include "scene_support.hpp"

using namespace mlcg;
using namespace mlcg::test;
namespace fs = std::filesystem;

namespace {

config::CaseSpec small_hopper(uint64_t checkpoint_steps) {
  auto cs = timed_hopper(600);
  cs.probes[0].window_start = 0.0;
  cs.output.checkpoint_interval = static_cast<double>(checkpoint_steps) * cs.levels[0].dt;
  return cs;
}

template <class T>
void expect_bitwise(const std::vector<T>& a, const std::vector<T>& b, const std::string& what) {
  ASSERT_EQ(a.size(), b.size()) << what;
  EXPECT_EQ(std::memcmp(a.data(), b.data(), a.size() * sizeof(T)), 0) << what << " differs";
}

}  // namespace

TEST(Restart, NPlusRestartPlusNEqualsTwoNBitForBit) {
  const uint64_t n = 8000;  // t = 0.096 s: the lid opened at 0.05 s; 2N = 0.19 s, particles have left
  const auto cs = small_hopper(n);

  const fs::path straight = fresh_temp_path("restart_straight"), split = fresh_temp_path("restart_split");
  {
    LevelOptions o = quiet();
    o.out_dir = straight;
    o.max_steps = 2 * n;
    Level level(cs, o);
    ASSERT_EQ(level.run(), RunStatus::StepLimit);
  }
  {
    LevelOptions o = quiet();
    o.out_dir = split;
    o.max_steps = n;
    Level level(cs, o);
    ASSERT_EQ(level.run(), RunStatus::StepLimit);
  }
  {
    LevelOptions o = quiet();
    o.out_dir = split;
    o.restart = split / "checkpoint.h5";
    o.max_steps = n;
    Level level(cs, o);
    ASSERT_EQ(level.step(), n);
    ASSERT_EQ(level.run(), RunStatus::StepLimit);
  }
  io::H5Reader a(straight / "checkpoint.h5"), b(split / "checkpoint.h5");
  EXPECT_EQ(a.attr_uint64("/", "step"), 2 * n);
  EXPECT_EQ(b.attr_uint64("/", "step"), 2 * n);
  // The scene really exercised what a restart must carry.
  EXPECT_GT(a.attr_int64("/", "removed"), 0) << "no particle left the domain before 2N";
  EXPECT_GT(a.read<int64_t>("history/pairs/key").size(), 100u) << "too few contacts to test their history";
  for (const char* v : {"particles/x", "particles/v", "particles/omega", "particles/f", "particles/torque",
                        "history/pairs/value", "history/walls/value"})
    expect_bitwise(a.read_vec3(v), b.read_vec3(v), v);
  expect_bitwise(a.read<int64_t>("particles/id"), b.read<int64_t>("particles/id"), "ids");
  expect_bitwise(a.read<int64_t>("history/pairs/key"), b.read<int64_t>("history/pairs/key"), "history keys");
  expect_bitwise(a.read<double>("probes/0/rate"), b.read<double>("probes/0/rate"), "probe samples");
  expect_bitwise(a.read<double>("grids/0/stress6"), b.read<double>("grids/0/stress6"), "grid accumulators");
  expect_bitwise(a.read<uint8_t>("series/rows"), b.read<uint8_t>("series/rows"), "series.csv rows");
  fs::remove_all(straight);
  fs::remove_all(split);
}

// A step checks the crossings before its rebuild, and a restarted level rebuilds at its first step: its crossing
// candidates must come from the loaded positions, or a crossing in that step is lost (the run that wrote the
// checkpoint still had its lists). The probes and the coupling's boundary faces get them in one place; the faces
// did not, and a restart at such a step left a hierarchy's region one coarse particle off its booked mass
// (MlcgRecovery.KilledFineLevel…).
TEST(Restart, ACrossingInTheFirstStepAfterTheCheckpointIsCounted) {
  const auto cs = small_hopper(0);
  const auto counted = [](const Level& l) { return l.probes()[0].state().total_mass + l.probes()[0].open_mass(); };
  uint64_t s = 0;  // the first step of the straight run with a crossing of the probe
  double after = 0.0;
  {
    Level level(cs, quiet());
    for (uint64_t k = 1; k <= 16000 && s == 0; ++k) {
      level.step_once();
      if (counted(level) != 0.0) s = k, after = counted(level);
    }
  }
  ASSERT_GT(s, 1u) << "no particle crossed the probe";
  const fs::path dir = fresh_temp_path("restart_crossing");
  {
    LevelOptions o = quiet();
    o.out_dir = dir;
    o.max_steps = static_cast<int64_t>(s - 1);
    Level level(cs, o);
    ASSERT_EQ(level.run(), RunStatus::StepLimit);
    EXPECT_EQ(counted(level), 0.0);
  }
  LevelOptions o = quiet();
  o.restart = dir / "checkpoint.h5";
  Level level(cs, o);
  level.step_once();
  EXPECT_EQ(counted(level), after) << "the crossing in step " << s << ", the first after the restart";
  fs::remove_all(dir);
}

// ---- a checkpoint of another scene (issue 13) ----------------------------------------------

namespace {

constexpr uint64_t kShort = 2500;  // 0.03 s: three probe samples, particles falling and touching

// Runs `cs` for kShort steps into `dir` (checkpoint.h5 at the end).
void first_part(const config::CaseSpec& cs, const fs::path& dir) {
  LevelOptions o = quiet();
  o.out_dir = dir;
  o.max_steps = kShort;
  Level level(cs, o);
  ASSERT_EQ(level.run(), RunStatus::StepLimit);
}

// The message of restarting `cs` from dir's checkpoint ("" when it starts).
std::string restart_refusal(const config::CaseSpec& cs, const fs::path& dir) {
  LevelOptions o = quiet();
  o.restart = dir / "checkpoint.h5";
  try {
    Level level(cs, o);
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

struct Foreign : ::testing::Test {
  void SetUp() override {
    cs = small_hopper(kShort);
    dir = fresh_temp_path(std::string("restart_") + ::testing::UnitTest::GetInstance()->current_test_info()->name());
    first_part(cs, dir);
  }
  void TearDown() override { fs::remove_all(dir); }
  config::CaseSpec cs;
  fs::path dir;
};

}  // namespace

TEST_F(Foreign, AnotherDensityIsRefusedBeforeStep1NamingIt) {
  auto other = cs;
  other.materials[0].density = 2000.0;
  const std::string msg = restart_refusal(other, dir);
  EXPECT_NE(msg.find("material 'beads' density 1000 in the checkpoint, 2000 in the case"), std::string::npos) << msg;
  EXPECT_NE(msg.find("checkpoint.h5"), std::string::npos) << msg;
}

TEST_F(Foreign, EveryOtherDifferenceIsNamedTogether) {
  auto other = cs;
  other.interactions[1].friction = 0.9;
  other.insertions[0].count = 800;
  other.grids[0].cell_size *= 2.0;
  other.walls.pop_back();
  other.particles.push_back({"beads", 2e-3, {0.0, 0.0, 0.1}, {}, {}, {}});
  const std::string msg = restart_refusal(other, dir);
  for (const char* what : {"interaction between 'beads' and 'steel' friction", "insertion 'fill' count 600 in the "
                           "checkpoint, 800 in the case", "grid 'hopper' cell_size", "wall 'lid' is in the checkpoint "
                           "but not in the case", "particles placed by the case 0 in the checkpoint, 1 in the case"})
    EXPECT_NE(msg.find(what), std::string::npos) << "no '" << what << "' in: " << msg;
}

TEST_F(Foreign, ReorderedMaterialsContinueAsTheSameScene) {
  auto reordered = cs;
  std::swap(reordered.materials[0], reordered.materials[1]);
  const fs::path same = fresh_temp_path("restart_same_order");
  fs::copy(dir, same, fs::copy_options::recursive);
  for (const auto& [spec, folder] : {std::pair(&cs, same), std::pair(&reordered, dir)}) {
    LevelOptions o = quiet();
    o.out_dir = folder;
    o.restart = folder / "checkpoint.h5";
    o.max_steps = kShort;
    Level level(*spec, o);
    ASSERT_EQ(level.run(), RunStatus::StepLimit) << folder;
  }
  io::H5Reader a(same / "checkpoint.h5"), b(dir / "checkpoint.h5");
  ASSERT_EQ(b.attr_uint64("/", "step"), 2 * kShort);
  for (const char* v : {"particles/x", "particles/v", "particles/omega"}) expect_bitwise(a.read_vec3(v), b.read_vec3(v), v);
  fs::remove_all(same);
}

TEST_F(Foreign, AnAddedProbeMeasuresFromTheRestartAndTheOthersAreKept) {
  auto more = cs;
  more.probes.insert(more.probes.begin(), more.probes[0]);  // a new one ahead of the old: matched by name
  more.probes[0].name = "upper";
  more.probes[0].point.z += 0.02;
  LevelOptions o = quiet();
  o.out_dir = dir;
  o.restart = dir / "checkpoint.h5";
  o.max_steps = kShort;
  Level level(more, o);
  const double restart_t = level.time();
  io::H5Reader before(dir / "checkpoint.h5");
  const auto old_rates = before.read<double>("probes/0/rate");
  ASSERT_EQ(level.run(), RunStatus::StepLimit);
  const auto& upper = level.probes()[0].state().samples;
  const auto& outlet = level.probes()[1].state().samples;
  ASSERT_FALSE(upper.empty());
  // Its first sample spans one interval from the restart (not the time since t = 0).
  EXPECT_NEAR(upper.front().t_end, restart_t + 1.0 / cs.probes[0].sample_rate, 1.5 * level.dt());
  ASSERT_GT(outlet.size(), old_rates.size());
  for (size_t k = 0; k < old_rates.size(); ++k) EXPECT_EQ(outlet[k].rate, old_rates[k]) << k;
}

// ---- a damaged checkpoint (issue 13; found by fuzzing, tests/fuzz/fuzz_level_checkpoint) --------

namespace {

template <class T>
hid_t native() {
  if constexpr (std::is_same_v<T, double>) return H5T_NATIVE_DOUBLE;
  else if constexpr (std::is_same_v<T, int32_t>) return H5T_NATIVE_INT32;
  else return H5T_NATIVE_INT64;
}

// Replaces dataset `name` of checkpoint `f` by `values` (`cols` per row), as a disk fault or an edit might.
template <class T>
void replace(const fs::path& f, const std::string& name, const std::vector<T>& values, hsize_t cols = 1) {
  const hid_t file = H5Fopen(f.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
  ASSERT_GE(file, 0);
  ASSERT_GE(H5Ldelete(file, name.c_str(), H5P_DEFAULT), 0) << name;
  const hsize_t dims[2] = {values.size() / cols, cols};
  const hid_t space = H5Screate_simple(cols == 1 ? 1 : 2, dims, nullptr);
  const hid_t ds = H5Dcreate2(file, name.c_str(), native<T>(), space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  if (!values.empty()) {
    ASSERT_GE(H5Dwrite(ds, native<T>(), H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data()), 0);
  }
  H5Dclose(ds);
  H5Sclose(space);
  H5Fclose(file);
}

}  // namespace

TEST_F(Foreign, DamagedCheckpointsAreRefusedNamingTheDataset) {
  const fs::path good = dir / "checkpoint.h5", bad = dir / "damaged.h5";
  io::H5Reader r(good);
  const auto first = r.read<int32_t>("history/pairs/first");
  const auto radius = r.read<double>("particles/radius");
  const auto x = r.read<double>("particles/x");
  const auto cuts = r.read<double>("decomposition/cuts_x");
  ASSERT_GT(radius.size(), 3u);
  ASSERT_EQ(r.read<double>("events/fired_at").size(), 1u);
  struct Damage {
    std::function<void(const fs::path&)> apply;
    std::string expect;
  };
  auto nan_x = x;
  nan_x[3 * 3 + 1] = std::nan("");
  const std::vector<int32_t> cut_first(first.begin(), first.end() - 1);
  const std::vector<double> cut_radius(radius.begin() + 1, radius.end());
  const Damage damages[] = {
      // what the fuzzer found: a heap overflow while the contact history was reordered
      {[&](const fs::path& f) { replace(f, "history/pairs/first", cut_first); },
       "history/pairs/first has " + std::to_string(first.size() - 1) + " entries, expected " +
           std::to_string(first.size()) + " (one per particle, plus one)"},
      {[&](const fs::path& f) { replace(f, "particles/radius", cut_radius); },
       "particles/radius has " + std::to_string(radius.size() - 1) + " entries, expected " +
           std::to_string(radius.size()) + " (one per particle)"},
      {[&](const fs::path& f) { replace(f, "events/fired_at", std::vector<double>{}); },
       "events/fired_at has 0 entries, expected 1 (one per event)"},
      {[&](const fs::path& f) { replace(f, "particles/x", nan_x, 3); },
       "particle 3 (id " + std::to_string(r.read<int64_t>("particles/id")[3]) +
           ") has a value that is not a finite number"},
      {[&](const fs::path& f) { replace(f, "decomposition/cuts_x", std::vector<double>(cuts.rbegin(), cuts.rend())); },
       "decomposition/cuts_x is not an ascending list of finite numbers"},
  };
  for (const auto& d : damages) {
    fs::copy_file(good, bad, fs::copy_options::overwrite_existing);
    d.apply(bad);
    LevelOptions o = quiet();
    o.restart = bad;
    std::string msg;
    try {
      Level level(cs, o);
    } catch (const std::exception& e) {
      msg = e.what();
    }
    EXPECT_NE(msg.find(bad.string() + ": " + d.expect + "; the checkpoint is damaged"), std::string::npos) << msg;
  }
}

// ---- run() and step_once() drive the same steps ---------------------------------------------

namespace {

// 216 particles in a loose lattice above a plane, thrown at up to 1 m/s in all directions: contacts
// with each other and the floor, and neighbour-list rebuilds, within a few hundred steps. No events or
// insertions, so run() lets each step's second half-kick wait for the next step's first half.
config::CaseSpec thrown_lattice() {
  auto cs = load("collision/wall_plane.toml");
  cs.gravity = {0.0, 0.0, -9.81};
  cs.domain.min = {-0.02, -0.02, -0.001};
  cs.domain.max = {0.02, 0.02, 0.04};
  cs.levels[0].dt = 1e-6;
  cs.time.end = 1.0;  // runs stop at their max_steps
  const config::ParticleSpec proto = cs.particles[0];
  cs.particles.clear();
  for (int i = 0; i < 6; ++i)
    for (int j = 0; j < 6; ++j)
      for (int k = 0; k < 6; ++k) {
        config::ParticleSpec p = proto;
        const int q = 36 * i + 6 * j + k;
        p.position = {-0.0075 + 0.003 * i, -0.0075 + 0.003 * j, 0.0015 + 0.003 * k};
        p.velocity = {std::sin(1.1 * q), std::cos(1.7 * q), -std::abs(std::sin(2.3 * q))};
        cs.particles.push_back(p);
      }
  return cs;
}

// A run() of `steps` steps into dir, no snapshots or checkpoints.
LevelOptions driving_options(config::CaseSpec& cs, const fs::path& dir, uint64_t steps) {
  cs.output.snapshot_interval = 0.0;
  cs.output.checkpoint_interval = 0.0;
  LevelOptions o = quiet();
  o.out_dir = dir;
  o.max_steps = static_cast<int64_t>(steps);
  return o;
}

}  // namespace

TEST(Driving, RunEqualsStepOnceBitForBitWithTheSeriesReadingTheWholeStep) {
  const uint64_t steps = 1501, every = 37;
  auto cs = thrown_lattice();
  cs.output.stats_interval = static_cast<double>(every) * cs.levels[0].dt;
  const fs::path dir = fresh_temp_path("driving");
  LevelOptions o = driving_options(cs, dir, steps);
  o.owed_kick_above = 100;  // the owed kick (large levels only by default) for these 216 particles
  Level by_run(cs, o);
  ASSERT_EQ(by_run.run(), RunStatus::StepLimit);

  Level by_step(cs, quiet());
  std::vector<std::string> energies;  // the state's kinetic energy where the series has a row
  for (uint64_t s = 1; s <= steps; ++s) {
    by_step.step_once();
    if (s % every == 0) energies.push_back(fmt::format("{:.9g}", by_step.kinetic_energy()));
  }
  ASSERT_GT(by_step.rebuilds(), 2u) << "the scene should rebuild its lists";
  ASSERT_GT(by_step.contact_stats().pair_contacts, 20) << "the scene should have contacts";
  const Particles &a = by_run.particles(), &b = by_step.particles();
  expect_bitwise(a.x, b.x, "x");
  expect_bitwise(a.v, b.v, "v");
  expect_bitwise(a.omega, b.omega, "omega");
  expect_bitwise(a.f, b.f, "f");
  // series.csv: a header, the row at t = 0, then one every `every` steps (kinetic energy: column 3).
  std::vector<std::string> rows;
  std::istringstream csv(slurp(dir / "series.csv"));
  for (std::string line; std::getline(csv, line);) rows.push_back(line);
  ASSERT_GE(rows.size(), energies.size() + 2);
  for (size_t r = 0; r < energies.size(); ++r) {
    std::istringstream row(rows[r + 2]);
    std::string cell;
    for (int c = 0; c < 3; ++c) std::getline(row, cell, ',');
    EXPECT_EQ(cell, energies[r]) << "row at step " << (r + 1) * every;
  }
  fs::remove_all(dir);
}

// A level between calibrate_kick_above and owed_kick_above particles per rank times both integrations on its
// first steps (3 blocks of 20 steps each way, alternating) and keeps the faster: whichever it keeps, and while it
// alternates, the state is the step-by-step run's to the bit, and the summary names the choice and its times.
TEST(Driving, AnIntegrationChosenByTimingOnThisHostGivesTheStepByStepStateBitForBit) {
  const uint64_t steps = 401;
  auto cs = thrown_lattice();
  const fs::path dir = fresh_temp_path("kick_choice");
  LevelOptions o = driving_options(cs, dir, steps);
  o.calibrate_kick_above = 100;  // these 216 particles are timed both ways
  o.owed_kick_above = 1000000;
  Level timed(cs, o);
  ASSERT_EQ(timed.run(), RunStatus::StepLimit);
  Level by_step(cs, quiet());
  for (uint64_t s = 1; s <= steps; ++s) by_step.step_once();
  const Particles &a = timed.particles(), &b = by_step.particles();
  expect_bitwise(a.x, b.x, "x");
  expect_bitwise(a.v, b.v, "v");
  expect_bitwise(a.omega, b.omega, "omega");
  expect_bitwise(a.f, b.f, "f");
  const auto integration = read_json(dir / "summary.json")["levels"][0]["performance"]["integration"];
  EXPECT_EQ(integration["chosen_by"], "calibration") << integration.dump();
  const std::string kick = integration["kick"];
  EXPECT_TRUE(kick == "fused" || kick == "split") << kick;
  EXPECT_GT(integration["split_seconds"].get<double>(), 0.0);
  EXPECT_GT(integration["fused_seconds"].get<double>(), 0.0);
  EXPECT_EQ(kick == "fused", integration["fused_seconds"].get<double>() < integration["split_seconds"].get<double>());
  fs::remove_all(dir);
}

// The summary says which pair kernel ran: the lattice of one size the one holding radius and mass as loop
// invariants on every step, the same lattice with one particle a tenth larger the general one.
TEST(Driving, TheSummaryNamesThePairKernelOfOneSizeOrOfMixedSizes) {
  for (const bool mixed : {false, true}) {
    auto cs = thrown_lattice();
    if (mixed) cs.particles[100].radius *= 1.1;
    const fs::path dir = fresh_temp_path("pair_kernel");
    Level level(cs, driving_options(cs, dir, 401));
    ASSERT_EQ(level.run(), RunStatus::StepLimit);
    ASSERT_GT(level.contact_stats().pair_contacts, 20);
    const auto kernel = read_json(dir / "summary.json")["levels"][0]["performance"]["pair_kernel"];
    EXPECT_EQ(kernel["one_size"].get<double>(), mixed ? 0.0 : 1.0) << kernel.dump();
    EXPECT_EQ(kernel["mixed"].get<double>(), 0.0) << kernel.dump();  // one material either way
    EXPECT_EQ(kernel["one_material"].get<double>(), mixed ? 1.0 : 0.0) << kernel.dump();
    fs::remove_all(dir);
  }
}
