#pragma once
// `mlcg plan CASE --out VARIANT.toml`: from a single-level case (the fully resolved reference) writes the
// MLCG variant a user would otherwise write by hand (`base = ` the case, saying only what differs):
//   - levels: the case's level as the finest, coarse levels at 2x (and 4x) its alpha with dt scaled alike;
//   - one fine region per outlet of the scene (scene/outlets.hpp), or one around outlets whose regions would
//     touch; each in the outlet's own frame: kPlanDepth (or kPlanDepthOnePercent for --error below 3) outlet
//     widths deep along the inward normal (a downward outlet's to the nearest whole cell, never below the
//     region rules' advised height; regions side by side kPlanDepthSiblings, rounded up), one cell beyond the outlet, the outlet's half-length plus one
//     width across it, in cubic cells of kPlanCellDiameters coarse diameters; grown to hold every probe;
//   - with three levels a region of the coarsest level around each, two of its cells deeper and one wider;
//   - the coupling interval automatic, events at fixed times (a hierarchy's levels must open together):
//     the time each fired in --reference-run, else its `latest`.
// It checks the variant as `mlcg run` would (the region rules, the coupler's grids, every level's guard),
// prints what it chose and why and the expected particle-steps against the reference (the cost model of
// `mlcg check`), and writes the file only when all passes (to a temporary name, then renamed; never over
// an existing file).
#include <string>

namespace mlcg::launcher {

// Evidence the planner plans from (config/region_rules.hpp has the measured thresholds):
inline constexpr double kPlanDepth = 1.5;            // outlet widths: silo_small at 1.5 D0 was +1.2 %
inline constexpr double kPlanDepthOnePercent = 2.0;  // silo_small at 2 D0: +0.4 %
// Fine regions side by side over one coarse level (one per outlet): at least this deep, rounded up to whole cells
// (config::kSiblingTopAboveOrifice has the evidence).
inline constexpr double kPlanDepthSiblings = 2.0;
inline constexpr double kPlanCellDiameters = 3.6;    // the paper's 2 cm cells over 5.6 mm coarse particles

struct PlanOptions {
  std::string case_file, out;
  double error = 3.0;       // target error of each outlet's discharge [%]
  int levels = 2;           // 2 or 3
  std::string reference_run;  // a completed run of the case: its events' firing times
};

// 0 written; 2 refused (the message on stderr, nothing written).
int plan_case(const PlanOptions& o);

}  // namespace mlcg::launcher
