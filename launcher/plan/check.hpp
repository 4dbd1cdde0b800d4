#pragma once
// `mlcg check CASE`: what `mlcg run CASE` checks before it starts anything (prepare_case, the same code),
// each level's time-step guard (the level's own, stability/stability_preview.hpp) and the coupler's grids
// (coupling_from_case, the coupler's own), without starting a process or writing a run folder. Then what
// the run would cost: the levels, dt against the Rayleigh and Hertz limits, the coupled regions, the
// particles per level, the particle-steps and the wall time on this machine (throughput.hpp).
#include <string>

#include "config/case_spec.hpp"
#include "plan/throughput.hpp"

namespace mlcg::launcher {

struct CheckOptions {
  std::string case_file;
  std::string out_dir;  // --out: checked as `mlcg run --out` would (must be new); nothing is created
  std::string hosts;    // --hosts / --curve: checked as `mlcg run` would
  bool curve = false;
  Calibration calibration = Calibration::Cached;
};

// 0 when `mlcg run` would start the case; 2 with `mlcg run`'s messages ("error: FILE:LINE: KEY: ...") on
// stderr when it would be refused, by the launcher or by a level's guard before step 1.
int check_case(const CheckOptions& o);

// The cost model `mlcg check` prints: the particle-steps of every level to simulated time `end` (each level's
// particles as counted or estimated there), and the case's end time (its earliest, for a conditional end;
// <= 0 when not known before the run). Throw as `mlcg check` would refuse the case.
double particle_steps_to(const config::CaseSpec& cs, double end);
double estimated_end(const config::CaseSpec& cs);

}  // namespace mlcg::launcher
