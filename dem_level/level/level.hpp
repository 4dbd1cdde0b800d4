#pragma once
// One coarse-grain level: the particles, walls, insertion, measurements and
// the time loop, configured from a parsed case. The level never reads the case
// file itself (config/ does) and the physics never sees a TOML node.
//
// Step order (velocity Verlet):
//   events and insertion due at t  ->  first half kick + drift  ->  probes count
//   crossings  ->  rebuild if needed  ->  forces  ->  second half kick  ->  guards
// A coupled level (LevelOptions::coupler, level_coupling.cpp) adds: at an interval
// start the coupler's commands and insertion; face crossings after the drift;
// controller forces after the contact forces; cell samples and the interval's
// statistics after the step. Uncoupled, each of these is one untaken branch.
//
// Its data is in named parts (level_parts.hpp): the physics the case fixes, the particle state,
// the stepper, the scene, the reporting, and RunState below (what a checkpoint carries).
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "config/case_spec.hpp"
#include "level/energy_account.hpp"
#include "level/kick_choice.hpp"
#include "level/level_parts.hpp"
#include "parallel/comm.hpp"

namespace spdlog { class logger; }

namespace mlcg {
namespace io { class H5Reader; class H5Writer; }
namespace bus { class IntervalStats; }
struct SceneMap;
namespace bus { class CouplingGeometry; }

struct LevelOptions {
  std::filesystem::path out_dir;   // run folder; empty = write nothing (tests)
  std::filesystem::path restart;   // checkpoint to continue from
  int64_t max_steps = -1;          // stop (with a checkpoint) after this many steps in this process
  bool quiet = false;              // no progress lines
  bool single_rank = false;        // run on this rank alone even inside an MPI job
  std::string level;               // the [[levels]] entry to run (name); empty = the first
  std::string coupler;             // coupler endpoint: register there and run coupled; empty = uncoupled
  // run() leaves a step's second half-kick to the next step's first half above this many particles
  // per rank (see Level::step; tests lower it to reach that path with few particles). In-process A/B,
  // 2026-12-03 on an AMD host, per step: 1,080,000 particles -4.5 to -5.6 %; the 30,000 tile -0.7 to +2.7 %
  // and the 29,451 silo bed +1 to +3 %; on an Intel host (2 MiB L2) the bed's integration -39 %. Between
  // calibrate_kick_above and owed_kick_above the level times both on its first steps (kick_choice.hpp).
  int64_t owed_kick_above = 100000;
  int64_t calibrate_kick_above = 5000;
};

// Raised when the level stops on a guard: NaN/inf or an excessive overlap.
struct GuardStop : std::runtime_error { using std::runtime_error::runtime_error; };
// Raised on every rank when the run's output could not be written (a full disk): the message names the
// file. Earlier files and checkpoints stay as they were (each is replaced atomically).
struct OutputStop : std::runtime_error { using std::runtime_error::runtime_error; };
// Raised when a coupled level cannot go on: the coupler fell silent, refused or sent unusable commands.
struct CouplingStop : std::runtime_error { using std::runtime_error::runtime_error; };
// Raised when a signal (or interrupt()) stops the level inside a long phase of a step (an insertion batch);
// the step's unfinished work is dropped.
struct StopRequested : std::runtime_error { using std::runtime_error::runtime_error; };

enum class RunStatus { Completed, StepLimit, Interrupted, Failed };
const char* to_string(RunStatus s);

// Where a removed particle left: below the domain (the outlet), out of a fine region through its
// boundary surface (handed back to the coupler), or out of the domain sideways or above (through or
// over a wall: never expected).
enum class Exit : uint8_t { Outlet = 0, Boundary = 1, Wall = 2 };
constexpr int kExits = 3;
const char* to_string(Exit e);

struct MassBalance {
  int64_t requested = 0, inserted = 0, present = 0, removed = 0, failed = 0, pending = 0;
  double inserted_mass = 0.0, present_mass = 0.0, removed_mass = 0.0, failed_mass = 0.0;
  int64_t removed_by[kExits] = {0, 0, 0};
  double removed_mass_by[kExits] = {0.0, 0.0, 0.0};
};

// The scalars of a level's run that a checkpoint carries besides the particles and the scene
// (checkpoint.cpp names each once, for its writer and its reader): the clock, the ids, the mass
// balance's counters, the output schedule and the random numbers of insertion.
struct RunState {
  uint64_t step = 0;
  int64_t next_id = 0;
  int64_t removed = 0;
  double removed_mass = 0.0;
  int64_t removed_by[kExits] = {0, 0, 0};
  double removed_mass_by[kExits] = {0.0, 0.0, 0.0};
  int64_t explicit_count = 0;       // the case's [[particles]] and [initial] particles (and the coupler's)
  double explicit_mass = 0.0;
  uint64_t particle_steps = 0;
  size_t max_particles = 0;
  uint64_t rebuilds = 0;
  double end_time = -1.0;           // < 0: not known yet (waits for an event)
  double next_stats = 0.0, next_snapshot = 0.0, next_checkpoint = 0.0;
  int64_t snapshots = 0;
  double wall_seconds_before = 0.0;  // from earlier processes of a restarted run
  std::mt19937_64 rng;              // insertion's; seeded from the case
};

class Level {
 public:
  Level(const config::CaseSpec& cs, LevelOptions opt);
  ~Level();
  Level(const Level&) = delete;
  Level& operator=(const Level&) = delete;

