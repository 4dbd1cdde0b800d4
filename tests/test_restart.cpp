// Checkpoint and restart: N steps + restart + N steps equals 2N steps bit for
// bit (same binary), through the real code path (checkpoint files on disk,
// a new Level reading them), in a scene with insertion, an event, removal,
// a probe and a cell grid all active across the checkpoint.
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>

#include "io/h5.hpp"
#include "scene_support.hpp"

using namespace mlcg;
using namespace mlcg::test;
namespace fs = std::filesystem;

namespace {

config::CaseSpec small_hopper(uint64_t checkpoint_steps) {
  auto cs = load("quickstart/case.toml");
  cs.insertions[0].count = 600;
  cs.events[0].after_insertion = false;
  cs.events[0].mean_speed_below = -1.0;
  cs.events[0].at = 0.05;
  cs.probes[0].window_start = 0.0;
  cs.output.snapshot_interval = 0.0;
  cs.output.checkpoint_interval = static_cast<double>(checkpoint_steps) * cs.levels[0].dt;
  return cs;
}

fs::path fresh_dir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("mlcg_restart_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(d);
  return d;
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

  const fs::path straight = fresh_dir("straight"), split = fresh_dir("split");
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
