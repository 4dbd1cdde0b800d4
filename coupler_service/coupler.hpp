#pragma once
// The coupler's interval logic, without sockets: given every level's
// statistics of interval k it computes every level's commands for interval
// k + 1 (DESIGN.md section 3). Deterministic: the result depends on the inputs
// and the seed only, never on the order in which levels reported.
//
// Per region (a coarse level over a fine one):
//   coarse face crossings  -> InsertionPlanner -> fine insertion list
//   coarse / fine sigma_zz -> PI per transition cell -> fine traction, speed limit
//   fine / coarse velocity -> PI per correction cell -> coarse acceleration
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "bus/coupling_grid.hpp"
#include "controllers.hpp"
#include "insertion_planner.hpp"
#include "mlcg/bus.pb.h"

namespace mlcg::coupling {

struct LevelConfig {
  std::string name;
  double alpha = 1.0, dt = 0.0;
  uint32_t ranks = 1;
};

struct RegionConfig {
  bus::CouplingGrid grid;           // coarse_level / fine_level index LevelConfig entries
  PlannerParams planner;
  PiController pi;                  // gains and limit; one copy per transition cell
  VelocityController velocity;
  enum class Correct { None, Velocity, MassFlow } correct = Correct::MassFlow;
  double velocity_only_below = -1e300;
  double phi_min = 0.05;            // a cell with less solid is treated as empty
};

struct CouplerConfig {
  std::vector<LevelConfig> levels;
  std::vector<RegionConfig> regions;
  double interval = 0.0;            // coupling interval [s]
  uint64_t seed = 1;
  double heartbeat = 1.0, timeout = 60.0;
};

// One region's controller and insertion state after an interval, for logs.
struct RegionLog {
  std::vector<double> setpoint, measured, traction;  // per transition cell (sigma_zz, Pa)
  std::vector<Vec3> acceleration;                    // per active cell (zero where not corrected)
  size_t inserted = 0;                               // particles in this interval's list
  double inserted_mass = 0.0;
  double returned_mass = 0.0;                        // fine mass that left the region this interval
  double coarse_mass = 0.0, fine_mass = 0.0;         // each level's mass in the region's active cells
  double fine_leaving = 0.0;                         // fine mass out of the region, not yet removed
};

class Coupler {
 public:
  // Throws std::invalid_argument naming the inconsistency (grids, levels, intervals).
  // pose: places the walls where they are at a time (turning meshes), called with the time of each
  // interval's insertion before it is planned; empty: the walls stay.
  Coupler(CouplerConfig cfg, FitsGeometry fits, PoseWalls pose = {});

  const CouplerConfig& config() const { return cfg_; }
  int level_index(const std::string& name) const;  // -1 if unknown
  bus::Welcome welcome(size_t level, uint64_t start_interval) const;
  // Commands for interval 0: nothing to insert, no forces.
  std::vector<bus::IntervalCommands> initial_commands() const;
  // stats[l] = level l's statistics of interval k. Throws std::invalid_argument
  // naming the level and field when a message does not fit the grids.
  std::vector<bus::IntervalCommands> advance(uint64_t k, const std::vector<bus::IntervalStats>& stats);

  // The levels finished without running the last commands: their insertion lists are returned to
  // the faces, so the totals count what the fine levels really inserted.
  void cancel_last_insertions();

  // The state a resumed run needs (faces, controllers, the latest insertion lists), and back
  // (coupler_checkpoint.cpp). restore() throws std::invalid_argument when the checkpoint does not
  // fit this case's grids.
  void save(bus::CouplerCheckpoint& out) const;
  void restore(const bus::CouplerCheckpoint& in);

  const bus::CouplingGeometry& geometry(size_t r) const { return regions_[r]->geo; }
  const InsertionPlanner& planner(size_t r) const { return regions_[r]->planner; }
  const RegionLog& log(size_t r) const { return regions_[r]->log; }

 private:
  struct Region {
    Region(const RegionConfig& c, const FitsGeometry& fits);
    RegionConfig cfg;
    bus::CouplingGeometry geo;
    InsertionPlanner planner;
    std::vector<PiController> pi;  // per transition cell (face order)
    std::vector<Vec3> vint;        // per active cell: the velocity controller's integral [m/s s]
    RegionLog log;
    std::vector<Insert> last;       // the latest insertion list sent
  };
  const bus::GridStats& grid_stats(const bus::IntervalStats& s, size_t region, size_t level) const;
  void check(const bus::GridStats& g, const Region& r, bool coarse, size_t level) const;
  // The three halves of one region's interval: the fine level's insertion list, the transition layer's
  // tractions and speed limits, the coarse level's correction accelerations.
  void plan_insertions(Region& r, const bus::GridStats& cs, const bus::GridStats& fs, uint64_t k,
                       bus::GridCommands& fine) const;
  void transition_layer(Region& r, const bus::GridStats& cs, const bus::GridStats& fs, bus::GridCommands& fine) const;
  void correct_coarse(Region& r, const bus::GridStats& cs, const bus::GridStats& fs, bus::GridCommands& coarse) const;
  // Every value finite, histogram counts and occupant radii within what a level can send (a stray or
  // damaged message must be refused, not planned with).
  void check_values(const bus::GridStats& g, const Region& r, size_t level) const;
  static constexpr int64_t kMaxCrossings = 1'000'000'000'000;  // per face and radius bin in one interval

  CouplerConfig cfg_;
  PoseWalls pose_;
  std::vector<std::unique_ptr<Region>> regions_;
};

}  // namespace mlcg::coupling
