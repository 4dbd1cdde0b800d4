// The cells of issue 13's fault matrix (README, "Fault matrix") that no other test covers: kill -9, SIGTERM and
// SIGSTOP of the coupler; SIGTERM of a one-rank level and SIGSTOP of the launcher; kill -9 of a rank, SIGSTOP of a
// rank and SIGTERM of mpirun for a two-rank level; a consistent set holding a level checkpoint of another set or
// another case. Each fault hits a quickstart hierarchy after a consistent checkpoint; the launcher must name the
// failing process with its pid within the limit, leave no process of the run, and `mlcg resume` must end with the
// result of an uninterrupted run (a run depends on the seed only). Faults follow each other in one run folder, each
// resume continuing from the last consistent checkpoint.
#include <gtest/gtest.h>

#include <algorithm>
#include <functional>
#include <optional>

#include "launch_support.hpp"
#include "run_checks.hpp"
#include "scene_support.hpp"

using launch_support::ContinueOnExit;
using launch_support::expect_no_process_left;
using launch_support::expect_resume_completes_as;
using launch_support::expect_same_result;
using launch_support::KillOnExit;
using launch_support::kBin;
using launch_support::pid_of;
using launch_support::processes_naming;
using launch_support::remove_run;
using launch_support::run;
using launch_support::run_hierarchy_case;
using launch_support::running;
using launch_support::short_quickstart;
using launch_support::start_mlcg;
using launch_support::wait_exit_within;
using launch_support::wait_for_checkpoint;
using mlcg::test::read_json;
using mlcg::test::slurp;
using mlcg::test::temp_path;

namespace fs = std::filesystem;

namespace {

// [coupling] timeout of the faulted runs: a hang is noticed after it. Not less: on a loaded machine the levels'
// start (the registration has the same timeout) took more than 5 s.
constexpr double kTimeout = 15.0;

// What the launcher did after one fault.
struct Fault {
  pid_t named = -1;         // the pid of the process status.json calls by the name given (a level: its mpirun)
  pid_t victim = -1;        // the pid that got the signal
  std::optional<int> code;  // the launcher's exit code; none when it did not end within the limit (then killed)
  std::string out;          // its output
};

// Runs `mlcg ARGS` (output to `log`) until the run's consistent checkpoint reaches interval k, sends `sig` to the
// process status.json calls `name` (or to the one `victim` picks), and waits up to `limit` s for the launcher.
Fault fault_at(const fs::path& dir, const std::vector<std::string>& args, uint64_t k, const std::string& name,
               int sig, double limit, const fs::path& log, const std::function<pid_t()>& victim = {}) {
  Fault f;
  const pid_t pid = start_mlcg(args, log);
  KillOnExit guard{pid};
  if (!wait_for_checkpoint(dir, k, pid)) {
    ADD_FAILURE() << "no consistent checkpoint at interval " << k << ":\n" << slurp(log);
    return f;
  }
  f.named = pid_of(dir, name);
  f.victim = victim ? victim() : f.named;
  if (f.named <= 0 || f.victim <= 0) {
    ADD_FAILURE() << "no process to fault: " << slurp(dir / "status.json");
    return f;
  }
  ContinueOnExit wake{f.victim};
  EXPECT_EQ(kill(f.victim, sig), 0);
  f.code = wait_exit_within(pid, limit);
  guard.pid = -1;
  f.out = slurp(log);
  return f;
}

// The fault ended the run within its limit with one of `codes` (two where the launcher's code is that of
// whichever of two processes ends first), naming the process (with its pid) in the launcher's output and as
// the reason of summary.json by `named` followed by `how`, the cause; no process is left.
void expect_named(const fs::path& dir, const Fault& f, std::initializer_list<int> codes, const std::string& named,
                  const std::string& how) {
  ASSERT_TRUE(f.code.has_value()) << "the launcher did not end within the limit:\n" << f.out;
  std::string allowed;
  for (const int c : codes) allowed += (allowed.empty() ? "" : " or ") + std::to_string(c);
  EXPECT_TRUE(std::count(codes.begin(), codes.end(), *f.code) == 1)
      << "the launcher's exit code is " << *f.code << ", not " << allowed << "\n" << f.out;
  const std::string text = named + " (pid " + std::to_string(f.named) + ") " + how;
  EXPECT_NE(f.out.find("mlcg: " + text), std::string::npos) << f.out;
  const auto s = read_json(dir / "summary.json");
  EXPECT_EQ(s["status"], "failed");
  EXPECT_EQ(s["reason"].get<std::string>().rfind(text, 0), 0u) << s["reason"];
  expect_no_process_left(dir);
}

// As expect_named where either of two processes may end first and the launcher reports that one: each
// (code, cause) pair is one way the run may end, and the launcher's code must come with its cause.
void expect_named_either(const fs::path& dir, const Fault& f, const std::vector<std::pair<int, std::string>>& ways,
                         const std::string& named) {
  ASSERT_TRUE(f.code.has_value()) << "the launcher did not end within the limit:\n" << f.out;
  const auto way = std::find_if(ways.begin(), ways.end(), [&](const auto& w) { return w.first == *f.code; });
  ASSERT_NE(way, ways.end()) << "the launcher's exit code is " << *f.code << "\n" << f.out;
  expect_named(dir, f, {way->first}, named, way->second);
}

// A rank of the run's level `level` (a dem_level process under its mpirun), or -1.
std::function<pid_t()> rank_of(const fs::path& dir, const std::string& level) {
  return [=] {
    for (const auto& p : processes_naming(dir)) {
      const std::string cmd = p.substr(p.find(": ") + 2);
      if (cmd.rfind(kBin + "/dem_level ", 0) == 0 && cmd.find("--level " + level + " ") != std::string::npos)
        return static_cast<pid_t>(std::stoi(p));
    }
    return static_cast<pid_t>(-1);
  };
}

// The run folder of a test, its short case and the uninterrupted run of that case to compare with; all removed
// at the end.
struct Chain {
  Chain(const std::string& tag, int fine_ranks)
      : cfile(short_quickstart(kTimeout, fine_ranks, tag)), ref(run_hierarchy_case(cfile.string(), tag + "_ref")),
        dir(temp_path(tag)) {
    fs::remove_all(dir);
  }
  ~Chain() {
    for (const auto& d : {ref, dir}) remove_run(d);
    for (const char* n : {".out1", ".out2", ".out3"}) fs::remove(dir.string() + n);
    mlcg::test::remove_case_copy(cfile);
  }
  std::vector<std::string> run() const { return {"run", cfile.string(), "--out", dir.string(), "--quiet"}; }
  std::vector<std::string> resume() const { return {"resume", dir.string(), "--quiet"}; }
  fs::path log(int n) const { return dir.string() + ".out" + std::to_string(n); }
  fs::path cfile, ref, dir;
};

}  // namespace

