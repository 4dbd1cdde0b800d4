// The faults of issue 13, each against the real programs: a run folder that
// already holds something is refused before anything is written there; the
// processes of a run end with their launcher, even when it is killed outright,
// and a run folder takes one live launcher at a time; dem_level honours SIGTERM
// inside a long insertion batch and while it waits to register with the coupler;
// a hung (SIGSTOP) level is named, not the coupler; a local peer flooding the
// bus without reading is dropped and the run goes on.
#include <gtest/gtest.h>

#include <sys/file.h>
#include <sys/syscall.h>

#include <zmq.hpp>

#include "launch_support.hpp"
#include "run_checks.hpp"

using launch_support::expect_no_process_left;
using launch_support::expect_same_result;
using launch_support::ContinueOnExit;
using launch_support::fingerprint;
using launch_support::KillOnExit;
using launch_support::quickstart_with_timeout;
using launch_support::running;
using launch_support::kBin;
using launch_support::kSrc;
using launch_support::pid_of;
using launch_support::remove_run;
using launch_support::run;
using launch_support::run_hierarchy_case;
using launch_support::start;
using launch_support::start_mlcg;
using launch_support::wait_exit;
using launch_support::wait_exit_within;
using launch_support::wait_for_checkpoint;
using mlcg::test::fresh_temp_path;
using mlcg::test::read_json;
using mlcg::test::slurp;
using mlcg::test::temp_path;

namespace fs = std::filesystem;

namespace {

// The pids of the processes status.json lists as running, once it lists n of them (it is written about once
// a second); fewer when it does not within 10 s.
std::vector<pid_t> run_processes(const fs::path& dir, size_t n) {
  std::vector<pid_t> out;
  for (int i = 0; i < 100 && out.size() < n; ++i) {
    out.clear();
    try {
      const auto st = read_json(dir / "status.json");
      for (const auto& p : st["processes"])
        if (p["state"] == "running") out.push_back(p["pid"].get<pid_t>());
    } catch (const std::exception&) {  // not written yet
    }
    if (out.size() < n) usleep(100000);
  }
  return out;
}

// Waits up to `seconds` for every pid to end; the ones still running.
std::vector<pid_t> still_running(const std::vector<pid_t>& pids, double seconds) {
  std::vector<pid_t> left = pids;
  for (int i = 0; i < static_cast<int>(seconds * 20) && !left.empty(); ++i) {
    usleep(50000);
    std::erase_if(left, [](pid_t p) { return !running(p); });
  }
  return left;
}

// Until `file` exists (the program is past its start), up to a minute on a loaded machine.
bool wait_for_file(const fs::path& file, pid_t pid) {
  for (int i = 0; i < 600; ++i) {
    if (fs::exists(file)) return true;
    if (waitpid(pid, nullptr, WNOHANG) == pid) return false;
    usleep(100000);
  }
  return false;
}

// A hierarchy run of the quickstart case stopped with Ctrl-C after a few consistent checkpoints: a run
// folder `mlcg resume` continues.
fs::path interrupted_hierarchy(const std::string& tag) {
  const fs::path dir = fresh_temp_path(tag);
  const pid_t pid = start_mlcg({"run", kSrc + "/cases/quickstart/mlcg.toml", "--out", dir.string(), "--quiet"},
                               dir.string() + ".out");
  EXPECT_TRUE(wait_for_checkpoint(dir, 100, pid)) << slurp(dir.string() + ".out");
  kill(pid, SIGINT);  // a launcher that has already ended is reaped below
  EXPECT_EQ(wait_exit(pid), 130) << slurp(dir.string() + ".out");
  return dir;
}

}  // namespace

// ---- A run never reuses a folder (issue 13, fault 1) ----

TEST(RunFolder, AnExistingRunFolderIsRefusedBeforeAnythingIsWritten) {
  const fs::path dir = fresh_temp_path("reuse");
  ASSERT_EQ(run(kBin + "/mlcg run " + kSrc + "/cases/collision/head_on.toml --out " + dir.string() + " --quiet > " +
                dir.string() + ".out 2>&1"),
            0) << slurp(dir.string() + ".out");
  const auto before = fingerprint(dir);
  ASSERT_GE(before.size(), 5u);
  // The same single-level case again, and a hierarchy, into the folder of the completed run.
  for (const std::string c : {"cases/collision/head_on.toml", "cases/quickstart/mlcg.toml"}) {
    EXPECT_EQ(run(kBin + "/mlcg run " + kSrc + "/" + c + " --out " + dir.string() + " --quiet > " + dir.string() +
                  ".out 2>&1"),
              2) << c;
    const std::string out = slurp(dir.string() + ".out");
    EXPECT_NE(out.find("error: --out " + dir.string() + " already holds a run (summary.json: completed)"), std::string::npos) << out;
    EXPECT_NE(out.find("Give --out a new folder"), std::string::npos) << out;
    EXPECT_EQ(fingerprint(dir), before) << c << " changed the files of the run already there";
  }
  fs::remove_all(dir);
  fs::remove(dir.string() + ".out");
}

