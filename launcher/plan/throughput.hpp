#pragma once
// What this machine computes: the particle-steps per second of one dem_level rank, measured by running
// dem_level itself on a small built-in dense scene (a settled lattice of 4,096 particles in a box,
// 1,000 steps, about a second on an idle core) and read from its summary.json. `mlcg check` turns it
// into a wall-time estimate. The measurement is cached in $XDG_CACHE_HOME/mlcg/throughput.json (else
// ~/.cache/mlcg/throughput.json), keyed by the dem_level binary's path and modification time and the
// core count: a new build or another machine measures again.
#include <optional>
#include <string>

namespace mlcg::launcher {

struct Throughput {
  double per_core = 0.0;    // particle-steps/s of one rank (wall time: a busy machine measures less)
  std::string measured;     // when, UTC ("2026-12-02 15:40 UTC")
  bool from_cache = false;
};

enum class Calibration {
  Cached,  // the cached measurement, else measure now
  Force,   // measure now (`mlcg check --calibrate`)
  Skip,    // the cached measurement or none (`--no-calibrate`, MLCG_NO_CALIBRATE=1)
};

// The throughput of `dem_level` (a path). nullopt, with the reason in `why`, when skipped without a
// cached value or when the measurement failed.
std::optional<Throughput> machine_throughput(const std::string& dem_level, Calibration how, std::string& why);

// The cache file used (for messages and tests).
std::string throughput_cache_file();

// The calibration scene as case text (exposed for tests).
std::string calibration_case_text();

}  // namespace mlcg::launcher
