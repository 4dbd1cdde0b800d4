#pragma once
// Starting the real programs from a test: mlcg and dem_level in the background, their exit, a run's
// checkpoints, the faults a test applies. Shared by the launcher tests (test_launcher, test_check,
// test_coupled_stability), the fault tests (test_faults, test_fault_matrix) and those of netns, root and slurm.
#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "files.hpp"
#include "run_checks.hpp"
#include "shell.hpp"

namespace launch_support {
namespace fs = std::filesystem;
using mlcg::test::fresh_temp_path;
using mlcg::test::read_json;
using mlcg::test::run;
using mlcg::test::slurp;
using mlcg::test::temp_path;

inline const std::string kBin = MLCG_BIN_DIR;
inline const std::string kSrc = MLCG_SOURCE_DIR;

// Every regular file under dir by its path, with a hash of its bytes: what "unchanged" means for a run folder.
inline std::map<std::string, size_t> fingerprint(const fs::path& dir) {
  std::map<std::string, size_t> out;
  for (const auto& e : fs::recursive_directory_iterator(dir))
    if (e.is_regular_file()) out[fs::relative(e.path(), dir).string()] = std::hash<std::string>{}(slurp(e.path()));
  return out;
}

// The process runs (a zombie waiting for its reaper, or no process, counts as ended).
inline bool running(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/stat");
  std::string stat;
  std::getline(in, stat);
  const auto close = stat.rfind(')');
  return close != std::string::npos && close + 2 < stat.size() && stat[close + 2] != 'Z';
}

// Kills and reaps a child that a failed assertion would leave running.
struct KillOnExit {
  pid_t pid;
  ~KillOnExit() {
    if (pid <= 0) return;
    kill(pid, SIGKILL);
    waitpid(pid, nullptr, 0);
  }
};

// Wakes and kills a process the test stopped, should the run have left it.
struct ContinueOnExit {
  pid_t pid;
  ~ContinueOnExit() {
    kill(pid, SIGCONT);
    if (running(pid)) kill(pid, SIGKILL);
  }
};

// A copy of `rel`, a case of the source tree, with its bases (copy_case), each (from, to) replaced at its
// first occurrence in the case or its bases (a `from` none holds fails the test), in the folder
// temp_path(tag + "_case"); the copy's path.
inline fs::path edited_case(const std::string& rel, const std::vector<std::pair<std::string, std::string>>& edits,
                            const std::string& tag) {
  return mlcg::test::copy_case(kSrc + "/" + rel, fresh_temp_path(tag + "_case"), edits);
}

// The quickstart hierarchy with `[coupling] timeout` set; the case file's path.
inline fs::path quickstart_with_timeout(double timeout, const std::string& tag) {
  return edited_case("cases/quickstart/mlcg.toml",
                     {{"[coupling]                 # interval automatic: 1.92e-4 s\n",
                       "[coupling]\ntimeout = " + std::to_string(timeout) + "\n"}},
                     tag);
}

// quickstart_with_timeout cut to 0.15 s (781 intervals, the lid still closed): faults, resumes and the reference
// run to compare with in a few seconds each. With `fine_ranks` > 1 the fine level runs on that many ranks.
inline fs::path short_quickstart(double timeout, int fine_ranks, const std::string& tag) {
  const fs::path c = quickstart_with_timeout(timeout, tag);
  std::string text = slurp(c);
  const std::string end = "end = 0.6", fine = "name = \"fine\"\nalpha = 1.0\n";
  EXPECT_NE(text.find(end), std::string::npos);
  EXPECT_NE(text.find(fine), std::string::npos);
  text.replace(text.find(end), end.size(), "end = 0.15");
  if (fine_ranks > 1) text.replace(text.find(fine), fine.size(), fine + "ranks = " + std::to_string(fine_ranks) + "\n");
  std::ofstream(c) << text;
  return c;
}

// `mlcg run` of a case in the source tree (`path`) to its end, into a new temporary folder named by `tag`.
// (An absolute `path` is taken as it is.)
inline fs::path run_hierarchy_case(const std::string& path, const std::string& tag) {
  const fs::path dir = fresh_temp_path(tag), c = fs::path(path).is_absolute() ? fs::path(path) : fs::path(kSrc) / path;
  EXPECT_EQ(run(kBin + "/mlcg run " + c.string() + " --out " + dir.string() + " --quiet > " + dir.string() +
                ".out 2>&1"),
            0)
      << "see " << dir.string() << ".out";
  return dir;
}

// Removes a run folder and the launcher output beside it.
inline void remove_run(const fs::path& dir) {
  fs::remove_all(dir);
  fs::remove(dir.string() + ".out");
}

// A hierarchy run that must give `ref`'s result to the last digit (a run depends on the seed only): the per-face
// totals, the per-interval coupling log and the fine level's mass balance.
inline void expect_same_result(const fs::path& dir, const fs::path& ref) {
  for (const char* f : {"faces_region0.csv", "region0.csv"})
    EXPECT_EQ(slurp(dir / "coupling" / f), slurp(ref / "coupling" / f)) << f << " differs from the reference run's";
  EXPECT_EQ(read_json(dir / "levels" / "fine" / "summary.json")["mass_balance"],
            read_json(ref / "levels" / "fine" / "summary.json")["mass_balance"]);
}

// `mlcg resume` of the run in `dir` (output appended to dir.out) completes, checked by check_region, with the
// result of `ref`, a run of the same case that nothing interrupted.
inline void expect_resume_completes_as(const fs::path& dir, const fs::path& ref) {
  ASSERT_EQ(run(kBin + "/mlcg resume " + dir.string() + " --quiet >> " + dir.string() + ".out 2>&1"), 0)
      << slurp(dir.string() + ".out");
  const auto s = read_json(dir / "summary.json");
  EXPECT_EQ(s["status"], "completed");
  run_checks::check_region(dir, s, 0, "fine");
  expect_same_result(dir, ref);
}

// Starts argv in the background (output to `log`); returns its pid.
inline pid_t start(std::vector<std::string> argv, const fs::path& log) {
  const pid_t pid = fork();
  if (pid == 0) {
    const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    dup2(fd, 1);
    dup2(fd, 2);
    std::vector<char*> args;
    for (auto& s : argv) args.push_back(s.data());
    args.push_back(nullptr);
    execv(args[0], args.data());
    _exit(127);
  }
  return pid;
}

// Starts `mlcg ARGS` in the background (output to `log`); returns its pid.
inline pid_t start_mlcg(const std::vector<std::string>& args, const fs::path& log) {
  std::vector<std::string> a{kBin + "/mlcg"};
  a.insert(a.end(), args.begin(), args.end());
  return start(a, log);
}

inline int exit_code(int status) { return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status); }