TEST(RunFolder, AFileGivenAsTheRunFolderIsRefusedWithoutAnAbort) {
  const fs::path file = temp_path("outfile");
  std::ofstream(file) << "not a run folder\n";
  EXPECT_EQ(run(kBin + "/mlcg run " + kSrc + "/cases/collision/head_on.toml --out " + file.string() + " > " +
                file.string() + ".out 2>&1"),
            2);
  const std::string out = slurp(file.string() + ".out");
  EXPECT_NE(out.find("error: --out " + file.string() + " is an existing file, not a folder"), std::string::npos) << out;
  EXPECT_NE(out.find("Give --out a new folder"), std::string::npos) << out;
  EXPECT_EQ(slurp(file), "not a run folder\n");
  fs::remove(file);
  fs::remove(file.string() + ".out");
}

// ---- A run's processes end with their launcher; one launcher per run folder (fault 2) ----

// kill -9 leaves the launcher no chance to stop anything: the coupler and the levels must end by themselves
// within a few seconds, the kernel releases the launcher's lock, and the run resumes from its last
// consistent checkpoint to the result of an uninterrupted run of the same case, to the last digit (the short
// quickstart: 0.15 s).
TEST(LauncherDeath, AKilledLauncherTakesEveryProcessOfItsRunWithIt) {
  const fs::path cfile = launch_support::short_quickstart(15.0, 1, "kill9");
  const fs::path ref = run_hierarchy_case(cfile.string(), "kill9_ref");
  const fs::path dir = fresh_temp_path("kill9");
  const pid_t pid = start_mlcg({"run", cfile.string(), "--out", dir.string(), "--quiet"}, dir.string() + ".out");
  KillOnExit guard{pid};
  ASSERT_TRUE(wait_for_checkpoint(dir, 100, pid)) << slurp(dir.string() + ".out");
  const std::vector<pid_t> children = run_processes(dir, 3);
  ASSERT_EQ(children.size(), 3u) << "the coupler and two levels: " << slurp(dir / "status.json");
  // While its launcher lives the folder is its own: a resume is refused, naming the launcher.
  EXPECT_EQ(run(kBin + "/mlcg resume " + dir.string() + " > " + dir.string() + ".resume 2>&1"), 2);
  const std::string refused = slurp(dir.string() + ".resume");
  EXPECT_NE(refused.find("in use by the launcher pid " + std::to_string(pid)), std::string::npos) << refused;

  ASSERT_EQ(kill(pid, SIGKILL), 0);
  EXPECT_EQ(wait_exit(pid), 128 + SIGKILL);
  guard.pid = -1;
  // 5 s (the kernel's SIGTERM, then the level's exit); an instrumented build's exit takes longer (sanitize.sh).
  const double limit = 5.0 * launch_support::time_scale();
  const auto left = still_running(children, limit);
  for (const pid_t p : left) {
    ADD_FAILURE() << "pid " << p << " of the run outlived its launcher by " << limit << " s";
    kill(p, SIGKILL);
  }
  const int fd = ::open((dir / "launcher.lock").c_str(), O_RDWR | O_CLOEXEC);
  ASSERT_GE(fd, 0) << "no launcher.lock in " << dir;
  EXPECT_EQ(flock(fd, LOCK_EX | LOCK_NB), 0) << "the dead launcher's lock is still held";
  ::close(fd);
  launch_support::expect_resume_completes_as(dir, ref);
  for (const auto& d : {ref, dir}) remove_run(d);
  fs::remove(dir.string() + ".resume");
  mlcg::test::remove_case_copy(cfile);
}

