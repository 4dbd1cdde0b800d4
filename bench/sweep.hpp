#pragma once
// The size sweep: how our per-core speed holds as one level grows from tens of thousands to a
// million particles. The beds are square boxes (plane walls) of the benchmark's particles and
// material: one tile of about 30,000 particles is poured and settled once by dem_level, the larger
// beds are nx x ny copies of it side by side (a 0.01 mm gap between copies, so no two particles
// overlap; the inner walls are gone). Every size is the same settled packing, so a particle costs
// the same work at every size, and a slower per-particle rate at 1M is the memory hierarchy's doing.
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "scenes.hpp"

namespace mlcg::bench {

struct SweepOptions {
  std::vector<long> sizes;   // wanted particle counts; each becomes round(size / tile) tiles
  std::vector<int> ranks;
  long steps = 2000;         // steps of the smallest size; larger sizes run fewer (>= 200)
  int repeat = 1;
  bool rebuild = false;
  std::filesystem::path work, dem_level;
  std::filesystem::path mpirun;  // empty: no runs on more than one rank
};

// Per rank count, the median particle-steps/s per core of each measured size (particle count).
using SweepRates = std::map<int, std::map<long, double>>;

// Prepares (or reuses) the tile, runs every size and rank count, prints a table and returns the rates.
SweepRates run_sweep(const BenchParams& p, const SweepOptions& o);

// r(largest) / r(smallest) per rank count, formatted as "rank1=<x> rank2=<y>" ("na" where missing).
std::string scaling_line(const SweepRates& rates, const std::vector<int>& ranks);

}  // namespace mlcg::bench
