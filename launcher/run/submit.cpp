#include "run/submit.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <stdexcept>

#include <fmt/format.h>

#include "config/case_parser.hpp"
#include "process/process.hpp"
#include "run/run_case.hpp"
#include "run/run_folder.hpp"

namespace fs = std::filesystem;

namespace mlcg::launcher {
namespace {

// A word for /bin/sh: single-quoted, a ' inside as '\''.
std::string quote(const std::string& s) {
  std::string out = "'";
  for (const char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

// Writes `text` to `path` through a temporary name beside it and link(2): the script appears whole or not at
// all, and an existing file is never replaced (EEXIST).
void write_new_file(const fs::path& path, const std::string& text) {
  const fs::path tmp = path.string() + fmt::format(".tmp{}", getpid());
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0755);
  if (fd < 0) throw std::runtime_error("cannot write " + tmp.string() + ": " + std::strerror(errno));
  const bool ok = ::write(fd, text.data(), text.size()) == static_cast<ssize_t>(text.size()) && ::fsync(fd) == 0;
  const int err = errno;
  ::close(fd);
  if (!ok) {
    ::unlink(tmp.c_str());
    throw std::runtime_error("cannot write " + tmp.string() + ": " + std::strerror(err));
  }
  const int linked = ::link(tmp.c_str(), path.c_str());
  const int lerr = errno;
  ::unlink(tmp.c_str());
  if (linked != 0 && lerr == EEXIST)
    throw std::runtime_error(path.string() + " exists already; it is never overwritten (give --out a new folder)");
  if (linked != 0) throw std::runtime_error("cannot write " + path.string() + ": " + std::strerror(lerr));
}

// Runs argv, returns (exit code, its standard output); stderr goes to ours.
std::pair<int, std::string> capture(const std::vector<std::string>& argv) {
  int fds[2];
  if (pipe(fds) != 0) throw std::runtime_error(std::string("pipe: ") + std::strerror(errno));
  const pid_t pid = fork();
  if (pid < 0) throw std::runtime_error(std::string("fork: ") + std::strerror(errno));
  if (pid == 0) {
    dup2(fds[1], 1);
    ::close(fds[0]);
    ::close(fds[1]);
    std::vector<char*> a;
    for (const auto& s : argv) a.push_back(const_cast<char*>(s.c_str()));
    a.push_back(nullptr);
    execvp(a[0], a.data());
    std::fprintf(stderr, "mlcg: cannot run %s: %s\n", a[0], std::strerror(errno));
    _exit(127);
  }
  ::close(fds[1]);
  std::string out;
  char buf[4096];
  for (ssize_t n; (n = ::read(fds[0], buf, sizeof buf)) != 0;) {
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) break;
    out.append(buf, static_cast<size_t>(n));
  }
  ::close(fds[0]);
  int status = 0;
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  return {exit_code_of(status), out};
}

}  // namespace

std::string submit_script(const std::string& mlcg, const std::string& case_file, const std::string& run_dir,
                          const std::string& job_name, int ntasks, int levels, int level_ranks, bool quiet) {
  const std::time_t now = std::time(nullptr);
  char stamp[32];
  std::strftime(stamp, sizeof stamp, "%Y-%m-%d %H:%M:%S", std::localtime(&now));
  std::string why = levels > 1 ? fmt::format("{} level rank(s) + 1 for the coupler", level_ranks)
                               : fmt::format("the level's {} rank(s), no coupler", level_ranks);
  std::string s = "#!/bin/sh\n";
  s += fmt::format("# Written by `mlcg submit` on {} for {}.\n", stamp, case_file);
  s += fmt::format("# --ntasks: {}. Options given to `mlcg submit` go to sbatch and win over these lines.\n", why);
  s += fmt::format("#SBATCH --job-name={}\n", job_name);
  s += fmt::format("#SBATCH --ntasks={}\n", ntasks);
  s += fmt::format("#SBATCH --output={}/slurm-%j.out\n", run_dir);
  s += "# mlcg places the coupler and the levels on the allocation's nodes (Slurm's environment) and starts\n"
       "# them with mpirun, which reaches the other nodes through Slurm.\n";
  s += fmt::format("exec {} run {} --out {}{}\n", quote(mlcg), quote(case_file), quote(run_dir),
                   quiet ? " --quiet" : "");
  return s;
}

int submit_case(const std::string& case_file, std::string out_dir, bool quiet,
                const std::vector<std::string>& sbatch_args) {
  fs::path script;
  std::string text;
  try {
    const config::CaseSpec cs = config::load_case(case_file);
    check_regions(cs);
    int ranks = 0;
    for (const auto& l : cs.levels) ranks += l.ranks;
    const int ntasks = ranks + (cs.levels.size() > 1 ? 1 : 0);
    if (out_dir.empty()) out_dir = default_run_dir(case_file);
    const fs::path run = fs::absolute(out_dir).lexically_normal();
    check_new_run_folder(run);
    fs::create_directories(run);
    script = run / kSubmitScript;
    const fs::path c(case_file);
    const std::string name = "mlcg-" + c.parent_path().filename().string() + "-" + c.stem().string();
    text = submit_script((fs::path(own_directory()) / "mlcg").string(), fs::absolute(case_file).lexically_normal(),
                         run.string(), name, ntasks, static_cast<int>(cs.levels.size()), ranks, quiet);
    write_new_file(script, text);
    out_dir = run.string();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 2;
  }
  std::vector<std::string> argv{"sbatch", "--parsable"};
  argv.insert(argv.end(), sbatch_args.begin(), sbatch_args.end());
  argv.push_back(script.string());
  std::pair<int, std::string> r;
  try {
    r = capture(argv);
  } catch (const std::exception& e) {
    r = {127, e.what()};
  }
  std::string job = r.second.substr(0, r.second.find_first_of(";\n"));
  if (r.first != 0 || job.empty()) {
    std::fprintf(stderr, "error: sbatch %s failed (exit code %d); nothing was submitted, %s removed\n",
                 script.string().c_str(), r.first, script.string().c_str());
    std::error_code ec;
    fs::remove(script, ec);
    if (fs::is_empty(out_dir, ec)) fs::remove(out_dir, ec);
    return r.first != 0 ? r.first : 1;
  }
  std::printf("mlcg: submitted Slurm job %s (%s)\nmlcg: run folder %s, the job's output %s/slurm-%s.out\n",
              job.c_str(), script.c_str(), out_dir.c_str(), out_dir.c_str(), job.c_str());
  return 0;
}

}  // namespace mlcg::launcher
