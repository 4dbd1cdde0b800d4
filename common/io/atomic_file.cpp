#include "io/atomic_file.hpp"

#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <system_error>

namespace mlcg::io {
namespace fs = std::filesystem;

namespace {

[[noreturn]] void fail(const std::string& what, const fs::path& p, int err) {
  throw std::runtime_error(what + " '" + p.string() + "': " + std::strerror(err));
}

void make_parent(const fs::path& p) {
  const fs::path parent = p.parent_path();
  if (parent.empty()) return;
  std::error_code ec;
  fs::create_directories(parent, ec);
  if (ec) throw std::runtime_error("cannot create directory '" + parent.string() + "': " + ec.message());
}

void fsync_path(const fs::path& p) {
  const int fd = ::open(p.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) fail("cannot open for fsync", p, errno);
  if (::fsync(fd) != 0) {
    const int err = errno;
    ::close(fd);
    fail("fsync failed on", p, err);
  }
  ::close(fd);
}

// Makes the rename itself durable. Best effort: some file systems refuse
// fsync on directories, and the data is already safely renamed at this point.
void fsync_dir(const fs::path& dir) noexcept {
  const int fd = ::open(dir.empty() ? "." : dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return;
  (void)::fsync(fd);
  ::close(fd);
}

std::atomic<unsigned long> g_temp_counter{0};

}  // namespace

AtomicPath::AtomicPath(fs::path final_path) : final_(std::move(final_path)) {
  if (final_.filename().empty()) throw std::runtime_error("AtomicPath: '" + final_.string() + "' names no file");
  make_parent(final_);
  temp_ = final_;
  temp_ += ".tmp." + std::to_string(::getpid()) + "." + std::to_string(g_temp_counter++);
}

AtomicPath::~AtomicPath() { discard(); }

AtomicPath::AtomicPath(AtomicPath&& o) noexcept
    : final_(std::move(o.final_)), temp_(std::move(o.temp_)), committed_(o.committed_) {
  o.committed_ = true;  // moved-from object must not delete anything
  o.temp_.clear();
}

AtomicPath& AtomicPath::operator=(AtomicPath&& o) noexcept {
  if (this != &o) {
    discard();
    final_ = std::move(o.final_);
    temp_ = std::move(o.temp_);
    committed_ = o.committed_;
    o.committed_ = true;
    o.temp_.clear();
  }
  return *this;
}

void AtomicPath::commit() {
  if (committed_) throw std::runtime_error("AtomicPath: '" + final_.string() + "' already committed");
  fsync_path(temp_);
  if (::rename(temp_.c_str(), final_.c_str()) != 0) fail("cannot rename temp file onto", final_, errno);
  committed_ = true;
  fsync_dir(final_.parent_path());
}

void AtomicPath::discard() noexcept {
  if (committed_ || temp_.empty()) return;
  ::unlink(temp_.c_str());
}

void write_temp(const AtomicPath& ap, std::string_view content) {
  const fs::path& p = ap.final_path();
  const int fd = ::open(ap.temp_path().c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) fail("cannot create temp file for", p, errno);
  const char* data = content.data();
  size_t left = content.size();
  while (left > 0) {
    const ssize_t w = ::write(fd, data, left);
    if (w < 0) {
      if (errno == EINTR) continue;
      const int err = errno;
      ::close(fd);
      fail("write failed for", p, err);
    }
    data += w;
    left -= static_cast<size_t>(w);
  }
  // close() can report deferred write errors (NFS, quota): check it.
  if (::close(fd) != 0) fail("close failed for", p, errno);
}

void write_file_atomic(const fs::path& p, std::string_view content) {
  AtomicPath ap(p);
  write_temp(ap, content);
  ap.commit();
}

void remove_stale_temps(const fs::path& dir, std::string_view prefix) noexcept {
  try {
    std::error_code ec;
    for (const auto& e : fs::directory_iterator(dir, ec)) {
      const std::string name = e.path().filename().string();
      if (name.compare(0, prefix.size(), prefix) != 0) continue;
      const size_t t = name.find(".tmp.", prefix.size());
      if (t == std::string::npos) continue;
      const size_t a = t + 5, b = name.find('.', a);
      if (b == std::string::npos || b == a) continue;
      long pid = 0;
      bool digits = true;
      for (size_t i = a; i < b; ++i) {
        if (name[i] < '0' || name[i] > '9') { digits = false; break; }
        pid = pid * 10 + (name[i] - '0');
        if (pid > 1L << 31) { digits = false; break; }
      }
      if (!digits || pid <= 0) continue;
      if (::kill(static_cast<pid_t>(pid), 0) == 0 || errno != ESRCH) continue;  // writer alive
      fs::remove(e.path(), ec);
    }
  } catch (...) {
  }
}

}  // namespace mlcg::io