// kill -9, SIGTERM and SIGSTOP of the coupler, one after the other, each resumed from the last consistent
// checkpoint. A stopped coupler is noticed by the levels ([coupling] timeout); the launcher names the coupler,
// not the level that timed out first.
TEST(CouplerFaults, KillTermAndStopAreNamedAndTheResumedRunEqualsTheUninterruptedOne) {
  const Chain c("cplf", 1);
  ASSERT_FALSE(HasFailure());
  Fault f = fault_at(c.dir, c.run(), 100, "coupler", SIGKILL, 30.0, c.log(1));
  expect_named(c.dir, f, {128 + SIGKILL}, "coupler", "was killed by signal 9");
  f = fault_at(c.dir, c.resume(), 300, "coupler", SIGTERM, 30.0, c.log(2));
  expect_named(c.dir, f, {2}, "coupler", "exited with code 2: stopped by a signal at interval ");
  f = fault_at(c.dir, c.resume(), 500, "coupler", SIGSTOP, kTimeout + 30.0, c.log(3));
  expect_named(c.dir, f, {3}, "coupler", "went silent: level '");
  EXPECT_NE(f.out.find("no message from the coupler"), std::string::npos) << f.out;
  expect_resume_completes_as(c.dir, c.ref);
}

// SIGTERM of the fine level (it stops as under Ctrl-C and tells the coupler it failed; whichever of the two ends
// first, the level is named), then SIGSTOP of the launcher until every process of the run has ended: nothing
// waits on the launcher, which reports the completed run when woken.
TEST(LevelAndLauncherFaults, SigtermOfALevelIsNamedAndAStoppedLauncherLosesNothing) {
  const Chain c("lvlf", 1);
  ASSERT_FALSE(HasFailure());
  const Fault f = fault_at(c.dir, c.run(), 100, "level 'fine'", SIGTERM, 30.0, c.log(1));
  // The coupler's code (2) when it ends first, the interrupted level's (130) otherwise.
  expect_named(c.dir, f, {2, 130}, "level 'fine'", "failed: interrupted by a signal");

  const pid_t pid = start_mlcg(c.resume(), c.log(2));
  KillOnExit guard{pid};
  ASSERT_TRUE(wait_for_checkpoint(c.dir, 300, pid)) << slurp(c.log(2));
  std::vector<pid_t> children;
  for (const auto& p : processes_naming(c.dir))
    if (std::stoi(p) != pid) children.push_back(std::stoi(p));
  ASSERT_EQ(children.size(), 3u) << "the coupler and two levels";
  ASSERT_EQ(kill(pid, SIGSTOP), 0);
  for (int i = 0; i < 1200 && std::any_of(children.begin(), children.end(), running); ++i) usleep(100000);
  EXPECT_FALSE(std::any_of(children.begin(), children.end(), running)) << "the run did not end with its launcher stopped";
  ASSERT_EQ(kill(pid, SIGCONT), 0);
  const auto code = wait_exit_within(pid, 60.0);
  guard.pid = -1;
  EXPECT_EQ(code, 0) << slurp(c.log(2));
  EXPECT_EQ(read_json(c.dir / "summary.json")["status"], "completed");
  expect_same_result(c.dir, c.ref);
}