  RunStatus run();                // until the end time (or max_steps / interrupt / guard)
  void step_once();               // one time step, events and insertion included (throws GuardStop)
  void add_particle(const ParticleInit& pi);  // explicit placement; ids must be unique

  // State, for tests and reports.
  const Particles& particles() const { return state_.p; }
  Particles& particles_mut() { stepper_.rebuild_pending = true; return state_.p; }
  double time() const { return static_cast<double>(run_.step) * physics_.dt; }
  uint64_t step() const { return run_.step; }
  double dt() const { return physics_.dt; }
  double end_time() const { return run_.end_time; }
  const WallSet& walls() const { return state_.walls; }
  const std::vector<Vec3>& wall_forces() const { return state_.wall_force; }
  const ContactStats& contact_stats() const { return stepper_.fctx.stats; }
  const std::vector<MassFlowProbe>& probes() const { return scene_.probes; }
  MassBalance mass_balance() const;
  double kinetic_energy() const;
  // Mechanical energy [J] (collective; level/energy.cpp): kinetic, rotational, gravitational
  // potential -m g.x, and the elastic energy stored in the contacts (Hertz and tangential springs).
  // Builds the neighbour lists first when they are stale (e.g. before step 1).
  using Energy = EnergyParts;
  Energy energy();
  // The energy account ([output] energy_interval; level/energy_account.hpp); null when off.
  const EnergyAccount* energy_account() const { return account_.get(); }
  const StabilityReport& stability() const { return physics_.stab; }
  const PhaseTimes& phase_times() const { return out_.times; }
  void reset_phase_times() { out_.times = PhaseTimes{}; }
  uint64_t rebuilds() const { return run_.rebuilds; }
  size_t neighbor_pairs() const { return state_.nl.pairs(); }
  // Heap bytes held for particles, contact lists, history and bins (capacities).
  size_t memory_bytes() const { return state_.memory_bytes(); }
  const config::CaseSpec& spec() const { return cs_; }
  // Cell-grid averages since the last output of grid g (resets them).
  GridAverages take_grid_averages(size_t g) { return scene_.grids[g].grid.take_averages(); }

  // Collective: the state of every rank, gathered and written by rank 0 (throws OutputStop on every
  // rank when it cannot be written).
  void write_checkpoint(const std::filesystem::path& path) const;
  void interrupt() { interrupted_ = true; }
  // This rank was asked to stop (interrupt() or a signal); the run loop agrees over the ranks.
  bool stopping() const;
  bool coupled() const { return coupled_ != nullptr; }
  // Collective. Intervals run, particles received from the coupler, and the largest overlap of
  // one of them with the particles of its rank at insertion, as a share of its diameter.
  // Also the largest overlap of an inserted particle with a wall (share of its diameter) and how
  // many were placed with their centre outside the walls (the grid's inside point cannot reach it).
  struct CouplingReport {
    uint64_t intervals = 0, inserted = 0;
    double worst_insert_overlap = 0.0, worst_insert_wall_overlap = 0.0;
    uint64_t inserted_outside_walls = 0;
  };
  CouplingReport coupling_report() const;

