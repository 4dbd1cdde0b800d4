#include "process.hpp"

#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstring>
#include <stdexcept>
#include <sys/wait.h>
#include <thread>
#include <unistd.h>

#include <filesystem>

namespace mlcg::launcher {

namespace {
std::atomic<int> g_signal{0};
extern "C" void remember_signal(int s) { g_signal.store(s); }
}  // namespace

pid_t spawn(const std::vector<std::string>& argv) {
  std::vector<char*> args;
  for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  const pid_t pid = fork();
  if (pid < 0) throw std::runtime_error(std::string("cannot fork: ") + std::strerror(errno));
  if (pid == 0) {
    // Own process group, so a terminal's Ctrl-C reaches it only through the launcher.
    setpgid(0, 0);
    execvp(args[0], args.data());
    std::fprintf(stderr, "error: cannot start %s: %s\n", args[0], std::strerror(errno));
    _exit(127);
  }
  setpgid(pid, pid);
  return pid;
}

ChildResult wait_forwarding(pid_t child) {
  struct sigaction sa {};
  sa.sa_handler = remember_signal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
  ChildResult r;
  bool forwarded = false;
  while (true) {
    int status = 0;
    const pid_t w = waitpid(child, &status, WNOHANG);
    if (w == child) {
      if (WIFEXITED(status)) r.exit_code = WEXITSTATUS(status);
      if (WIFSIGNALED(status)) {
        r.signalled = true;
        r.exit_code = 128 + WTERMSIG(status);
      }
      break;
    }
    if (w < 0 && errno != EINTR) break;
    const int s = g_signal.load();
    if (s != 0 && !forwarded) {
      kill(-child, SIGTERM);  // the whole group: mpirun and its ranks, or the level
      forwarded = true;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return r;
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
