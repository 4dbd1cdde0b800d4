#pragma once
// Particle snapshot series: one HDF5 file per snapshot plus an XDMF index that
// ParaView opens as a time series.
//
//   run/particles.xmf                       Temporal Collection of Polyvertex grids
//   run/particles/particles_000042.h5       /position /velocity /omega (n x 3),
//                                           /radius (n), /id (n, int64), /connectivity
//   run/particles/index.json                the series' own record (used on resume)
//
// Every file is replaced atomically. Write order (h5, index.json, xmf) means a
// crash at any point leaves an index that only lists complete files.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "core/vec3.hpp"

namespace mlcg::io {

namespace detail {
// "base_000042.h5" (at least 6 digits).
std::string numbered_name(std::string_view base, std::uint64_t index, std::string_view ext);
// Shortest decimal text that parses back to exactly `v` (XML, CSV).
std::string format_double(double v);
// Series names become file names and XML attribute values: [A-Za-z0-9_.-]+, no leading '.'.
void check_series_name(const std::string& name, const char* who);
// Complete XDMF 3 document: one Temporal Collection `name` around `grids` (XML text).
std::string xdmf_document(const std::string& name, const std::string& grids);
}  // namespace detail

class SnapshotSeries {
 public:
  struct Entry {
    std::uint64_t index = 0;  // file counter
    double time = 0.0;
    std::uint64_t step = 0;
    std::uint64_t count = 0;  // particles
  };

  // resume=false: starts a new series; throws if run_dir/base/index.json exists
  // (refuses to mix two runs). resume=true: continues the recorded series (or
  // starts one if none exists) and rewrites the xmf from the index.
  SnapshotSeries(std::filesystem::path run_dir, std::string base, bool resume = false);

  // Writes snapshot file + index + xmf. Pointers may be null only when n == 0.
  // Entries at times >= `time` are dropped first (and their files deleted): after
  // a restart from a checkpoint, the re-run replaces what was written past it.
  void write(double time, std::uint64_t step, std::size_t n, const Vec3* x, const Vec3* v, const Vec3* omega,
             const double* radius, const std::int64_t* id);

  // Drops entries with time > `time` (e.g. right after restarting from a checkpoint).
  void truncate_after(double time);

  void set_compression(bool on) { compress_ = on; }
  const std::vector<Entry>& entries() const { return entries_; }
  std::size_t size() const { return entries_.size(); }
  std::filesystem::path file_path(const Entry& e) const;
  const std::filesystem::path& xmf_path() const { return xmf_; }
  const std::filesystem::path& directory() const { return dir_; }

 private:
  void drop_from(std::size_t k);  // removes entries_[k..] and their files
  void save_index() const;
  void save_xmf() const;

  std::filesystem::path run_dir_, dir_, xmf_, index_;
  std::string base_;
  std::vector<Entry> entries_;
  bool compress_ = false;
};

}  // namespace mlcg::io
