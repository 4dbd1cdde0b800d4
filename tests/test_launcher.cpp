// `mlcg run` on a single-level case starts one dem_level and no coupler, leaves
// a complete run folder, and refuses a bad case before starting anything; on a
// two-level case it starts the coupler and both levels.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <sys/wait.h>
#include <unistd.h>

#include <nlohmann/json.hpp>

#include "run_checks.hpp"

using run_checks::check_region;
using run_checks::read_json;

namespace fs = std::filesystem;

namespace {
int run(const std::string& cmd) {
  const int s = std::system(cmd.c_str());
  return WIFEXITED(s) ? WEXITSTATUS(s) : -1;
}
const std::string kBin = MLCG_BIN_DIR;
const std::string kSrc = MLCG_SOURCE_DIR;

}  // namespace

TEST(Launcher, RunsASingleLevelCaseToACompleteRunFolder) {
  const fs::path dir = fs::temp_directory_path() / ("mlcg_launch_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  const fs::path log = dir.string() + ".out";
  ASSERT_EQ(run(kBin + "/mlcg run " + kSrc + "/cases/collision/head_on.toml --out " + dir.string() + " > " +
                log.string() + " 2>&1"),
            0);
  std::ifstream out(log);
  const std::string text((std::istreambuf_iterator<char>(out)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("no coupler needed"), std::string::npos) << text;
  EXPECT_NE(text.find("completed"), std::string::npos) << text;
  for (const char* f : {"summary.json", "series.csv", "log.txt", "checkpoint.h5", "particles.xmf", "case.toml"})
    EXPECT_TRUE(fs::exists(dir / f)) << f;
  std::ifstream in(dir / "summary.json");
  const auto j = nlohmann::json::parse(in);
  EXPECT_EQ(j["status"], "completed");
  EXPECT_EQ(j["levels"][0]["particles_final"], 2);
  EXPECT_EQ(j["levels"][0]["particle_steps"], 2 * 5000);
  // No stray temporary files are left behind.
  for (const auto& e : fs::recursive_directory_iterator(dir))
    EXPECT_EQ(e.path().string().find(".tmp."), std::string::npos) << e.path();
  fs::remove_all(dir);
  fs::remove(log);
}

TEST(Launcher, RefusesABadCaseWithFileLineAndKey) {
  const fs::path bad = fs::temp_directory_path() / ("mlcg_bad_" + std::to_string(::getpid()) + ".toml");
  int line = 0;
  {
    std::ifstream src(kSrc + "/cases/collision/head_on.toml");
    std::string text((std::istreambuf_iterator<char>(src)), std::istreambuf_iterator<char>());
    const size_t at = text.find("poisson_ratio = 0.25");
    line = 1 + static_cast<int>(std::count(text.begin(), text.begin() + static_cast<long>(at), '\n'));
    text.replace(at, 20, "poisson_ratio = 0.75");
    std::ofstream(bad) << text;
  }
  const fs::path log = bad.string() + ".out";
  EXPECT_EQ(run(kBin + "/mlcg run " + bad.string() + " --out " + bad.string() + ".run > " + log.string() + " 2>&1"),
            2);
  std::ifstream out(log);
  const std::string text((std::istreambuf_iterator<char>(out)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find(bad.filename().string() + ":" + std::to_string(line) + ": materials[0].poisson_ratio"), std::string::npos) << text;
  EXPECT_FALSE(fs::exists(bad.string() + ".run")) << "a refused case must not start a run";
  fs::remove(bad);
  fs::remove(log);
}

TEST(Launcher, StartsAMultiRankLevelThroughMpirun) {
  const fs::path dir = fs::temp_directory_path() / ("mlcg_launch2_" + std::to_string(::getpid()));
  const fs::path cfile = dir.string() + ".toml";
  fs::remove_all(dir);
  {
    std::ifstream src(kSrc + "/cases/collision/head_on.toml");
    std::string text((std::istreambuf_iterator<char>(src)), std::istreambuf_iterator<char>());
    text.replace(text.find("dt = 1e-7"), 9, "dt = 1e-7\nranks = 2");
    std::ofstream(cfile) << text;
  }
  ASSERT_EQ(run(kBin + "/mlcg run " + cfile.string() + " --out " + dir.string() + " --quiet > /dev/null 2>&1"), 0);
  std::ifstream in(dir / "summary.json");
  const auto j = nlohmann::json::parse(in);
  EXPECT_EQ(j["status"], "completed");
  EXPECT_EQ(j["levels"][0]["ranks"], 2);
  EXPECT_EQ(j["levels"][0]["performance"]["ranks"], 2);
  EXPECT_EQ(j["levels"][0]["particles_final"], 2);
  fs::remove_all(dir);
  fs::remove(cfile);
}

// A whole two-level run (coupler + two dem_level processes) on the small quickstart hopper: the mass
// handed from the coarse to the fine level is exact per face, the fine level's balance is exact,
// nothing overlaps on insertion, and the fine level carries the discharge.
fs::path run_hierarchy_case(const std::string& name, const std::string& tag) {
  const fs::path dir = fs::temp_directory_path() / ("mlcg_" + tag + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  EXPECT_EQ(run(kBin + "/mlcg run " + kSrc + "/cases/quickstart/" + name + " --out " + dir.string() + " --quiet > " +
                dir.string() + ".out 2>&1"),
            0)
      << "see " << dir.string() << ".out";
  return dir;
}

TEST(MlcgRun, TwoLevelHopperHandsMassOverExactlyAndDischargesThroughTheFineLevel) {
  const fs::path dir = run_hierarchy_case("mlcg.toml", "2lvl");
  const auto s = read_json(dir / "summary.json");
  EXPECT_EQ(s["status"], "completed");
  ASSERT_EQ(s["levels"].size(), 2u);
  EXPECT_EQ(s["probes_from_level"], "fine");
  const double inserted = check_region(dir, s, 0, "fine");
  EXPECT_GT(s["coupling"]["regions"][0]["inserted_particles"].get<int64_t>(), 500);
  // The fine level discharges: its probe saw mass; the coarse level holds the case's particles.
  EXPECT_GT(s["probes"][0]["total_mass_kg"].get<double>(), 0.1 * inserted);
  const auto coarse = read_json(dir / "levels" / "coarse" / "summary.json");
  EXPECT_EQ(coarse["mass_balance"]["inserted"].get<int64_t>(), 313);
  EXPECT_GE(s["coupling"]["overhead_share"].get<double>(), 0.0);
  fs::remove_all(dir);
  fs::remove(dir.string() + ".out");
}

TEST(MlcgRun, ThreeLevelHopperNestsTwoRegionsThroughTheMiddleLevel) {
  const fs::path dir = run_hierarchy_case("mlcg3.toml", "3lvl");
  const auto s = read_json(dir / "summary.json");
  EXPECT_EQ(s["status"], "completed");
  ASSERT_EQ(s["levels"].size(), 3u);
  ASSERT_EQ(s["coupling"]["regions"].size(), 2u);
  EXPECT_EQ(s["probes_from_level"], "fine");
  check_region(dir, s, 0, "coarse");  // alpha 4 -> 2
  const double inserted = check_region(dir, s, 1, "fine");  // alpha 2 -> 1, fed by what region 0 inserted
  EXPECT_GT(s["probes"][0]["total_mass_kg"].get<double>(), 0.1 * inserted);
  fs::remove_all(dir);
  fs::remove(dir.string() + ".out");
}
