#pragma once
// inserted.csv of a fine level: every particle the coupler sent it, as received (interval, grid, the face
// whose mass it carries, id, position, radius, mass). Written by rank 0 only (every rank reads the same
// list), so the coupler's per-face ledger and the placement can be checked against what the level got.
// A level continuing from a checkpoint at interval k keeps the rows of the intervals before k and drops
// the rest (they are run again); rows reach the disk at least at every checkpoint.
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <vector>

#include "core/particles.hpp"
#include "mlcg/bus.pb.h"

namespace mlcg::coupling {

class InsertLog {
 public:
  // Opens `path` for the run that starts at interval `start` (a fresh file at 0).
  void open(const std::filesystem::path& path, uint64_t start);
  bool is_open() const { return out_.is_open(); }
  // The particles of grid command `c` of interval k, as parsed (in the order of c.insert()).
  void record(uint64_t k, const bus::GridCommands& c, const std::vector<ParticleInit>& list);
  void flush() { if (out_.is_open()) out_.flush(); }

 private:
  std::ofstream out_;
};

}  // namespace mlcg::coupling
