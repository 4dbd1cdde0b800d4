// A full disk (issue 13 B): runs write into a tiny tmpfs until it is full. A
// single level and every level of a hierarchy end with a clear error naming
// the file, status "failed" in summary.json and the error in log.txt, and no
// process crashes (HDF5 used to segfault in its teardown, rc 139); the files
// written before stay intact. Needs root to mount the tmpfs (skips otherwise);
// label root.
#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

#include "io/h5.hpp"

namespace fs = std::filesystem;

namespace {

const std::string kBin = MLCG_BIN_DIR;
const std::string kSrc = MLCG_SOURCE_DIR;

int sh(const std::string& cmd) {
  const int s = std::system(cmd.c_str());
  if (WIFSIGNALED(s)) return 128 + WTERMSIG(s);
  return WIFEXITED(s) ? WEXITSTATUS(s) : -1;
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  return {(std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>()};
}

// A tmpfs of `kib` KiB mounted for one test, unmounted by the destructor.
class TinyDisk {
 public:
  explicit TinyDisk(int kib) : dir_(fs::temp_directory_path() / ("mlcg_full_" + std::to_string(::getpid()))) {
    if (geteuid() != 0) {
      why_ = "needs root to mount a tmpfs";
      return;
    }
    fs::create_directories(dir_);
    if (sh("mount -t tmpfs -o size=" + std::to_string(kib) + "k tmpfs " + dir_.string() + " 2>/dev/null") != 0)
      why_ = "cannot mount a tmpfs here";
  }
  ~TinyDisk() {
    if (why_.empty()) sh("umount -l " + dir_.string());
    std::error_code ec;
    fs::remove(dir_, ec);
  }
  const std::string& skip_reason() const { return why_; }
  const fs::path& dir() const { return dir_; }

 private:
  fs::path dir_;
  std::string why_;
};

// A case file (outside the tiny disk) from `rel` with a snapshot every `every` s.
fs::path frequent_snapshots(const std::string& rel, const std::string& every, const std::string& tag) {
  std::string text = slurp(kSrc + "/" + rel);
  const std::string from = "snapshot_interval = 0.05";
  const size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos);
  text.replace(at, from.size(), "snapshot_interval = " + every);
  const fs::path c = fs::temp_directory_path() / ("mlcg_full_" + tag + "_" + std::to_string(::getpid()) + ".toml");
  std::ofstream(c) << text;
  return c;
}

// The snapshots a level listed before the disk filled all open as HDF5 files.
void expect_listed_snapshots_intact(const fs::path& level_dir) {
  const fs::path index = level_dir / "particles" / "index.json";
  ASSERT_TRUE(fs::exists(index)) << level_dir;
  const auto j = nlohmann::json::parse(slurp(index));
  size_t opened = 0;
  for (const auto& e : j["entries"]) {
    char name[64];
    std::snprintf(name, sizeof name, "particles_%06llu.h5", e["index"].get<unsigned long long>());
    const fs::path f = level_dir / "particles" / name;
    EXPECT_NO_THROW(mlcg::io::H5Reader r(f)) << f;
    ++opened;
  }
  EXPECT_GT(opened, 0u) << "no snapshot was written before the disk filled";
}

}  // namespace

TEST(DiskFull, SingleLevelStopsNamingTheFileWithAFailedSummaryAndLog) {
  TinyDisk disk(2048);
  if (!disk.skip_reason().empty()) GTEST_SKIP() << disk.skip_reason();
  const fs::path c = frequent_snapshots("cases/quickstart/case.toml", "0.001", "single");
  const fs::path run = disk.dir() / "run", err = fs::temp_directory_path() / ("mlcg_full_err_" + std::to_string(::getpid()));
  const int rc = sh(kBin + "/dem_level " + c.string() + " --out " + run.string() + " --quiet 2> " + err.string());
  const std::string stderr_text = slurp(err);
  EXPECT_EQ(rc, 3) << stderr_text;  // failed, not a crash (139) nor an uncaught exception (1)
  EXPECT_NE(stderr_text.find("No space left on device"), std::string::npos) << stderr_text;
  EXPECT_NE(stderr_text.find(run.string() + "/"), std::string::npos) << "the file is not named: " << stderr_text;
  const auto s = nlohmann::json::parse(slurp(run / "summary.json"));
  EXPECT_EQ(s["status"], "failed");
  EXPECT_NE(s["reason"].get<std::string>().find("No space left on device"), std::string::npos) << s["reason"];
  const std::string log = slurp(run / "log.txt");
  EXPECT_NE(log.find("STOPPED: cannot write the run's output"), std::string::npos) << log;
  expect_listed_snapshots_intact(run);
  fs::remove(c);
  fs::remove(err);
}

namespace {
// `mlcg run` of `rel` with a snapshot every millisecond into disk/run; its output in `text`.
int mlcg_run_on(const TinyDisk& disk, const std::string& rel, std::string& text) {
  const fs::path c = frequent_snapshots(rel, "0.001", fs::path(rel).stem().string());
  const fs::path out = fs::temp_directory_path() / ("mlcg_full_out_" + std::to_string(::getpid()));
  const int rc = sh(kBin + "/mlcg run " + c.string() + " --out " + (disk.dir() / "run").string() + " --quiet > " +
                    out.string() + " 2>&1");
  text = slurp(out);
  fs::remove(c);
  fs::remove(out);
  return rc;
}
}  // namespace

TEST(DiskFull, EveryLevelOfAHierarchyFailsCleanlyWithoutACrash) {
  TinyDisk disk(3072);
  if (!disk.skip_reason().empty()) GTEST_SKIP() << disk.skip_reason();
  std::string text;
  EXPECT_NE(mlcg_run_on(disk, "cases/quickstart/mlcg.toml", text), 0) << text;
  EXPECT_EQ(text.find("signal 11"), std::string::npos) << text;
  EXPECT_EQ(text.find("code 139"), std::string::npos) << text;
  EXPECT_NE(text.find("No space left on device"), std::string::npos) << text;
  // Each level says how it ended (failed, or interrupted when the launcher stopped it first): in its
  // summary.json, or on stderr when there was no room left for that.
  for (const std::string level : {"coarse", "fine"}) {
    const fs::path summary = disk.dir() / "run" / "levels" / level / "summary.json";
    if (fs::exists(summary)) {
      const std::string status = nlohmann::json::parse(slurp(summary))["status"];
      EXPECT_TRUE(status == "failed" || status == "interrupted") << level << ": " << status;
    } else {
      EXPECT_NE(text.find("dem_level: level '" + level + "' failed: "), std::string::npos) << level << ": " << text;
    }
  }
}

TEST(DiskFull, SingleLevelThroughTheLauncherEndsWithTheLevelsCode) {
  TinyDisk disk(2048);
  if (!disk.skip_reason().empty()) GTEST_SKIP() << disk.skip_reason();
  std::string text;
  EXPECT_EQ(mlcg_run_on(disk, "cases/quickstart/case.toml", text), 3) << text;  // the level's "failed"
  EXPECT_EQ(text.find("terminate called"), std::string::npos) << text;  // the launcher does not abort either
  EXPECT_NE(text.find("== " + (disk.dir() / "run").string() + ": failed =="), std::string::npos) << text;
}
