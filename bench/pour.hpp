#pragma once
// The pour: the benchmark silo (lid closed) filled from empty, close above the growing heap, as the
// bed's preparation and the silo_small reference fill it, but at the measured runs' dt. MLCG only:
// LIGGGHTS inserts by its own rules, so a ratio would compare two insertions, not two solvers. Issue 14
// gives a phase its own scene when insertion or neighbour rebuilds cost more than 10 % of it; the
// reference's filling spends about 27 % of its time in rebuilds. The table shows the per-core rate and
// the shares of the loop time in rebuilds ("neighbor") and insertion ("insert").
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "parse.hpp"
#include "scenes.hpp"

namespace mlcg::bench {

struct PourOptions {
  std::vector<int> ranks;
  int repeat = 1;
  Files files;                    // the silo and lid STL, written by the caller
  std::filesystem::path work, dem_level;
  std::filesystem::path mpirun;   // empty: no runs on more than one rank
};

// One rank count's runs summarised: medians (NaN when no run succeeded; `error` then says why).
struct PourRow {
  double per_core = kNaN;         // particle-steps/s per core
  double spread = kNaN;           // (max - min) / median of the rate, over the repeats
  double busy = kNaN;             // cores other processes kept busy
  double rebuild_share = kNaN;    // summary.json "neighbor" seconds / loop seconds
  double insert_share = kNaN;     // "insert" seconds / loop seconds
  double rebuilds_per_1000 = kNaN;
  long particles_end = -1;        // particles at the end of the median-rate run
  std::string breakdown;          // the median-rate run's time breakdown
  std::string error;
};
using PourRows = std::map<int, PourRow>;

// The medians of `runs` (each parsed with Count::Grows); a row with `error` set when there are none.
PourRow summarise_pour(const std::vector<RunMetrics>& runs);
// What is wrong with one run of `steps` steps: particles lost from the closed silo or never placed, a
// different step count, the run's own warnings. Empty for a good run.
std::vector<std::string> pour_problems(const RunMetrics& m, long steps);

// Writes the cases, runs every rank count `repeat` times (in rounds), prints the table.
PourRows run_pour(const BenchParams& p, const PourOptions& o);

// "pour rank1=<x> rank2=<y> rebuild_share1=<a> rebuild_share2=<b>" for `ranks` ("na" where missing).
std::string pour_line(const PourRows& rows, const std::vector<int>& ranks);

}  // namespace mlcg::bench
