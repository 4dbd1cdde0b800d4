#pragma once
// Reads a dem_level particle snapshot (HDF5: position/velocity/omega (n x 3), radius, id) and writes
// one in the same layout (what [initial] file = ... reads).
#include <cstdint>
#include <filesystem>
#include <vector>

namespace mlcg::bench {

struct Snapshot {
  std::vector<double> x, v, w;  // n x 3, row-major
  std::vector<double> radius;
  std::vector<std::int64_t> id;
  size_t size() const { return radius.size(); }
};

Snapshot read_snapshot(const std::filesystem::path& file);
void write_snapshot(const std::filesystem::path& file, const Snapshot& s);

}  // namespace mlcg::bench
