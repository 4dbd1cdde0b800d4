#include "process/process.hpp"

#include <atomic>
#include <chrono>
#include <cerrno>
#include <csignal>
#include <cstring>
#include <stdexcept>
#include <sys/wait.h>
#include <thread>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sys/prctl.h>

namespace mlcg::launcher {

namespace {
std::atomic<int> g_signal{0};
extern "C" void remember_signal(int s) { g_signal.store(s); }
}  // namespace

pid_t spawn(const std::vector<std::string>& argv) {
  std::vector<char*> args;
  for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  const pid_t launcher = getpid();
  const pid_t pid = fork();
  if (pid < 0) throw std::runtime_error(std::string("cannot fork: ") + std::strerror(errno));
  if (pid == 0) {
    // Own process group, so a terminal's Ctrl-C reaches it only through the launcher.
    setpgid(0, 0);
    // A launcher killed outright (SIGKILL) forwards nothing: the kernel sends SIGTERM instead, which the
    // coupler and the levels honour and mpirun passes on to its ranks. It survives the exec.
    prctl(PR_SET_PDEATHSIG, SIGTERM);
    if (getppid() != launcher) _exit(128 + SIGTERM);  // the launcher died before the line above
    execvp(args[0], args.data());
    std::fprintf(stderr, "error: cannot start %s: %s\n", args[0], std::strerror(errno));
    _exit(127);
  }
  setpgid(pid, pid);
  return pid;
}

void catch_signals() {
  struct sigaction sa {};
  sa.sa_handler = remember_signal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
}

int take_signal() { return g_signal.exchange(0); }

std::string describe_exit(int status) {
  if (WIFSIGNALED(status))
    return "was killed by signal " + std::to_string(WTERMSIG(status)) + " (" + strsignal(WTERMSIG(status)) + ")";
  return "exited with code " + std::to_string(WEXITSTATUS(status));
}

int exit_code_of(int status) { return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status); }

GroupResult wait_group(const std::vector<NamedChild>& children, double grace) {
  catch_signals();
  GroupResult r;
  std::vector<bool> done(children.size(), false);
  bool stopping = false;
  auto stop_at = std::chrono::steady_clock::time_point::max();
  const auto stop_all = [&](int sig) {
    for (size_t c = 0; c < children.size(); ++c)
      if (!done[c]) kill(-children[c].pid, sig);
  };
  for (;;) {
    size_t running = 0;
    for (size_t c = 0; c < children.size(); ++c) {
      if (done[c]) continue;
      int status = 0;
      const pid_t w = waitpid(children[c].pid, &status, WNOHANG);
      if (w != children[c].pid) {
        ++running;
        continue;
      }
      done[c] = true;
      const int code = exit_code_of(status);
      if (code != 0 && r.failed.empty() && !stopping) {
        r.failed = children[c].name;
        r.exit_code = code;
      }
      if (code != 0 && !stopping) {
        stopping = true;
        stop_all(SIGTERM);
        stop_at = std::chrono::steady_clock::now() + std::chrono::milliseconds(static_cast<int64_t>(grace * 1000));
      }
    }
    if (running == 0) break;
    if (g_signal.load() != 0 && !stopping) {
      r.interrupted = true;
      stopping = true;
      stop_all(SIGTERM);
      stop_at = std::chrono::steady_clock::now() + std::chrono::milliseconds(static_cast<int64_t>(grace * 1000));
    }
    if (std::chrono::steady_clock::now() > stop_at) {
      stop_all(SIGKILL);
      stop_at = std::chrono::steady_clock::time_point::max();
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  if (r.interrupted && r.exit_code == 0) r.exit_code = 130;
  return r;
}

void become_subreaper() { prctl(PR_SET_CHILD_SUBREAPER, 1); }

namespace {
std::vector<pid_t> own_children() {
  std::vector<pid_t> out;
  const pid_t self = getpid();
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator("/proc", ec)) {
    const std::string name = e.path().filename().string();
    if (name.find_first_not_of("0123456789") != std::string::npos) continue;
    std::ifstream in(e.path() / "stat");
    std::string stat;
    std::getline(in, stat);
    const auto close = stat.rfind(')');  // the command may hold spaces and parentheses
    if (close == std::string::npos) continue;
    char state = 0;
    int ppid = 0;
    if (std::sscanf(stat.c_str() + close + 1, " %c %d", &state, &ppid) == 2 && ppid == self)
      out.push_back(static_cast<pid_t>(std::stoi(name)));
  }
  return out;
}
}  // namespace

void end_strays(double grace) {
  // Helpers that end with their parent (Open MPI's singleton daemon of a 1-rank level) get a second.
  auto strays = own_children();
  for (int i = 0; i < 20 && !strays.empty(); ++i) {
    for (const pid_t p : strays) waitpid(p, nullptr, WNOHANG);
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    strays = own_children();
  }
  if (strays.empty()) return;
  std::fprintf(stderr, "mlcg: stopping %zu process(es) left behind by the run\n", strays.size());
  for (const pid_t p : strays) kill(p, SIGTERM);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(static_cast<int64_t>(grace * 1000));
  while (!strays.empty()) {
    for (const pid_t p : strays) waitpid(p, nullptr, WNOHANG);
    strays = own_children();
    if (std::chrono::steady_clock::now() > deadline)
      for (const pid_t p : strays) kill(p, SIGKILL);
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
}

std::string own_directory() {
  return std::filesystem::canonical("/proc/self/exe").parent_path().string();
}

std::vector<std::string> mpirun_prefix(int ranks) {
  std::vector<std::string> a{"mpirun", "-np", std::to_string(ranks)};
  if (geteuid() == 0) a.push_back("--allow-run-as-root");
  if (ranks > static_cast<int>(std::thread::hardware_concurrency())) a.push_back("--oversubscribe");
  return a;
}

}  // namespace mlcg::launcher
