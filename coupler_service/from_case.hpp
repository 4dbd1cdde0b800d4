#pragma once
// Builds the coupler's configuration from a parsed multi-level case: the
// coupling grids (cubic cells on each region's box, clipped to the geometry),
// controller gains and limits with their automatic defaults, and the
// geometry test the insertion planner uses.
#include <memory>

#include "config/case_spec.hpp"
#include "coupler.hpp"
#include "walls/wall_set.hpp"

namespace mlcg::coupling {

struct CaseCoupling {
  CouplerConfig cfg;
  std::shared_ptr<const WallSet> walls;  // the case's walls without those an event removes
  FitsGeometry fits;                     // sphere clear of the walls and reachable from an anchor
  PoseWalls pose;                        // places turning meshes where they are at a time; empty: none turn
};

// Throws std::invalid_argument when the case has no [coupling] section, a
// region's box holds no cell inside the geometry, or a turning mesh changes a
// region's cells as it turns (naming the region's line).
CaseCoupling coupling_from_case(const config::CaseSpec& cs);

// Coupling intervals between consistent checkpoints: [coupling] checkpoint_every (0 = the default:
// often, because a stop waits for the next one), rounded to whole intervals, at least 1.
inline constexpr double kDefaultCheckpointEvery = 0.02;  // s of simulated time
uint64_t checkpoint_intervals(const config::CaseSpec& cs);

}  // namespace mlcg::coupling
