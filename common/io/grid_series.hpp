#pragma once
// Cell statistics on a regular grid, as a time series ParaView opens directly.
//
//   run/grids/NAME.xmf                  Temporal Collection of 3DCoRectMesh grids
//   run/grids/NAME/NAME_000007.h5       cell-centred datasets, shape (nz, ny, nx[, c])
//   run/grids/NAME/index.json           the series' own record (used on resume)
//   run/grids/NAME/times.csv            index,time
//
// Cells are ordered x fastest (i + nx*(j + ny*k)), i.e. C order over (nz, ny, nx).
// The "stress" dataset is stored in XDMF Tensor6 order xx xy xz yy yz zz (what
// ParaView expects) and carries an attribute "components" saying so; the
// write() argument uses the solver's order xx yy zz xy xz yz.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "core/vec3.hpp"
#include "io/series_index.hpp"

namespace mlcg::io {

struct GridSpec {
  Vec3 origin;       // corner of cell (0,0,0)
  double h = 0.0;    // cubic cell edge
  int nx = 0, ny = 0, nz = 0;
  std::size_t cells() const { return static_cast<std::size_t>(nx) * ny * nz; }
};

// entries(), size(), file_path(), xmf_path(), directory(), truncate_after()
// and set_compression() come from SeriesIndex.
class GridSeries : public SeriesIndex<SeriesEntry> {
 public:
  using Entry = SeriesEntry;

  // Same resume rules as SnapshotSeries; on resume the recorded grid must equal `spec`.
  GridSeries(std::filesystem::path run_dir, std::string name, const GridSpec& spec, bool resume = false);
  GridSeries(std::filesystem::path run_dir, std::string name, Vec3 origin, double h, int nx, int ny, int nz,
             bool resume = false)
      : GridSeries(std::move(run_dir), std::move(name), GridSpec{origin, h, nx, ny, nz}, resume) {}

  // Sizes: cells() each, except mean_velocity (cells()) and stress6 (6 * cells()).
  // Entries at times >= `time` are dropped first, as in SnapshotSeries.
  void write(double time, const std::vector<double>& volume_fraction, const std::vector<Vec3>& mean_velocity,
             const std::vector<double>& max_speed, const std::vector<double>& stress6,
             const std::vector<double>& count);

  const GridSpec& spec() const { return spec_; }

 private:
  void header_to_json(nlohmann::json& j) const override;
  void to_json(nlohmann::json& j, const Entry& e) const override;
  Entry from_json(const nlohmann::json& j) const override;
  std::string xdmf_grid(const Entry& e, const std::string& file) const override;

  GridSpec spec_;
};

}  // namespace mlcg::io