// A fine level on two ranks: kill -9 of one rank, SIGSTOP of one rank, SIGTERM of its mpirun. Each names level
// 'fine' (with its mpirun's pid), no rank is left, and the run resumed on two ranks ends as an uninterrupted
// two-rank run.
TEST(TwoRankLevelFaults, KillAndStopOfARankAndSigtermOfMpirunAreNamedAndNoRankIsLeft) {
  const Chain c("mpif", 2);
  ASSERT_FALSE(HasFailure());
  // mpirun ends with 128 + 9 when a rank is killed by signal 9.
  Fault f = fault_at(c.dir, c.run(), 100, "level 'fine'", SIGKILL, 60.0, c.log(1), rank_of(c.dir, "fine"));
  expect_named(c.dir, f, {128 + SIGKILL}, "level 'fine'", "exited with code 137");
  // A stopped rank stops responding: the coupler names the level after its timeout and ends with 2.
  f = fault_at(c.dir, c.resume(), 300, "level 'fine'", SIGSTOP, kTimeout + 60.0, c.log(2), rank_of(c.dir, "fine"));
  expect_named(c.dir, f, {2}, "level 'fine'", "went silent: no message for ");
  EXPECT_NE(f.out.find("it is hung, stopped (SIGSTOP)"), std::string::npos) << f.out;
  // mpirun ends with 1 on SIGTERM; its ranks stop as under Ctrl-C and tell the coupler, which may end first (2).
  f = fault_at(c.dir, c.resume(), 500, "level 'fine'", SIGTERM, 60.0, c.log(3));
  expect_named_either(c.dir, f, {{1, "exited with code 1"}, {2, "failed: interrupted by a signal"}}, "level 'fine'");
  expect_resume_completes_as(c.dir, c.ref);
}

// A consistent set whose level checkpoint is replaced, after an interrupt, by one of another set (as another run's
// would be: its interval is not the set's) or of another case (a level checkpoint of the single-level quickstart):
// the launcher's file checks pass (both are whole MLCG level checkpoints), so the processes start, and the coupler
// (interval) or the level (dt and alpha, then the scene) refuses before anything is simulated. The launcher names
// the level, no process is left, the checkpoints are unchanged, and with the right file back the run resumes to the
// uninterrupted result.
TEST(CheckpointFaults, ALevelCheckpointOfAnotherSetOrCaseIsRefusedAndTheSetStaysIntact) {
  const Chain c("cpf", 1);
  ASSERT_FALSE(HasFailure());
  const fs::path& dir = c.dir;
  const pid_t pid = start_mlcg(c.run(), c.log(1));
  KillOnExit guard{pid};
  ASSERT_TRUE(wait_for_checkpoint(dir, 200, pid)) << slurp(c.log(1));
  kill(pid, SIGTERM);
  ASSERT_EQ(wait_exit_within(pid, 60.0), 130) << slurp(c.log(1));
  guard.pid = -1;
  const auto m = read_json(dir / "checkpoints" / "manifest.json");
  ASSERT_TRUE(m.contains("previous")) << m.dump();
  const fs::path sets = dir / "checkpoints";
  const fs::path fine = sets / m["levels"]["fine"].get<std::string>();
  const fs::path coarse = sets / m["levels"]["coarse"].get<std::string>();
  const fs::path foreign = dir.string() + ".foreign.h5";
  {
    mlcg::Level level(mlcg::test::load("quickstart/case.toml"), mlcg::test::quiet());
    level.write_checkpoint(foreign);
  }
  struct Swap {
    fs::path target, with;
    std::string refusal;
  };
  const std::string k = std::to_string(m["interval"].get<uint64_t>());
  const Swap swaps[] = {
      {fine, sets / m["previous"]["levels"]["fine"].get<std::string>(),
       "starts at interval " + std::to_string(m["previous"]["interval"].get<uint64_t>()) + ", the coupler is at " + k},
      {coarse, foreign, "written with dt = 1.2e-05 s and alpha = 1, but the case now has dt = 2.4e-05 s and alpha = 2"}};
  for (const auto& s : swaps) {
    const std::string kept = slurp(s.target);
    fs::copy_file(s.with, s.target, fs::copy_options::overwrite_existing);
    const auto before = launch_support::fingerprint(sets);
    const int code = run(kBin + "/mlcg resume " + dir.string() + " --quiet > " + c.log(2).string() + " 2>&1");
    const std::string out = slurp(c.log(2));
    const std::string level = s.target == fine ? "fine" : "coarse";
    // The level refuses the file and exits with 1, the launcher with the level's code.
    EXPECT_EQ(code, 1) << out;
    EXPECT_NE(out.find("mlcg: level '" + level + "' (pid "), std::string::npos) << out;
    EXPECT_NE(out.find(") exited with code 1; stopping every other process"), std::string::npos) << out;
    EXPECT_NE(out.find(s.refusal), std::string::npos) << out;
    expect_no_process_left(dir);
    EXPECT_EQ(launch_support::fingerprint(sets), before) << "a refused resume changed the checkpoints";
    std::ofstream(s.target, std::ios::binary) << kept;
  }
  expect_resume_completes_as(dir, c.ref);
  fs::remove(foreign);
}
