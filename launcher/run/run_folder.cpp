#include "run/run_folder.hpp"

#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fcntl.h>
#include <string>
#include <sys/file.h>
#include <unistd.h>

#include "run/checkpoints.hpp"

namespace fs = std::filesystem;

namespace mlcg::launcher {
namespace {

std::string why(int err) { return std::strerror(err); }

// What the folder holds, for the message: "a run (summary.json: completed)", "a run (log.txt)", "3 entries".
std::string contents(const fs::path& dir, size_t entries, const nlohmann::json& summary) {
  if (summary.is_object()) return "a run (summary.json: " + summary.value("status", "?") + ")";
  if (fs::exists(dir / "launcher.json")) return "the run folder of a multi-level run";
  for (const char* f : {"case.toml", "log.txt", "checkpoint.h5"})
    if (fs::exists(dir / f)) return std::string("a run (") + f + ")";
  return std::to_string(entries) + " entr" + (entries == 1 ? "y" : "ies");
}

// The pid a holder wrote into the lock file, or "unknown" (it may not have written it yet).
std::string holder_of(int fd) {
  char buf[32] = {0};
  const ssize_t n = pread(fd, buf, sizeof buf - 1, 0);
  std::string pid(buf, n > 0 ? static_cast<size_t>(n) : 0);
  while (!pid.empty() && (pid.back() == '\n' || pid.back() == ' ')) pid.pop_back();
  return pid.empty() ? "unknown" : pid;
}

}  // namespace

bool submission_file(const std::string& name) {
  if (name == kLockFile || name == kSubmitScript) return true;
  const std::string pre = "slurm-", post = ".out";
  if (name.size() <= pre.size() + post.size() || name.rfind(pre, 0) != 0 ||
      name.compare(name.size() - post.size(), post.size(), post) != 0)
    return false;
  for (size_t k = pre.size(); k < name.size() - post.size(); ++k)
    if (!std::isdigit(static_cast<unsigned char>(name[k]))) return false;
  return true;
}

void check_new_run_folder(const fs::path& dir) {
  std::error_code ec;
  const auto st = fs::status(dir, ec);
  if (st.type() == fs::file_type::not_found) return;
  if (ec) throw RunFolderError("cannot use --out " + dir.string() + ": " + ec.message());
  if (!fs::is_directory(st))
    throw RunFolderError("--out " + dir.string() + " is an existing file, not a folder; nothing was written. Give --out "
                         "a new folder");
  size_t entries = 0;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec))
    entries += !submission_file(it->path().filename().string());  // a run that wrote nothing else
  if (ec) throw RunFolderError("cannot read --out " + dir.string() + ": " + ec.message());
  if (entries == 0) return;
  const auto summary = read_json_or_null(dir / "summary.json");
  const std::string what = "--out " + dir.string() + " already holds " + contents(dir, entries, summary) +
                           "; a run never reuses a folder and nothing was written. ";
  const bool completed = summary.is_object() && summary.value("status", "") == "completed";
  if (!completed && fs::exists(dir / "launcher.json") && fs::exists(dir / "checkpoints" / "manifest.json"))
    throw RunFolderError(what + "Continue that run with `mlcg resume " + dir.string() + "`, or give --out a new folder");
  throw RunFolderError(what + "Give --out a new folder");
}

RunLock::RunLock(const fs::path& run_dir) {
  const fs::path p = run_dir / kLockFile;
  fd_ = ::open(p.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd_ < 0) throw RunFolderError("cannot open " + p.string() + ": " + why(errno) + " (is the folder writable?)");
  if (flock(fd_, LOCK_EX | LOCK_NB) != 0) {
    const int err = errno;
    const std::string holder = holder_of(fd_);
    ::close(fd_);
    fd_ = -1;
    if (err != EWOULDBLOCK) throw RunFolderError("cannot lock " + p.string() + ": " + why(err));
    throw RunFolderError(run_dir.string() + " is in use by the launcher pid " + holder + " (it holds " + p.string() +
                         "); a run folder takes one running hierarchy at a time: let that run end or stop it first "
                         "(Ctrl-C in its terminal, or kill -INT " + holder + ")");
  }
  // The holder's pid for the message above. Written in place, not through a temporary file and a
  // rename: the lock belongs to this inode, which must stay the lock file. The lock holds without it.
  const std::string pid = std::to_string(getpid()) + "\n";
  if (ftruncate(fd_, 0) != 0 || pwrite(fd_, pid.data(), pid.size(), 0) != static_cast<ssize_t>(pid.size()))
    std::fprintf(stderr, "mlcg: warning: cannot write this launcher's pid into %s: %s\n", p.c_str(), why(errno).c_str());
}

RunLock::~RunLock() {
  if (fd_ >= 0) ::close(fd_);  // releases the lock
}

std::unique_ptr<RunLock> claim_new_run_folder(const fs::path& dir) {
  check_new_run_folder(dir);
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw RunFolderError("cannot create the run folder --out " + dir.string() + ": " + ec.message());
  auto lock = std::make_unique<RunLock>(dir);
  check_new_run_folder(dir);
  return lock;
}

}  // namespace mlcg::launcher
