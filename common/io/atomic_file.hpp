#pragma once
// Atomic file replacement: every user-visible file is written under a temporary
// name in the same directory, fsync'ed, then renamed over the final name, so an
// interrupted run never leaves a half-written file under a final name.
#include <filesystem>
#include <string>
#include <string_view>

namespace mlcg::io {

// Writes `content` to `p` atomically (temp file + fsync + rename). Creates the
// parent directory if needed. Throws std::runtime_error naming the path and errno.
void write_file_atomic(const std::filesystem::path& p, std::string_view content);

class AtomicPath;
// Writes `content` to ap's temp file (created or truncated; not yet committed). Throws
// std::runtime_error naming the final path and errno (e.g. "No space left on device").
void write_temp(const AtomicPath& ap, std::string_view content);

// RAII temp-path holder for writers that need a file name (e.g. HDF5):
// write to temp_path(), close the file, then commit(). If commit() is never
// called (exception, early return) the destructor removes the temp file.
class AtomicPath {
 public:
  // Temp name is "<final>.tmp.<pid>.<n>" in the final file's directory (same
  // file system, so rename is atomic). Creates the parent directory if needed.
  explicit AtomicPath(std::filesystem::path final_path);
  ~AtomicPath();
  AtomicPath(const AtomicPath&) = delete;
  AtomicPath& operator=(const AtomicPath&) = delete;
  AtomicPath(AtomicPath&& o) noexcept;
  AtomicPath& operator=(AtomicPath&& o) noexcept;

  const std::filesystem::path& temp_path() const { return temp_; }
  const std::filesystem::path& final_path() const { return final_; }
  bool committed() const { return committed_; }

  // fsync the (closed) temp file, rename it over the final path, fsync the
  // directory. Throws if the temp file is missing or already committed.
  void commit();
  // Remove the temp file now (no-op if absent or committed). Never throws.
  void discard() noexcept;

 private:
  std::filesystem::path final_, temp_;
  bool committed_ = false;
};

// Removes "<prefix>*.tmp.<pid>.*" leftovers in `dir` whose writing process is
// gone (a killed run). Files of live processes are kept. Best effort, never throws.
void remove_stale_temps(const std::filesystem::path& dir, std::string_view prefix) noexcept;

}  // namespace mlcg::io
