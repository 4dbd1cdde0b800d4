#pragma once
// The parts a Level (level.hpp) is made of: plain structs the level owns and its files work on,
// each named for one question a reader asks of the level.
//   LevelPhysics   what the case fixes for this level: time step, scale, gravity, domain, materials, guard
//   ParticleState  the particles, their neighbour and wall lists and their contact history
//   Stepper        how the time loop moves the state on: the force routine and its context, the rank
//                  decomposition and ghosts, the neighbour search's sizes and when it rebuilds
//   Scene          what the case puts around the particles: insertions, probes, cell grids, events
//   Reporting      what the level writes and tells besides its log: snapshots, the series' rows, the
//                  phase times, progress lines, the first output that failed
// RunState (level.hpp) holds the scalars a checkpoint carries. The parts are members, not pointers, and
// have no virtual calls: the time loop reaches a particle array through one member offset, as before.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/material.hpp"
#include "core/particles.hpp"
#include "insertion/inserter.hpp"
#include "level/force_dispatch.hpp"
#include "measure/cell_grid.hpp"
#include "measure/probe.hpp"
#include "neighbor/neighbor_list.hpp"
#include "parallel/decomposition.hpp"
#include "parallel/exchange.hpp"
#include "stability/stability.hpp"
#include "walls/wall_set.hpp"

namespace mlcg {
namespace io { class SnapshotSeries; class GridSeries; }

// A level's coupling work in parts (summary.json: performance.coupling_parts): where the overhead goes.
struct CouplingTimes {
  double insert = 0.0;      // the coupler's insertion list: adding, overlap and wall checks
  double crossings = 0.0;   // face crossings after each drift and births inside the region (coarse role)
  double controller = 0.0;  // traction weights each interval, controller forces each step
  double samples = 0.0;     // cell samples (the stress kernel's extra on those steps is in force)
  double statistics = 0.0;  // the interval's message: cell means, occupants, mass check
  double send = 0.0;        // handing the statistics to the bus
  double total() const { return insert + crossings + controller + samples + statistics + send; }
};

// Wall seconds spent per phase of the step loop (for benchmarks and reports).
struct PhaseTimes {
  double integrate = 0.0;  // both velocity-Verlet halves and the NaN guard
  double neighbor = 0.0;   // rebuilds: removal, sorting, binning, lists, wall candidates
  double force = 0.0;      // pair and wall contact kernels
  double comm = 0.0;       // exchanges between MPI ranks
  double measure = 0.0;    // probes, cell grids, event conditions
  double insert = 0.0;     // insertion batches
  double output = 0.0;     // series, snapshots, checkpoints
  CouplingTimes coupling;  // multi-level work, in parts
  double coupling_wait = 0.0;  // blocked on the coupler's commands (the other levels' pace included)
  double force_sample_steps = 0.0;  // the part of force spent on steps that accumulate stress (cell samples)
  double sample_steps = 0.0;        // how many steps those were
  double insert_rebuilds = 0.0;         // neighbour rebuilds only the coupler's insertions asked for
  double insert_rebuild_seconds = 0.0;  // their time (in neighbor)
  double pair_kernel_steps[3] = {0.0, 0.0, 0.0};  // steps with pairs listed, per pair-kernel variant (ContactStats)
  double total() const {
    return integrate + neighbor + force + comm + measure + insert + output + coupling.total() + coupling_wait;
  }
};

// Set once by Level::setup from the case (select_level, setup_contact, setup_stability).
struct LevelPhysics {
  double dt = 0.0, alpha = 1.0;
  Vec3 gravity;
  Vec3 dom_lo, dom_hi;
  MaterialTable mt;
  StabilityReport stab;
};

// The particles and their contacts. Between rebuilds the lists hold the contact history; around a
// rebuild (and after a checkpoint is read) it is held per particle in pair_hist and wall_hist.
struct ParticleState {
  Particles p;
  NeighborList nl;
  WallSet walls;
  ContactHistory pair_hist, wall_hist;
  bool history_loaded = false;      // contact history came from a checkpoint, not the list
  std::vector<double> stress6;      // 6 per particle; filled only on stress steps
  std::vector<Vec3> wall_force;     // per wall

  // Drops the ghosts; first the lists' contact history moves to per-particle form (unless it is
  // there already), as the lists index ghosts. keep_history: the contact model uses it (else cleared).
  void detach_ghosts(bool keep_history);
  // Heap bytes held for particles, contact lists, history and bins (capacities).
  size_t memory_bytes() const;
};

// What step_once() and rebuild() work with besides the state.
struct Stepper {
  Stepper(ParticleState& s, const MaterialTable& mt)
      : fctx{s.p, s.nl, s.walls, mt, 0.0, s.stress6, s.wall_force, {}} {}
  Stepper(const Stepper&) = delete;
  Stepper& operator=(const Stepper&) = delete;

  ContactChoice choice;
  bool keep_history = true;
  ForceRoutine forces = nullptr;
  ForceContext fctx;                // the state's arrays, as the force routine sees them
  Decomposition dec;
  GhostExchange ghosts;
  bool balance = true;
  double skin = 0.0;
  double r_max = 0.0;               // largest radius this level will hold
  double ghost_cutoff = 0.0;        // 2 r_max + skin
  bool rebuild_pending = true;
  int64_t global_particles = 0;     // over all ranks, as of the last rebuild
};

// The case's insertions, probes, cell grids and events, in the case's order.
struct Scene {
  struct Event {
    bool fired = false;
    double fired_at = -1.0;
    double next_check = 0.0;
  };
  struct Grid {
    CellGrid grid;
    uint64_t sample_every = 1;   // steps
    double output_interval = 0.0;
    double next_output = 0.0;
    int64_t outputs = 0;
    std::unique_ptr<io::GridSeries> series;
    std::vector<double> sums, maxs;  // scratch for one sample
  };
  std::vector<Inserter> ins;
  std::vector<MassFlowProbe> probes;
  std::vector<std::string> probe_events;  // window_relative_to per probe
  std::vector<Grid> grids;
  std::vector<Event> events;
};

// Output and reporting (not physics state).
struct Reporting {
  mutable std::string output_error;  // rank 0: the first output that could not be written (by const writers)
  std::unique_ptr<io::SnapshotSeries> snaps;
  std::vector<std::string> series_rows;
  PhaseTimes times;
  double wall_start = 0.0, last_progress = -1e300, last_progress_t = 0.0;
};

}  // namespace mlcg
