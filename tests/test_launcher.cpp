// `mlcg run` on a single-level case starts one dem_level and no coupler, leaves
// a complete run folder, and refuses a bad case before starting anything.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sys/wait.h>

#include <nlohmann/json.hpp>

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