inline int wait_exit(pid_t pid) {
  int status = 0;
  waitpid(pid, &status, 0);
  return exit_code(status);
}

// Deadlines are multiplied by MLCG_TEST_TIME_SCALE (default 1): scripts/sanitize.sh sets it, because
// under ASan a process's exit alone (the leak check with full stack unwinding) takes seconds.
inline double time_scale() {
  const char* s = std::getenv("MLCG_TEST_TIME_SCALE");
  const double v = s ? std::atof(s) : 1.0;
  return v >= 1.0 ? v : 1.0;
}

// The exit code when the child ends within `seconds` (times time_scale()); else nullopt (and it is
// killed and reaped).
inline std::optional<int> wait_exit_within(pid_t pid, double seconds) {
  const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds * time_scale());
  int status = 0;
  while (std::chrono::steady_clock::now() < until) {
    if (waitpid(pid, &status, WNOHANG) == pid) return exit_code(status);
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  kill(pid, SIGKILL);
  waitpid(pid, &status, 0);
  return std::nullopt;
}

// Waits (generously: the machine may be loaded) until the run's manifest names interval >= k.
inline bool wait_for_checkpoint(const fs::path& dir, uint64_t k, pid_t launcher) {
  for (int i = 0; i < 1200; ++i) {
    try {
      if (read_json(dir / "checkpoints" / "manifest.json")["interval"].get<uint64_t>() >= k) return true;
    } catch (const std::exception&) {  // not there yet
    }
    if (waitpid(launcher, nullptr, WNOHANG) == launcher) return false;
    usleep(100000);
  }
  return false;
}

// Processes whose command line names the run folder (the launcher's children and their MPI ranks).
inline std::vector<std::string> processes_naming(const fs::path& dir) {
  std::vector<std::string> out;
  for (const auto& e : fs::directory_iterator("/proc")) {
    const std::string pid = e.path().filename().string();
    if (pid.find_first_not_of("0123456789") != std::string::npos || std::stoi(pid) == ::getpid()) continue;
    std::string cmd = slurp(e.path() / "cmdline");
    std::replace(cmd.begin(), cmd.end(), '\0', ' ');
    if (cmd.find(dir.string() + "/") != std::string::npos || cmd.find(dir.string() + " ") != std::string::npos)
      out.push_back(pid + ": " + cmd);
  }
  return out;
}

// Every process status.json lists (the last attempt's) is gone, and none names the run folder.
inline void expect_no_process_left(const fs::path& dir) {
  for (const auto& p : processes_naming(dir)) ADD_FAILURE() << "still running: " << p;
  const auto st = read_json(dir / "status.json");
  ASSERT_FALSE(st["processes"].empty());
  for (const auto& p : st["processes"]) {
    const pid_t pid = p["pid"].get<pid_t>();
    EXPECT_TRUE(kill(pid, 0) != 0 && errno == ESRCH) << p["name"] << " (pid " << pid << ") is still alive";
  }
}

// The pid status.json gives the running process `name` ("level 'fine'"); -1 when none within 10 s.
inline pid_t pid_of(const fs::path& dir, const std::string& name) {
  for (int i = 0; i < 100; ++i) {
    try {
      const auto st = read_json(dir / "status.json");
      for (const auto& p : st["processes"])
        if (p["name"] == name && p["state"] == "running") return p["pid"].get<pid_t>();
    } catch (const std::exception&) {
    }
    usleep(100000);
  }
  return -1;
}

}  // namespace launch_support
