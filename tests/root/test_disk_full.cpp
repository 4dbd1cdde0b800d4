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
#include <map>
#include <optional>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

#include "launch_support.hpp"
#include "io/h5.hpp"

namespace fs = std::filesystem;

namespace {

using launch_support::edited_case;
using launch_support::kBin;
using launch_support::kSrc;
using mlcg::test::fresh_temp_path;
using mlcg::test::read_json;
using mlcg::test::slurp;
using mlcg::test::temp_path;

int sh(const std::string& cmd) {
  const int s = std::system(cmd.c_str());
  if (WIFSIGNALED(s)) return 128 + WTERMSIG(s);
  return WIFEXITED(s) ? WEXITSTATUS(s) : -1;
}

// A tmpfs of `kib` KiB mounted for one test, unmounted by the destructor.
class TinyDisk {
 public:
  explicit TinyDisk(int kib) : dir_(temp_path("full")) {
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
  return edited_case(rel, {{"snapshot_interval = 0.05", "snapshot_interval = " + every}}, "full_" + tag);
}

// The snapshots a level listed before the disk filled all open as HDF5 files.
void expect_listed_snapshots_intact(const fs::path& level_dir) {
  const fs::path index = level_dir / "particles" / "index.json";
  ASSERT_TRUE(fs::exists(index)) << level_dir;
  const auto j = read_json(index);
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
  const fs::path run = disk.dir() / "run", err = temp_path("full_err");
  const int rc = sh(kBin + "/dem_level " + c.string() + " --out " + run.string() + " --quiet 2> " + err.string());
  const std::string stderr_text = slurp(err);
  EXPECT_EQ(rc, 3) << stderr_text;  // failed, not a crash (139) nor an uncaught exception (1)
  EXPECT_NE(stderr_text.find("No space left on device"), std::string::npos) << stderr_text;
  EXPECT_NE(stderr_text.find(run.string() + "/"), std::string::npos) << "the file is not named: " << stderr_text;
  const auto s = read_json(run / "summary.json");
  EXPECT_EQ(s["status"], "failed");
  EXPECT_NE(s["reason"].get<std::string>().find("No space left on device"), std::string::npos) << s["reason"];
  const std::string log = slurp(run / "log.txt");
  EXPECT_NE(log.find("STOPPED: cannot write the run's output"), std::string::npos) << log;
  expect_listed_snapshots_intact(run);
  mlcg::test::remove_case_copy(c);
  fs::remove(err);
}

namespace {
// `mlcg run` of `rel` with a snapshot every millisecond into disk/run; its output in `text`.
int mlcg_run_on(const TinyDisk& disk, const std::string& rel, std::string& text) {
  const fs::path c = frequent_snapshots(rel, "0.001", fs::path(rel).stem().string());
  const fs::path out = temp_path("full_out");
  const int rc = sh(kBin + "/mlcg run " + c.string() + " --out " + (disk.dir() / "run").string() + " --quiet > " +
                    out.string() + " 2>&1");
  text = slurp(out);
  mlcg::test::remove_case_copy(c);
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
      const std::string status = read_json(summary)["status"];
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

// ---- the disk fills at a chosen write (issue 13, fault matrix) ----

namespace {
using launch_support::fingerprint;

// Fills the file system of `dir` with `dir`/filler until `leave` bytes are free; with `leave` = 0 until a
// write fails.
void fill(const fs::path& dir, uintmax_t leave) {
  const uintmax_t page = 4096, free = fs::space(dir).available;
  std::ofstream f(dir / "filler", std::ios::binary | std::ios::app);
  const std::string block(page, 'x');
  for (uintmax_t n = free > leave ? (free - leave) / page : 0; n > 0 && f.write(block.data(), block.size()); --n) {
  }
  while (leave == 0 && f.put('x') && f.flush()) {
  }
}

void expect_no_temporary_files(const fs::path& dir) {
  for (const auto& e : fs::recursive_directory_iterator(dir))
    EXPECT_EQ(e.path().filename().string().find(".tmp."), std::string::npos) << e.path();
}

// The quickstart hierarchy writing nothing big but its consistent checkpoints (no snapshots, no grids).
// Only the consistent sets mid-run: no snapshots, grids, or the levels' own periodic checkpoints (whether a
// level's own checkpoint at t = 0.2 s came before or after the disk filled depended on the run's speed: under
// the sanitizers it came after, and that file, not the next set's, was the one that did not fit).
const std::vector<std::pair<std::string, std::string>> kCheckpointsOnly = {
    {"snapshot_interval = 0.05", "snapshot_interval = 10.0"},
    {"checkpoint_interval = 0.2", "checkpoint_interval = 10.0"},
    {"[[grids]]\nname = \"hopper\"", "[[grids]]\nname = \"unused\""},
    {"output_interval = 0.02", "output_interval = 10.0"}};
}  // namespace

namespace {
// What one fill did to the hierarchy on the tiny disk.
struct Filled {
  std::optional<int> code;  // the launcher's exit code (none: it did not end within 2 min)
  std::string out;          // its output
  std::map<std::string, size_t> sets;  // the checkpoints folder when the disk filled
};

// Runs `mlcg ARGS` until the consistent set reaches interval k, then fills the disk until half that set's size is
// left (`half_set`) or nothing, and waits for the launcher.
Filled fill_at(const TinyDisk& disk, const fs::path& dir, const std::vector<std::string>& args, uint64_t k,
               bool half_set, const fs::path& log) {
  Filled f;
  const pid_t pid = launch_support::start_mlcg(args, log);
  launch_support::KillOnExit guard{pid};
  if (!launch_support::wait_for_checkpoint(dir, k, pid)) {
    ADD_FAILURE() << slurp(log);
    return f;
  }
  uintmax_t set = 0;
  const auto m = read_json(dir / "checkpoints" / "manifest.json");
  for (const auto& e : fs::directory_iterator(dir / "checkpoints" / fs::path(m["coupler"].get<std::string>()).parent_path()))
    set += e.file_size();
  fill(disk.dir(), half_set ? set / 2 : 0);
  f.sets = fingerprint(dir / "checkpoints");
  // a write in flight when the disk filled is a temporary name, not part of a set: it must go, not stay
  std::erase_if(f.sets, [](const auto& e) { return e.first.find(".tmp.") != std::string::npos; });
  f.code = launch_support::wait_exit_within(pid, 120.0);
  guard.pid = -1;
  f.out = slurp(log);
  return f;
}

// The run failed without a crash, naming the full disk; every file of the sets there when the disk filled, the
// manifest included, is there unchanged; no process and no temporary file is left.
void expect_failed_keeping_the_sets(const fs::path& dir, const Filled& f) {
  ASSERT_TRUE(f.code.has_value()) << f.out;
  EXPECT_NE(*f.code, 0) << f.out;
  EXPECT_EQ(f.out.find("signal 11"), std::string::npos) << f.out;
  EXPECT_NE(f.out.find(": No space left on device"), std::string::npos) << f.out;
  const auto after = fingerprint(dir / "checkpoints");
  for (const auto& [file, hash] : f.sets) {
    ASSERT_TRUE(after.count(file)) << file << " was removed after the disk filled";
    EXPECT_EQ(after.at(file), hash) << file << " changed after the disk filled";
  }
  launch_support::expect_no_process_left(dir);
  expect_no_temporary_files(dir);
  std::istringstream lines(f.out);
  for (std::string line; std::getline(lines, line);)
    if (line.rfind("mlcg: ", 0) == 0 && (line.find("No space left") != std::string::npos ||
                                         line.find("process was stopped") != std::string::npos))
      std::printf("%s\n", line.c_str());
}
}  // namespace

// The disk fills twice, each time after a consistent set: first so that half that set's size is left (the next
// set cannot be written: the level whose checkpoint does not fit is named with the file), then to the last byte
// (every write fails, the summaries' too: the launcher still names what failed). Each time the sets on disk stay
// as they were, and once there is room again `mlcg resume` continues; the run ends with the result of a run on a
// roomy disk.
TEST(DiskFull, ConsistentSetsThatDoNotFitKeepTheLastOneAndTheRunResumesToTheSameResult) {
  TinyDisk disk(64 * 1024);
  if (!disk.skip_reason().empty()) GTEST_SKIP() << disk.skip_reason();
  const fs::path cfile = edited_case("cases/quickstart/mlcg.toml", kCheckpointsOnly, "full_sets");
  const fs::path ref = temp_path("full_sets_ref"), dir = disk.dir() / "run", out = ref.string() + ".run";
  ASSERT_EQ(sh(kBin + "/mlcg run " + cfile.string() + " --out " + ref.string() + " --quiet > " + ref.string() +
               ".out 2>&1"),
            0) << slurp(ref.string() + ".out");
  Filled f = fill_at(disk, dir, {"run", cfile.string(), "--out", dir.string(), "--quiet"}, 1000, true, out);
  expect_failed_keeping_the_sets(dir, f);
  EXPECT_NE(f.out.find("mlcg: level '"), std::string::npos) << "no level named: " << f.out;
  const std::string named =
      "failed: cannot write the run's output: write failed for '" + (dir / "checkpoints" / "i").string();
  const size_t at = f.out.find(named);
  ASSERT_NE(at, std::string::npos) << "the checkpoint is not named: " << f.out;
  const std::string first = f.out.substr(at, f.out.find('\'', at + named.size()) - at);  // that set's file
  fs::remove(disk.dir() / "filler");

  f = fill_at(disk, dir, {"resume", dir.string(), "--quiet"}, 2000, false, out);
  expect_failed_keeping_the_sets(dir, f);
  // Nothing can record which level failed now: the launcher names the first process to end (often the coupler,
  // which that level's failure stopped); the level's own message is on stderr.
  EXPECT_TRUE(f.out.find("mlcg: level '") != std::string::npos || f.out.find("mlcg: coupler (pid") != std::string::npos)
      << "nothing named: " << f.out;
  EXPECT_NE(f.out.find("failed: cannot write the run's output: write failed for '" + dir.string()), std::string::npos)
      << "no level said what it could not write: " << f.out;
  if (fs::exists(dir / "summary.json")) {  // none when not even the first attempt's fitted
    EXPECT_TRUE(nlohmann::json::parse(slurp(dir / "summary.json"), nullptr, false).is_object()) << "a summary cut short";
  }
  EXPECT_EQ(f.out.find(first), std::string::npos) << "the earlier failure named again: " << f.out;
  fs::remove(disk.dir() / "filler");

  ASSERT_EQ(sh(kBin + "/mlcg resume " + dir.string() + " --quiet >> " + out.string() + " 2>&1"), 0) << slurp(out);
  launch_support::expect_same_result(dir, ref);
  launch_support::remove_run(ref);
  fs::remove(out);
  mlcg::test::remove_case_copy(cfile);
}

// A single level through `mlcg run`, checkpointing every 0.01 s, on a disk filled to the last byte once its first
// checkpoint and summary exist (at t = 0.01 s of 0.1 s): the next checkpoint cannot be written, nor can the summary
// after it. The level and the launcher say so and end with code 3; every file written before stays whole (the
// summary as it was, not half-written); and that checkpoint, continued on a roomy disk, ends as an uninterrupted
// run does.
TEST(DiskFull, ACheckpointAndTheSummaryThatDoNotFitLeaveTheLastOnesWholeAndRestartable) {
  TinyDisk disk(64 * 1024);
  if (!disk.skip_reason().empty()) GTEST_SKIP() << disk.skip_reason();
  const fs::path cfile = edited_case("cases/quickstart/case.toml",
                                     {{"snapshot_interval = 0.05", "snapshot_interval = 10.0"},
                                      {"checkpoint_interval = 0.2", "checkpoint_interval = 0.01"},
                                      {"output_interval = 0.02", "output_interval = 10.0"},
                                      {"end = { event = \"open\", plus = 0.5 }", "end = 0.1"}},
                                     "full_single");
  const fs::path ref = temp_path("full_single_ref"), dir = disk.dir() / "run", out = ref.string() + ".run";
  ASSERT_EQ(sh(kBin + "/dem_level " + cfile.string() + " --out " + ref.string() + " --quiet"), 0);
  fill(disk.dir(), 1024 * 1024);  // the last MiB then fills in milliseconds, long before the run's end
  const pid_t pid = launch_support::start_mlcg({"run", cfile.string(), "--out", dir.string(), "--quiet"}, out);
  launch_support::KillOnExit guard{pid};
  for (int i = 0; i < 6000 && !fs::exists(dir / "summary.json"); ++i) usleep(10000);  // after the first checkpoint
  ASSERT_TRUE(fs::exists(dir / "checkpoint.h5")) << slurp(out);
  fill(disk.dir(), 0);
  auto before = fingerprint(dir);
  before.erase("log.txt");  // appends may still fill its last page
  const auto code = launch_support::wait_exit_within(pid, 120.0);
  guard.pid = -1;
  const std::string text = slurp(out);
  EXPECT_EQ(code, 3) << text;
  EXPECT_NE(text.find("dem_level: level 'main' failed: cannot write the run's output: write failed for '" +
                      (dir / "checkpoint.h5").string() + "': No space left on device"),
            std::string::npos) << text;
  EXPECT_NE(text.find("mlcg: cannot add the CPU time to the summary: write failed for '" +
                      (dir / "summary.json").string() + "': No space left on device"),
            std::string::npos) << text;
  EXPECT_NE(text.find(": failed (summary.json could not be updated since, it says running) =="), std::string::npos)
      << text;
  auto after = fingerprint(dir);
  after.erase("log.txt");
  EXPECT_EQ(after, before) << "a file written before the disk filled changed";
  EXPECT_EQ(read_json(dir / "summary.json")["status"], "running") << "the summary was rewritten";
  expect_no_temporary_files(dir);

  // The checkpoint left behind continues (on a roomy disk) to the uninterrupted run's end.
  const fs::path copy = fresh_temp_path("full_single_copy");
  fs::copy(dir, copy, fs::copy_options::recursive);
  fs::remove(disk.dir() / "filler");
  ASSERT_EQ(sh(kBin + "/dem_level " + cfile.string() + " --out " + copy.string() + " --restart " +
               (copy / "checkpoint.h5").string() + " --quiet"),
            0);
  EXPECT_EQ(slurp(copy / "series.csv"), slurp(ref / "series.csv"));
  EXPECT_EQ(read_json(copy / "summary.json")["mass_balance"],
            read_json(ref / "summary.json")["mass_balance"]);
  for (const auto& d : {ref, copy}) fs::remove_all(d);
  fs::remove(out);
  mlcg::test::remove_case_copy(cfile);
}

// A level on two ranks whose snapshots fill the disk: rank 0's write error reaches both ranks, the level ends
// with code 3 naming the file, and no rank is left.
TEST(DiskFull, ATwoRankLevelStopsOnBothRanksNamingTheFile) {
  TinyDisk disk(2048);
  if (!disk.skip_reason().empty()) GTEST_SKIP() << disk.skip_reason();
  const fs::path cfile = edited_case("cases/quickstart/case.toml",
                                     {{"snapshot_interval = 0.05", "snapshot_interval = 0.001"},
                                      {"dt = 1.2e-5", "dt = 1.2e-5\nranks = 2"}},
                                     "full_ranks");
  const fs::path dir = disk.dir() / "run", out = temp_path("full_ranks").string() + ".out";
  const int rc = sh("timeout 300 " + kBin + "/mlcg run " + cfile.string() + " --out " + dir.string() + " --quiet > " +
                    out.string() + " 2>&1");
  const std::string text = slurp(out);
  EXPECT_EQ(rc, 3) << text;
  EXPECT_NE(text.find("No space left on device"), std::string::npos) << text;
  EXPECT_NE(text.find(dir.string() + "/"), std::string::npos) << "the file is not named: " << text;
  EXPECT_NE(text.find("level 'main' (alpha 1, 2 rank(s))"), std::string::npos) << text;
  for (const auto& p : launch_support::processes_naming(dir)) ADD_FAILURE() << "still running: " << p;
  expect_listed_snapshots_intact(dir);
  fs::remove(out);
  mlcg::test::remove_case_copy(cfile);
}
