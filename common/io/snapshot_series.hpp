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

#include "core/vec3.hpp"
#include "io/series_index.hpp"

namespace mlcg::io {

struct SnapshotEntry {
  std::uint64_t index = 0;  // file counter
  double time = 0.0;
  std::uint64_t step = 0;
  std::uint64_t count = 0;  // particles
};

// entries(), size(), file_path(), xmf_path(), directory(), truncate_after()
// and set_compression() come from SeriesIndex.
class SnapshotSeries : public SeriesIndex<SnapshotEntry> {
 public:
  using Entry = SnapshotEntry;

  // resume=false: starts a new series; throws if run_dir/base/index.json exists
  // (refuses to mix two runs). resume=true: continues the recorded series (or
  // starts one if none exists) and rewrites the xmf from the index.
  SnapshotSeries(std::filesystem::path run_dir, std::string base, bool resume = false);

  // Writes snapshot file + index + xmf. Pointers may be null only when n == 0.
  // Entries at times >= `time` are dropped first (and their files deleted): after
  // a restart from a checkpoint, the re-run replaces what was written past it.
  void write(double time, std::uint64_t step, std::size_t n, const Vec3* x, const Vec3* v, const Vec3* omega,
             const double* radius, const std::int64_t* id);

 private:
  void to_json(nlohmann::json& j, const Entry& e) const override;
  Entry from_json(const nlohmann::json& j) const override;
  std::string xdmf_grid(const Entry& e, const std::string& file) const override;
};

}  // namespace mlcg::io