 private:
  // setup() in steps (level_setup.cpp), in the order it runs them.
  void setup();
  void setup_logging();
  void select_level();              // the [[levels]] entry: dt, alpha; gravity, domain, seed
  void setup_contact();             // materials and the force routine of the contact model
  void setup_decomposition();
  void setup_walls();
  void setup_insertions();
  void place_case_particles(bool fills_scene, std::vector<ParticleKind>& kinds, std::vector<PlacedParticle>& placed);
  double setup_stability(const std::vector<ParticleKind>& explicit_kinds,
                         const std::vector<PlacedParticle>& placed);  // returns the largest radius
  void setup_skin(double r_max);
  void setup_measurements();
  void start_state();               // run folder; checkpoint, coupler or the forces at t = 0
  void initial_forces();
  void load_checkpoint(const std::filesystem::path& path);
  // Parts of load_checkpoint (checkpoint.cpp): the checkpoint's scene against the case (refused when
  // it is another), the particles, and the state of walls, insertions, events, probes, grids, series.
  SceneMap check_scene(const io::H5Reader& r) const;
  void load_particles(const io::H5Reader& r, const SceneMap& map);
  void restore_scene_state(const io::H5Reader& r, const SceneMap& map);
  void restore_probes(const io::H5Reader& r, const SceneMap& map);
  void restore_grids(const io::H5Reader& r, const SceneMap& map);
  void refuse_placed_overlap();   // collective; after the forces at t = 0
  void load_initial_state(std::vector<ParticleKind>& kinds, std::vector<PlacedParticle>& placed, bool add);

  void pre_step();                // events and insertion at the current time
  void check_events(double t);
  void insert_due(double t);
  void fire_event(size_t e);
  void rebuild();
  // The probes' and the coupling's crossing candidates, from the particles where they are; from > 0: only the
  // particles [from, n_local) added since (a step checks crossings before its rebuild: they may cross in it).
  void refresh_candidates(size_t from = 0);
  std::string non_finite(const char* what, uint64_t step) const;  // names the first bad particle
  // run()'s steps may leave their second half-kick owed to the next step's first half (one pass
  // over the arrays instead of two): while kick_owed_, v and omega are half a kick short. Whatever
  // reads them between steps calls settle_kick() first (collective: guards the velocities);
  // pay_owed_kick() only applies it (on the way out of a failed run) and returns its checksum.
  void step(bool may_owe);
  void timed_rebuild(bool for_insert);  // rebuild(), its time also booked to the insertion that asked for it
  void step_forces();  // contact forces (with stress on sample steps), then the controller's
  bool may_owe_kick() const;
  bool owe_kick_allowed() const;  // nothing reads the velocities between two steps of run()
  void book_kick_step();          // a calibrating step's integration time; decides after the last
  void settle_kick();
  double pay_owed_kick();
  // Collective stop: throws GuardStop on every rank if any rank has a problem.
  void guard(const std::string& local_problem, double badness);
  void after_step();              // measurements and outputs at the new time
  void sample_energy();           // collective: a row of the energy account, when one is due
  void write_outputs(bool final);
  void write_snapshot();             // collective: gathered on rank 0
  void write_snapshot_file(const std::vector<char>& gathered);  // rank 0
  void write_series_files(std::vector<std::string> rows, const std::string& last, bool final) const;  // rank 0
  void write_summary_file(const std::string& status, const std::string& reason, const MassBalance& b,
                          const double* sums, const CouplingReport& cr) const;  // rank 0
  std::string series_row() const;
  void write_summary(const std::string& status, const std::string& reason) const;
  // The final outputs and log lines of run(); after a failed output only the summary is tried.
  void finish_run(RunStatus status, const std::string& reason, bool output_failed);
  void write_checkpoint_file(const std::filesystem::path& path, const std::vector<char>& particles,
                             const std::vector<char>& open_mass, const std::vector<char>& coupling_pending,
                             const CouplingReport& coupling) const;
  void restore_coupling_pending(const io::H5Reader& r);
  void write_scene_state(io::H5Writer& w) const;  // walls, insertions, probes, grids, events, series, scene
  // Output written on rank 0 that can fail (a full disk): the first failure is kept, and every
  // rank throws OutputStop with it at the next sync_output() (collective).
  void rank0_output(const std::function<void()>& write) const;
  void sync_output() const;
  void progress(bool force);
  std::string describe_particle(size_t i) const;
  void resolve_end_time();