// The test holds the folder's lock as a live launcher does (status.json cannot tell: it is the old run's).
// Neither `mlcg resume` nor `mlcg run` may touch the folder.
TEST(RunFolderLock, AFolderHeldByALiveLauncherIsNeitherResumedNorReused) {
  const fs::path dir = interrupted_hierarchy("held");
  ASSERT_FALSE(HasFailure());
  const int fd = ::open((dir / "launcher.lock").c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  ASSERT_GE(fd, 0);
  ASSERT_EQ(flock(fd, LOCK_EX | LOCK_NB), 0);
  const std::string me = std::to_string(::getpid()) + "\n";
  ASSERT_EQ(ftruncate(fd, 0), 0);
  ASSERT_EQ(pwrite(fd, me.data(), me.size(), 0), static_cast<ssize_t>(me.size()));
  const auto before = fingerprint(dir);
  // `timeout`: a resume that is not refused would run the rest of the hierarchy.
  EXPECT_EQ(run("timeout -s INT 120 " + kBin + "/mlcg resume " + dir.string() + " --quiet > " + dir.string() +
                ".resume 2>&1"),
            2);
  const std::string refused = slurp(dir.string() + ".resume");
  EXPECT_NE(refused.find(dir.string() + " is in use by the launcher pid " + std::to_string(::getpid())),
            std::string::npos) << refused;
  EXPECT_EQ(fingerprint(dir), before) << "the refused resume changed the run folder";
  // A new run into it is refused too, with the way to continue this one.
  EXPECT_EQ(run(kBin + "/mlcg run " + kSrc + "/cases/quickstart/mlcg.toml --out " + dir.string() + " --quiet > " +
                dir.string() + ".run 2>&1"),
            2);
  const std::string again = slurp(dir.string() + ".run");
  EXPECT_NE(again.find("already holds a run (summary.json: interrupted)"), std::string::npos) << again;
  EXPECT_NE(again.find("Continue that run with `mlcg resume " + dir.string() + "`"), std::string::npos) << again;
  EXPECT_EQ(fingerprint(dir), before) << "the refused run changed the run folder";
  ::close(fd);
  fs::remove_all(dir);
  for (const auto& f : {dir.string() + ".out", dir.string() + ".resume", dir.string() + ".run"}) fs::remove(f);
}

// ---- dem_level honours SIGTERM everywhere (fault 3) ----

// One batch asks for 600,000 particles (no rate) in a 0.13 m^3 cylinder around the funnel: a
// legitimate batch (16 % of the volume; an impossible one is refused before step 1) that takes
// many seconds of SSI. It logs its progress; SIGTERM inside it ends the level within 2 s, with the
// batch dropped.
TEST(DemLevelSignals, SigtermEndsALongInsertionBatchWithinTwoSeconds) {
  const fs::path dir = temp_path("bigbatch");
  const fs::path cfile = dir.string() + ".toml";
  fs::remove_all(dir);
  std::string text = slurp(kSrc + "/cases/quickstart/case.toml");
  for (const auto& [from, to] : std::vector<std::pair<std::string, std::string>>{
           {"min = [-0.05, -0.05, -0.04]\nmax = [0.05, 0.05, 0.15]", "min = [-0.3, -0.3, -0.04]\nmax = [0.3, 0.3, 0.5]"},
           {"radius = 0.037, zmin = 0.002, zmax = 0.135", "radius = 0.29, zmin = 0.002, zmax = 0.49"},
           {"count_alpha1 = 2500     # beads of 4 mm; a level at alpha inserts 2500 / alpha^3 of its own\nrate_alpha1 = 20000.0\n",
            "count = 600000\n"},
           {"follow_gap = 0.005\nfollow_height = 0.02\n", ""},
           {"[time]\n", "[time]\nprogress_interval = 0.5\n"}}) {
    ASSERT_NE(text.find(from), std::string::npos) << from;
    text.replace(text.find(from), from.size(), to);
  }
  std::ofstream(cfile) << text;
  const pid_t pid = start({kBin + "/dem_level", cfile.string(), "--out", dir.string(), "--quiet"}, dir.string() + ".out");
  KillOnExit guard{pid};
  ASSERT_TRUE(wait_for_file(dir / "case.toml", pid)) << slurp(dir.string() + ".out");
  // The batch says that it moves (progress_interval = 0.5 s), in the log as it happens (a busy
  // machine may take a few seconds for the set-up).
  std::string log;
  for (int i = 0; i < 200 && log.find(" of 600000 particles") == std::string::npos; ++i) {
    usleep(50000);
    log = slurp((dir / "log.txt").string());
  }
  EXPECT_NE(log.find("insertion 'fill': batch 1 has tried "), std::string::npos) << log;
  EXPECT_NE(log.find(" of 600000 particles"), std::string::npos) << log;
  ASSERT_EQ(waitpid(pid, nullptr, WNOHANG), 0) << "dem_level ended before the signal";
  ASSERT_EQ(kill(pid, SIGTERM), 0);
  const auto code = wait_exit_within(pid, 2.0);
  guard.pid = -1;
  ASSERT_TRUE(code.has_value()) << "dem_level ignored SIGTERM inside the insertion batch for 2 s (killed)";
  EXPECT_EQ(*code, 130);
  const std::string out = slurp(dir.string() + ".out");
  EXPECT_NE(out.find("interrupted by a signal during batch 1 of insertion 'fill'"), std::string::npos) << out;
  const auto s = read_json(dir / "summary.json");
  EXPECT_EQ(s["status"], "interrupted");
  EXPECT_EQ(s["mass_balance"]["inserted"], 0) << "the unfinished batch must be dropped";
  for (const auto& e : fs::recursive_directory_iterator(dir))
    EXPECT_EQ(e.path().string().find(".tmp."), std::string::npos) << e.path();
  fs::remove_all(dir);
  for (const auto& f : {dir.string() + ".out", cfile.string()}) fs::remove(f);
}

namespace {
// A thread of `pid` other than its first that lets SIGTERM through (Open MPI's), or -1.
pid_t other_thread_taking_sigterm(pid_t pid) {
  for (const auto& e : fs::directory_iterator("/proc/" + std::to_string(pid) + "/task")) {
    const pid_t tid = std::stoi(e.path().filename().string());
    if (tid == pid) continue;
    std::ifstream in(e.path() / "status");
    for (std::string line; std::getline(in, line);)
      if (line.rfind("SigBlk:", 0) == 0 && !((std::stoull(line.substr(7), nullptr, 16) >> (SIGTERM - 1)) & 1u))
        return tid;
  }
  return -1;
}
}  // namespace

// A level whose coupler never comes waits up to [coupling] timeout (60 s) for its welcome. A SIGTERM
// may be taken by any thread that does not block it: sent to an Open MPI thread, its handler runs there
// and the level's poll is not woken; the wait must still end within 2 s.
TEST(DemLevelSignals, SigtermEndsTheWaitForTheCouplerWithinTwoSeconds) {
  const fs::path dir = fresh_temp_path("nocoupler");
  const pid_t pid = start({kBin + "/dem_level", kSrc + "/cases/quickstart/mlcg.toml", "--out", dir.string(), "--level",
                           "coarse", "--coupler", "ipc://" + dir.string() + ".ipc", "--quiet"},
                          dir.string() + ".out");
  KillOnExit guard{pid};
  ASSERT_TRUE(wait_for_file(dir / "case.toml", pid)) << slurp(dir.string() + ".out");
  sleep(1);  // registering by now
  const pid_t tid = other_thread_taking_sigterm(pid);
  ASSERT_GT(tid, 0) << "no thread besides the first takes SIGTERM";
  ASSERT_EQ(syscall(SYS_tgkill, pid, tid, SIGTERM), 0);
  const auto code = wait_exit_within(pid, 2.0);
  guard.pid = -1;
  ASSERT_TRUE(code.has_value()) << "dem_level ignored SIGTERM while waiting for the coupler for 2 s (killed)";
  EXPECT_NE(*code, 0);
  const std::string out = slurp(dir.string() + ".out");
  EXPECT_NE(out.find("error: interrupted by a signal while level 'coarse' waited for the welcome"), std::string::npos)
      << out;
  fs::remove_all(dir);
  for (const auto& f : {dir.string() + ".out", dir.string() + ".ipc"}) fs::remove(f);
}

// ---- A hung level is named (fault 4) ----

// kill -STOP of the fine level: the coarse level waits on the coupler, which waits on 'fine'. The run ends
// within about the timeout, naming 'fine' as the silent level in the launcher's output, the coupler's log
// and the summary; the coarse level's summary says it stopped because of 'fine'; nothing blames the coupler, and no
// process of the run is left (the stopped one included).
TEST(HungLevel, AStoppedFineLevelIsNamedWithinTheTimeoutAndNoProcessIsLeft) {
  constexpr double kTimeout = 5.0;
  const fs::path cfile = quickstart_with_timeout(kTimeout, "hung");
  const fs::path dir = fresh_temp_path("hung");
  const pid_t pid = start_mlcg({"run", cfile.string(), "--out", dir.string(), "--quiet"}, dir.string() + ".out");
  KillOnExit guard{pid};
  ASSERT_TRUE(wait_for_checkpoint(dir, 100, pid)) << slurp(dir.string() + ".out");
  const pid_t fine = pid_of(dir, "level 'fine'");
  ASSERT_GT(fine, 0) << slurp(dir / "status.json");
  ContinueOnExit wake{fine};
  ASSERT_EQ(kill(fine, SIGSTOP), 0);
  // The timeout, then a second or two to stop the others (without waking the stopped level: 15 s more).
  const auto code = wait_exit_within(pid, kTimeout + 8.0);
  guard.pid = -1;
  const std::string out = slurp(dir.string() + ".out");
  ASSERT_TRUE(code.has_value()) << "the run did not end within the timeout + 8 s of the SIGSTOP:\n" << out;
  EXPECT_NE(*code, 0);
  const std::string named = "level 'fine' (pid " + std::to_string(fine) + ") went silent: no message for ";
  EXPECT_NE(out.find("mlcg: " + named), std::string::npos) << out;
  const std::string coarse = read_json(dir / "levels" / "coarse" / "summary.json")["reason"];
  EXPECT_NE(coarse.find("while level 'coarse' waited for the commands of interval"), std::string::npos) << coarse;
  EXPECT_NE(coarse.find(": level 'fine' went silent"), std::string::npos) << coarse;
  EXPECT_EQ(out.find("is coupler_service running"), std::string::npos) << "the coupler was blamed:\n" << out;
  EXPECT_NE(slurp(dir / "coupler.log").find("level 'fine' went silent"), std::string::npos);
  const auto s = read_json(dir / "summary.json");
  EXPECT_EQ(s["status"], "failed");
  EXPECT_EQ(s["reason"].get<std::string>().rfind(named, 0), 0u) << s["reason"];
  EXPECT_EQ(s["coupling"]["silent_level"], "fine");
  // `mlcg ps` on the ended run tells why, from status.json.
  const auto st = read_json(dir / "status.json");
  EXPECT_EQ(st["state"], "failed");
  EXPECT_EQ(st.value("reason", "").rfind(named, 0), 0u) << st;
  ASSERT_EQ(run(kBin + "/mlcg ps " + dir.string() + " > " + dir.string() + ".ps 2>&1"), 0);
  EXPECT_NE(slurp(dir.string() + ".ps").find("reason: " + named), std::string::npos) << slurp(dir.string() + ".ps");
  fs::remove(dir.string() + ".ps");
  expect_no_process_left(dir);
  fs::remove_all(dir);
  fs::remove(dir.string() + ".out");
  mlcg::test::remove_case_copy(cfile);
}

// ---- A local peer cannot stall the bus (fault 5) ----

// A DEALER on the run's bus.ipc sends 5000 garbage frames and never reads the coupler's refusals. The
// coupler drops it once they back up (logged once, its binary id in hex) and the run ends with the per-face
// totals of an undisturbed run (runs are deterministic).
TEST(BusFlood, APeerThatNeverReadsIsDroppedAndTheRunIsUnaffected) {
  const fs::path ref = run_hierarchy_case("cases/quickstart/mlcg.toml", "flood_ref"), dir = temp_path("flood");
  ASSERT_FALSE(HasFailure());
  fs::remove_all(dir);
  const pid_t pid = start_mlcg({"run", kSrc + "/cases/quickstart/mlcg.toml", "--out", dir.string(), "--quiet"},
                               dir.string() + ".out");
  KillOnExit guard{pid};
  ASSERT_TRUE(wait_for_checkpoint(dir, 100, pid)) << slurp(dir.string() + ".out");  // the levels are coupled
  const std::string id("\x00\xff" "flood", 7);  // bytes a log must not print raw
  zmq::context_t ctx;
  zmq::socket_t s(ctx, zmq::socket_type::dealer);
  s.set(zmq::sockopt::routing_id, id);
  s.set(zmq::sockopt::sndhwm, 0);  // no limit here: the sends below never block the test
  s.set(zmq::sockopt::linger, 0);
  s.connect("ipc://" + (dir / "bus.ipc").string());
  for (int i = 0; i < 5000; ++i) s.send(zmq::buffer("garbage " + std::to_string(i)), zmq::send_flags::none);
  // The socket stays open, unread, until the run ends.
  EXPECT_EQ(wait_exit(pid), 0) << slurp(dir.string() + ".out");
  guard.pid = -1;
  expect_same_result(dir, ref);
  const std::string log = slurp(dir / "coupler.log");
  const std::string dropped = "dropped peer 0x00ff666c6f6f64";
  const size_t at = log.find(dropped);
  EXPECT_NE(at, std::string::npos) << log.substr(0, 4000);
  EXPECT_EQ(log.find(dropped, at + 1), std::string::npos) << "the drop must be logged once";
  EXPECT_EQ(log.find(id.substr(1)), std::string::npos) << "the peer's id is logged as raw bytes";
  for (const auto& d : {ref, dir}) remove_run(d);
}
