#include "process.hpp"

#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

namespace mlcg::bench {

namespace fs = std::filesystem;

namespace {
// Busy time of all cores since boot [s] (user + nice + system + irq + softirq + steal), or -1.
double machine_busy_seconds() {
  std::ifstream in("/proc/stat");
  std::string cpu;
  unsigned long long user = 0, nice = 0, system = 0, idle = 0, iowait = 0, irq = 0, softirq = 0, steal = 0;
  if (!(in >> cpu >> user >> nice >> system >> idle >> iowait >> irq >> softirq >> steal) || cpu != "cpu") return -1.0;
  const long hz = sysconf(_SC_CLK_TCK);
  return hz > 0 ? static_cast<double>(user + nice + system + irq + softirq + steal) / static_cast<double>(hz) : -1.0;
}
}  // namespace

ProcessResult run_process(const std::vector<std::string>& argv, const fs::path& cwd, const fs::path& log,
                          const std::string& echo_prefix, const std::vector<std::string>& echo_if) {
  std::ofstream out(log, std::ios::app);
  if (!out) throw std::runtime_error("cannot write " + log.string());
  out << "$";
  for (const auto& a : argv) out << " " << a;
  out << "\n" << std::flush;

  int fds[2];
  if (pipe(fds) != 0) throw std::runtime_error(std::string("pipe: ") + std::strerror(errno));
  std::vector<char*> args;
  for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  const double busy0 = machine_busy_seconds();
  const auto t0 = std::chrono::steady_clock::now();
  const pid_t pid = fork();
  if (pid < 0) throw std::runtime_error(std::string("fork: ") + std::strerror(errno));
  if (pid == 0) {
    close(fds[0]);
    dup2(fds[1], STDOUT_FILENO);
    dup2(fds[1], STDERR_FILENO);
    close(fds[1]);
    if (chdir(cwd.c_str()) != 0) {
      std::fprintf(stderr, "error: cannot enter %s: %s\n", cwd.c_str(), std::strerror(errno));
      _exit(127);
    }
    execvp(args[0], args.data());
    std::fprintf(stderr, "error: cannot start %s: %s\n", args[0], std::strerror(errno));
    _exit(127);
  }
  close(fds[1]);
  std::string pending;
  char buf[4096];
  auto flush_line = [&](const std::string& line) {
    if (echo_prefix.empty() && echo_if.empty()) return;
    bool echo = echo_if.empty();
    for (const auto& s : echo_if) echo = echo || s.empty() || line.find(s) != std::string::npos;
    if (echo) std::printf("%s%s\n", echo_prefix.c_str(), line.c_str()), std::fflush(stdout);
  };
  while (true) {
    const ssize_t k = read(fds[0], buf, sizeof buf);
    if (k < 0 && errno == EINTR) continue;
    if (k <= 0) break;
    out.write(buf, k);
    pending.append(buf, static_cast<size_t>(k));
    size_t nl;
    while ((nl = pending.find_first_of("\n\r")) != std::string::npos) {
      const std::string line = pending.substr(0, nl);
      pending.erase(0, nl + 1);
      if (!line.empty()) flush_line(line);
    }
  }
  close(fds[0]);
  if (!pending.empty()) flush_line(pending);
  int status = 0;
  struct rusage ru {};
  while (wait4(pid, &status, 0, &ru) < 0 && errno == EINTR) {
  }
  ProcessResult r;
  r.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const double busy1 = machine_busy_seconds();
  r.cpu_seconds = static_cast<double>(ru.ru_utime.tv_sec + ru.ru_stime.tv_sec) +
                  1e-6 * static_cast<double>(ru.ru_utime.tv_usec + ru.ru_stime.tv_usec);
  if (busy0 >= 0 && busy1 >= 0) r.machine_busy_seconds = busy1 - busy0;
  if (WIFEXITED(status)) r.exit_code = WEXITSTATUS(status);
  else if (WIFSIGNALED(status)) r.exit_code = 128 + WTERMSIG(status);
  out << "[exit code " << r.exit_code << ", " << r.wall_seconds << " s]\n";
  return r;
}

std::optional<fs::path> find_in_path(const std::string& name) {
  if (name.find('/') != std::string::npos) {
    if (access(name.c_str(), X_OK) == 0) return fs::absolute(name);
    return std::nullopt;
  }
  const char* path = std::getenv("PATH");
  std::stringstream ss(path ? path : "/usr/local/bin:/usr/bin:/bin");
  std::string dir;
  while (std::getline(ss, dir, ':')) {
    if (dir.empty()) continue;
    const fs::path p = fs::path(dir) / name;
    if (access(p.c_str(), X_OK) == 0 && fs::is_regular_file(p)) return p;
  }
  return std::nullopt;
}

fs::path own_directory() { return fs::canonical("/proc/self/exe").parent_path(); }

std::vector<std::string> mpirun_prefix(const fs::path& mpirun, int ranks) {
  std::vector<std::string> a{mpirun.string(), "-np", std::to_string(ranks)};
  if (geteuid() == 0) a.push_back("--allow-run-as-root");
  a.push_back("--oversubscribe");  // the benchmark may ask for as many ranks as there are cores, or more
  return a;
}

std::string load_average() {
  std::ifstream in("/proc/loadavg");
  std::string a = "?", b = "?", c = "?";
  in >> a >> b >> c;
  return a + " " + b + " " + c;
}

}  // namespace mlcg::bench