  // Multi-level coupling (level_coupling.cpp); each hook runs only when coupled_.
  struct Coupled;
  struct CoupledDeleter { void operator()(Coupled* c) const; };  // Coupled is complete only in level_coupling.cpp
  void connect_coupler();               // collective: register, welcome, grids
  void coupling_begin_step();           // at an interval start: commands, insertion, controller weights
  void coupling_after_drift();          // face crossings
  void coupling_born(size_t i);         // particle i was just inserted by the level itself
  bool coupling_wants_stress() const;   // this step's forces feed a cell sample
  bool coupling_take_insert_rebuild();  // the pending rebuild is the coupler's insertion's (cleared on reading)
  void coupling_forces();               // controller forces
  void coupling_end_step();             // cell samples; the statistics (at the interval's end or `lead` before)
  bus::IntervalStats coupling_stats();  // collective: the statistics of the running interval
  std::vector<double> coupling_pending() const;  // every grid's sums since the last statistics, this rank's
  bool coupling_removes(size_t i);      // rebuild: particle i left a fine region (counted)
  void check_inserted_walls(Coupled& c, const bus::CouplingGeometry& geo, size_t first);  // particles [first, n)
  // One rank with valid lists: the coupler's particles can join them without a rebuild (append_inserted).
  bool can_append() const;
  void coupling_refresh(size_t from);  // the grids' part of refresh_candidates
  void append_inserted(size_t first);   // particles [first, n) into the lists and candidates
  bool coupling_finished() const;       // the coupler said stop and the last interval is done
  bool coupling_mid_interval() const;   // coupled, with steps of the current interval still to run
  bool coupling_reached(double end) const;  // the last interval of a run ending at `end` is done
  const std::string& coupling_stop_reason() const;  // non-empty: the coupler cut the run short
  void coupling_bye(RunStatus status, const std::string& reason);

  config::CaseSpec cs_;
  LevelOptions opt_;
  config::LevelSpec lvl_;
  Comm comm_;
  // The parts (level_parts.hpp); stepper_ refers to state_'s arrays and physics_' materials.
  LevelPhysics physics_;
  ParticleState state_;
  Stepper stepper_;
  Scene scene_;
  RunState run_;                    // what a checkpoint carries besides the particles and the scene
  int64_t case_placed_ = 0;         // the case's own: [[particles]] and [initial] on this level
  CouplingReport coupling_restored_;  // a coupled level's counters from its checkpoint (inserted, worst overlap)
  std::vector<double> coupling_pending_restored_;  // this rank's sums counted after the last statistics sent
  bool interrupted_ = false;
  int64_t steps_this_process_ = 0;
  bool kick_owed_ = false;          // see step()
  KickChoice kick_;                 // whether run()'s steps owe their kick: by size, or timed on this host

  std::shared_ptr<spdlog::logger> log_;
  Reporting out_;
  std::unique_ptr<Coupled, CoupledDeleter> coupled_;  // null unless LevelOptions::coupler is set
  std::unique_ptr<EnergyAccount> account_;            // null unless [output] energy_interval > 0
};

// Installs SIGINT/SIGTERM handlers that ask every running level to stop cleanly.
void install_signal_handlers();
bool stop_requested();

}  // namespace mlcg
