#pragma once
// What one measured run reports, read from dem_level's summary.json / series.csv or from a LIGGGHTS log.
#include <cstdint>
#include <filesystem>
#include <limits>
#include <string>
#include <utility>
#include <vector>

namespace mlcg::bench {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

struct RunMetrics {
  bool ok = false;
  std::string error;           // why not ok (first error line of the program)
  int ranks = 0;
  long steps = 0;
  long particles = 0;          // at the start of the run
  long particles_end = 0;
  double loop_seconds = 0.0;   // time-stepping wall time (setup and final output excluded)
  double rate = 0.0;           // particle-steps per second (all ranks)
  double neighbours = kNaN;    // neighbour-list pairs per particle (see the table notes)
  double rebuilds_per_1000 = kNaN;
  double bytes_per_particle = kNaN;
  // Share of loop_seconds, in this order: force, neighbour, comm, measure, other (NaN = not reported).
  double share[5] = {kNaN, kNaN, kNaN, kNaN, kNaN};
  double insert_share = kNaN;          // MLCG: insertion's share of loop_seconds (part of "other")
  long inserted = -1;                  // MLCG: mass_balance.inserted ([initial] particles included)
  long failed_to_place = -1;           // MLCG: mass_balance.failed_to_place
  double final_kinetic_energy = kNaN;  // [J]
  long dangerous_builds = -1;          // LIGGGHTS only
  double background_cores = kNaN;      // cores other processes kept busy meanwhile (machine load)
  std::vector<std::string> warnings;
  std::string breakdown;               // the program's own time breakdown, as text
};

// Whether a run keeps its particle count (a bed, a discharge) or fills (the pour): only a constant count
// lets parse_mlcg check summary.json's particle_steps against particles x steps.
enum class Count { Constant, Grows };

// dem_level run folder (summary.json, series.csv, log.txt); `exit_code` of the process.
RunMetrics parse_mlcg(const std::filesystem::path& run_dir, const std::filesystem::path& console_log, int exit_code,
                      Count count = Count::Constant);
// One dem_level run of `case_file` on `ranks` ranks (through `mpirun` when more than one) into a fresh
// `run_dir` (what it prints in run_dir/console.txt), parsed as parse_mlcg does; background_cores is set
// when /proc/stat tells it.
RunMetrics run_mlcg(const std::filesystem::path& dem_level, const std::filesystem::path& mpirun, int ranks,
                    const std::filesystem::path& case_file, const std::filesystem::path& run_dir,
                    Count count = Count::Constant);
// LIGGGHTS log (the `-log` file, or the console output).
RunMetrics parse_liggghts(const std::filesystem::path& log, const std::filesystem::path& console_log, int exit_code);

// The median of the values that are not NaN (NaN when none is).
double median(std::vector<double> v);

// Over the repeats of one configuration (not empty): the median of f(run); the run whose rate is
// closest to the median rate (the one whose details a table shows); (max - min) / median of the
// rates (NaN for a single run).
template <class F>
double median_of(const std::vector<RunMetrics>& runs, F f) {
  std::vector<double> v;
  for (const auto& m : runs) v.push_back(f(m));
  return median(v);
}
const RunMetrics& median_run(const std::vector<RunMetrics>& runs);
double rate_spread(const std::vector<RunMetrics>& runs);

// A number for a table, or "-" for NaN; a fraction as a percentage ("12.3%"), or "-".
std::string fmt_num(double x, const char* spec = "{:.3g}");
std::string fmt_pct(double x);

// First line of `file` that contains `needle` (trimmed), or "".
std::string first_line_with(const std::filesystem::path& file, const std::string& needle);

}  // namespace mlcg::bench
