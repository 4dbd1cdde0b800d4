#pragma once
// The parsed case: plain values only. The physics is configured from these
// structs and never sees a TOML node. Specs compare equal when every value
// and every SourceLoc is equal (tests compare a variant with a full file). Every field is documented, with its TOML
// key, in cases/README.md. Lengths in m, times in s (simulated), angles none.
#include <algorithm>
#include <cstdint>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "core/vec3.hpp"

namespace mlcg::config {

// Where a table came from, so checks made after parsing can still name file:line.
struct SourceLoc {
  std::string file;
  int line = 0;
  std::string str() const { return file + ":" + std::to_string(line); }
  bool operator==(const SourceLoc&) const = default;
};

struct MaterialSpec {              // [[materials]]
  std::string name;                // name
  double youngs_modulus = 0.0;     // youngs_modulus  > 0
  double poisson_ratio = 0.0;      // poisson_ratio   in [0, 0.5)
  double density = 0.0;            // density         > 0
  SourceLoc loc;
  bool operator==(const MaterialSpec&) const = default;
};

struct InteractionSpec {           // [[interactions]]
  std::string a, b;                // between = ["m1", "m2"]
  double restitution = 0.0;        // restitution     in (0, 1]
  double friction = 0.0;           // friction        >= 0
  double rolling_friction = 0.0;   // rolling_friction >= 0 (needs [contact] rolling = "cdt")
  SourceLoc loc;
  bool operator==(const InteractionSpec&) const = default;
};

struct ContactSpec {               // [contact]
  std::string normal = "hertz";    // normal: "hertz"
  std::string tangential = "history";  // tangential: "history" | "none"
  std::string rolling = "none";    // rolling: "none" | "cdt"
  bool clamp_normal = false;       // clamp_normal: clamp the normal force at zero (no attraction)
  bool operator==(const ContactSpec&) const = default;
};

struct LevelSpec {                 // [[levels]]
  std::string name = "level0";     // name
  double alpha = 1.0;              // alpha: coarse-grain ratio >= 1; radii of every insertion are scaled by it
  double dt = 0.0;                 // dt > 0 (the parser resolves dt_alpha1 x alpha into it)
  int ranks = 1;                   // ranks >= 1 (MPI processes of this level)
  double skin = 0.0;               // skin >= 0 [m]; 0 = automatic (0.5 x largest level radius)
  double dt_alpha1 = 0.0;          // dt_alpha1 > 0: instead of dt, dt = dt_alpha1 x alpha (dt scales with alpha)
  double dt_rayleigh = 0.0;        // dt_rayleigh in (0, 1]: instead of dt, this share of the Rayleigh time of the level's
                                   // smallest particle, rounded down to 2 significant digits (resolved by the parser)
  std::vector<int> processors;     // processors = [px, py, pz]: MPI process grid (product = ranks); empty = automatic
  bool balance = true;             // balance: shift the rank boundaries to even out particle counts
  SourceLoc loc;
  bool operator==(const LevelSpec&) const = default;
};

struct DomainSpec {                // [domain]
  Vec3 min, max;                   // min, max: particles leaving this box are removed and counted
  bool operator==(const DomainSpec&) const = default;
};

enum class WallType { Plane, Cylinder, Cone, Disk, Mesh };

struct WallSpec {                  // [[walls]]
  std::string name;                // name (unique; events refer to it)
  WallType type = WallType::Plane; // type: "plane" | "cylinder" | "cone" | "disk" | "mesh"
  std::string material;            // material (a [[materials]] name)
  // plane: a half-space boundary; particles live on the side `normal` points to
  Vec3 point, normal{0, 0, 1};     // point, normal
  // cylinder / cone / disk: surface of revolution about the axis through `center`
  Vec3 center, axis{0, 0, 1};      // center, axis (need not be unit; normalised)
  double radius = 0.0;             // radius (cylinder, disk)
  double inner_radius = 0.0;       // inner_radius (disk) in [0, radius): an annulus, e.g. a flat floor with an orifice
  double radius_bottom = 0.0;      // radius_bottom, radius_top (cone) at s = bottom / top
  double radius_top = 0.0;
  double bottom = 0.0, top = 0.0;  // bottom < top: extent along the axis, measured from center (cylinder, cone)
  bool rim_bottom = false;         // rims = "none" | "bottom" | "top" | "both": contacts with the end circles
  bool rim_top = false;
  // mesh
  std::string file;                // file: STL (ASCII or binary), relative to the case file's folder
  double scale = 1.0;              // scale > 0 applied to the file's coordinates, then
  Vec3 offset;                     // offset added
  // The surface's motion, the geometry staying in place: a belt (plane, mesh: a velocity along the surface)
  // or a drum (cylinder, cone, disk: turning about its own axis, right-handed, rad/s).
  Vec3 surface_velocity;           // surface_velocity [m/s]
  double angular_velocity = 0.0;   // angular_velocity [rad/s]
  bool moving() const { return angular_velocity != 0.0 || !(surface_velocity == Vec3{}); }
  // A mesh moved rigidly from t = 0 (its geometry moves): at move_velocity, turning at move_angular_velocity
  // [rad/s, along the axis, right-handed] about the axis through move_center, which moves along.
  Vec3 move_velocity, move_angular_velocity, move_center;
  bool moves_rigidly() const { return !(move_velocity == Vec3{}) || !(move_angular_velocity == Vec3{}); }
  // The largest radius of a surface of revolution (0 for a plane or mesh): where a turning wall is fastest.
  double outer_radius() const { return std::max({radius, radius_bottom, radius_top}); }
  // The fastest speed of its surface [m/s]: a belt's, or a turning wall's at its outer radius.
  double surface_speed() const { return norm(surface_velocity) + std::abs(angular_velocity) * outer_radius(); }
  SourceLoc loc;
  bool operator==(const WallSpec&) const = default;
};

enum class RadiusKind { Constant, Uniform, Discrete };

struct RadiusSpec {                // radius = 1.4e-3  or  radius = { uniform = [min, max] }
  RadiusKind kind = RadiusKind::Constant;  //        or  radius = { values = [...], fractions = [...] }
  double value = 0.0;
  double min = 0.0, max = 0.0;
  std::vector<double> values, fractions;   // fractions by number, sum to 1
  double largest() const;
  double smallest() const;
  double mean() const;                // by number
  double mean_volume_factor() const;  // E[r^3]
  bool operator==(const RadiusSpec&) const = default;
};

enum class RegionType { Box, Cylinder };

struct RegionSpec {                // region = { type = "box", min = [...], max = [...] }
  RegionType type = RegionType::Box;  //   or { type = "cylinder", center = [x, y], radius, zmin, zmax } (axis = z)
  Vec3 min, max;                   // box, and the bounding box of a cylinder region after parsing
  double cx = 0.0, cy = 0.0, radius = 0.0;  // cylinder
  bool operator==(const RegionSpec&) const = default;
};

struct InsertionSpec {             // [[insertion]]
  std::string name;                // name
  std::string material;            // material
  RegionSpec region;               // region (inside the domain)
  RadiusSpec radius;               // radius at alpha = 1
  int64_t count = -1;              // count: particles of this level to insert (or count_alpha1 / alpha^3 of the
                                   //   coarsest level, rounded), or
  double mass = -1.0;              // mass [kg] in total; exactly one of count / count_alpha1 / mass
  double rate = -1.0;              // rate [particles/s] (or rate_alpha1 / alpha^3), or
  double mass_rate = -1.0;         // mass_rate [kg/s]; neither = everything in the first batch
  double start = 0.0;              // start >= 0
  double interval = 0.0;           // interval: batch period [s]; 0 = automatic
  Vec3 velocity;                   // velocity [m/s]
  double follow_gap = -1.0;        // follow_gap >= 0: each batch the region's bottom moves to this height
                                   //   above the highest particle below it (fill close above the heap)
  double follow_height = 0.0;      // follow_height > 0 [m]: height of the slab used with follow_gap;
                                   //   0 = 10 largest radii
  int max_attempts = 200;          // max_attempts: SSI candidates per particle before it counts as unplaced
  SourceLoc loc;
  bool operator==(const InsertionSpec&) const = default;
};

struct ParticleSpec {              // [[particles]] one particle placed explicitly (validation scenes)
  std::string material;            // material
  double radius = 0.0;             // radius > 0 at alpha = 1 (the level scales it by alpha)
  Vec3 position;                   // position (inside the domain)
  Vec3 velocity;                   // velocity [m/s]
  Vec3 omega;                      // omega [rad/s]
  SourceLoc loc;
  bool operator==(const ParticleSpec&) const = default;
};

struct EventSpec {                 // [[events]]
  std::string name;                // name
  double at = -1.0;                // at: fire at this time, or a condition:
  bool after_insertion = false;    // after_insertion: only once every insertion has finished
  double mean_speed_below = -1.0;  // mean_speed_below [m/s]: fire when the mass-weighted mean speed drops below
  double check_interval = 0.01;    // check_interval [s]
  double latest = std::numeric_limits<double>::infinity();  // latest: fire then at the latest (warns)
  std::vector<std::string> remove_walls;  // remove_walls = ["lid"]
  SourceLoc loc;
  bool operator==(const EventSpec&) const = default;
};

struct TimeSpec {                  // [time]
  double end = -1.0;               // end [s], or
  std::string end_event;           // end = { event = "open", plus = 0.6 }
  double end_plus = 0.0;
  double progress_interval = 2.0;  // progress_interval [wall s] between progress lines
  bool operator==(const TimeSpec&) const = default;
};

struct ProbeSpec {                 // [[probes]]  mass-flow probe: disk in a plane
  std::string name;
  Vec3 point;                      // point (centre, inside the domain)
  Vec3 normal{0, 0, -1};           // normal: positive flow direction
  double radius = 0.0;             // radius > 0
  double sample_rate = 100.0;      // sample_rate [Hz]
  double window_start = 0.0;       // window = [t0, t1] for mean and std of the mass flow
  double window_end = std::numeric_limits<double>::infinity();
  std::string window_event;        // window_relative_to = "open": the window counts from that event
  SourceLoc loc;
  bool operator==(const ProbeSpec&) const = default;
};

struct GridSpec {                  // [[grids]] cell statistics
  std::string name;
  Vec3 min, max;                   // min, max (inside the domain)
  double cell_size = 0.0;          // cell_size > 0 (cubic cells; the box is rounded up to whole cells)
  double sample_interval = 0.0;    // sample_interval [s]: 0 = every output_interval
  double output_interval = 0.0;    // output_interval [s] > 0: averages written this often
  SourceLoc loc;
  bool operator==(const GridSpec&) const = default;
};

struct OutputSpec {                // [output]
  double snapshot_interval = 0.0;  // snapshot_interval [s]; 0 = only the final state
  double checkpoint_interval = 0.0;// checkpoint_interval [s]; 0 = only at the end
  double stats_interval = 0.01;    // stats_interval [s]: rows of series.csv
  double energy_interval = 0.0;    // energy_interval [s]: rows of energy.csv (the energy account); 0 = off
  bool operator==(const OutputSpec&) const = default;
};

struct StabilitySpec {             // [stability]
  double rayleigh_fraction = 0.2;  // rayleigh_fraction in (0,1]: dt must not exceed this share of the Rayleigh time
  double min_steps_per_contact = 10.0;  // min_steps_per_contact: Hertz contact at max_impact_speed
  double max_overlap_fraction = 0.3;    // max_overlap_fraction: stop if an overlap exceeds this share of the smaller radius
  double max_impact_speed = -1.0;  // max_impact_speed [m/s]; < 0 = estimated from insertion speed and free fall
  std::string dt_override_reason;  // dt_override_reason: set to accept a dt above the guard, saying why
  bool operator==(const StabilitySpec&) const = default;
};

struct InitialSpec {               // [initial] start from particles saved in a snapshot file
  std::string file;                // file: an HDF5 particle snapshot (run/particles/*.h5), relative to the case
  std::string material;            // material of those particles
  SourceLoc loc;
  bool operator==(const InitialSpec&) const = default;
};

// Multi-level coupling (paper section 2.3; DESIGN.md section 3). Present only in
// hierarchy cases; a single-level case has none and starts no coupler.
struct CouplingRegionSpec {        // [[coupling.regions]] one fine region inside a coarser level
  std::string coarse, fine;        // coarse = "name", fine = "name": [[levels]] names, alpha(coarse) > alpha(fine)
  Vec3 min, max;                   // min, max [m]: box of the fine region, rounded outward to whole cells
  double cell_size = 0.02;         // cell_size [m] > 0: cubic coupling cells (paper: 2 cm)
  std::optional<Vec3> inside;      // inside: a point inside the geometry; default: the top layer's centre under the fill
  double insert_depth = 0.0;       // insert_depth [m] >= 0: slab below the boundary surface where fine particles
                                   //   are inserted; 0 = automatic (2 coarse diameters, at most one cell)
  double fade = 1.5;               // fade > 0 [fine diameters]: the PI traction fades out over this depth
  double kp = 0.5;                 // kp >= 0: PI proportional gain [Pa traction per Pa stress error]
  double ki = 200.0;               // ki >= 0, ki x interval <= 0.5 [1/s]: PI integral gain
  double traction_limit = 0.0;     // traction_limit [Pa] >= 0: largest |traction|; 0 = automatic
                                   //   (density x |g| x domain height: a full column of solid)
  std::string correct = "mass_flow";  // correct: "mass_flow" | "velocity" | "none" (coarse correction cells)
  double velocity_gain = 500.0;    // velocity_gain > 0 [1/s]: P controller on the coarse cells' mean velocity;
                                   //   velocity_gain x interval <= 0.5
  double velocity_ki = 25000.0;    // velocity_ki >= 0 [1/s2]: its integral gain, <= velocity_gain^2 / 4;
                                   //   default velocity_gain^2 / 10 (25000 at the default gain)
  double acceleration_limit = 0.0; // acceleration_limit [m/s2] >= 0; 0 = automatic (5 |g|)
  double velocity_only_below = -std::numeric_limits<double>::infinity();
                                   // velocity_only_below [m]: cells below this height use pure velocity coupling
  int radius_bins = 8;             // radius_bins >= 1: size-histogram bins of the crossing coarse particles
  bool open_bottom = false;        // open_bottom: the box's bottom is a boundary face where the vessel goes on below
  SourceLoc loc;
  std::map<std::string, SourceLoc> key_locs;  // where each key is written, so checks made after parsing can name it
  SourceLoc loc_of(const std::string& key) const {
    const auto it = key_locs.find(key);
    return it == key_locs.end() ? loc : it->second;
  }
  bool operator==(const CouplingRegionSpec&) const = default;
};

struct CouplingSpec {              // [coupling]
  double interval = 0.0;           // interval [s] > 0: coupling interval, every level's dt divides it;
                                   //   0 = automatic (the smallest multiple of every dt >= 15 finest steps)
  std::string endpoint;            // endpoint: ZeroMQ endpoint of the coupler; "" = ipc:// in the run folder
  double heartbeat = 1.0;          // heartbeat [wall s] > 0
  double timeout = 60.0;           // timeout [wall s] > heartbeat: a level silent this long stops the run
  double checkpoint_every = 0.0;   // checkpoint_every [s] >= 0: simulated time between consistent checkpoints
                                   //   of the hierarchy; 0 = automatic (0.02 s)
  double lead = 0.5;               // lead in [0, 0.5]: each level sends its statistics floor(lead x its steps per
                                   //   interval) steps before the interval ends and counts those steps into the
                                   //   next interval's, so that the coupler's answer overlaps them
  int samples = 2;                 // samples in [1, 64]: cell samples per interval, evenly over the steps up to
                                   //   the statistics (the last of them always samples); each is a stress step
  int retry_full_every = 1;        // retry_full_every in [1, 64]: a boundary face whose insertion slab was full
                                   //   tries again at intervals that are multiples of it; above 1 the fine level
                                   //   reports only the slabs of the faces that may try
  std::vector<CouplingRegionSpec> regions;
  SourceLoc loc;
  bool operator==(const CouplingSpec&) const = default;
};

struct OrificeSpec {               // [orifice] or one [[orifices]] entry: an outlet the walls cannot say
                                   //   (a slot under a round lid), for the region rules, `mlcg check` and
                                   //   `mlcg plan`; the solver does not use it. Given, they replace the
                                   //   outlets found in the geometry (scene/outlets.hpp).
  std::string name;                // name: unique; default "orifice" ([orifice]) or "orifice<i>" ([[orifices]])
  Vec3 center;                     // center [m]
  Vec3 normal{0, 0, -1};           // normal: the direction the flow leaves through it (normalised)
  double diameter = 0.0;           // diameter > 0: a circular orifice; or
  double width = 0.0;              // width, length > 0: a slot (the rules use its width)
  double length = 0.0;
  SourceLoc loc;
  double size() const { return diameter > 0.0 ? diameter : width; }  // the constraining opening [m]
  bool operator==(const OrificeSpec&) const = default;
};

struct SwapSpec {                  // [[swap]]: replace a level's binary during a multi-level run
  std::string level;               // level = "name": a [[levels]] entry
  double at = 0.0;                 // at [s] >= 0: simulated time; the swap happens at the next consistent checkpoint
  std::string binary;              // binary: path of the new solver (relative to the case's folder)
  SourceLoc loc;
  bool operator==(const SwapSpec&) const = default;
};

struct LauncherSpec {              // [launcher]: how `mlcg run` supervises a hierarchy
  int restart_on_failure = 0;      // restart_on_failure >= 0: restarts from the last consistent checkpoint
                                   //   after a process of the hierarchy died; 0 = stop every process
  SourceLoc loc;
  bool operator==(const LauncherSpec&) const = default;
};

struct LimitsSpec {               // [limits]: what a case may ask of the machine, estimated before step 1
  int64_t max_steps = 1'000'000'000;     // max_steps >= 1: time steps of any level to reach the end
  int64_t max_output_files = 20'000;     // max_output_files >= 1: snapshots, grid frames and checkpoints written
  double max_memory_gb = 16.0;           // max_memory_gb > 0: particles, cells, samples and series rows held
  SourceLoc loc;
  bool operator==(const LimitsSpec&) const = default;
};

struct CaseSpec {
  std::string path;                // the case file as given
  std::string dir;                 // its folder (relative files resolve here)
  std::vector<std::string> bases;  // base: the files this case varies, nearest first (resolved paths)
  std::string title;               // title
  uint64_t seed = 1;               // seed
  Vec3 gravity{0.0, 0.0, -9.81};   // gravity
  std::vector<MaterialSpec> materials;
  std::vector<InteractionSpec> interactions;
  ContactSpec contact;
  std::vector<LevelSpec> levels;
  DomainSpec domain;
  std::vector<WallSpec> walls;
  std::vector<InsertionSpec> insertions;
  std::vector<ParticleSpec> particles;
  std::optional<InitialSpec> initial;
  std::vector<EventSpec> events;
  std::vector<ProbeSpec> probes;
  std::vector<GridSpec> grids;
  OutputSpec output;
  StabilitySpec stability;
  TimeSpec time;
  std::vector<OrificeSpec> orifices;     // [orifice] (one entry) or [[orifices]]
  std::optional<CouplingSpec> coupling;  // [coupling]: only in multi-level cases
  LauncherSpec launcher;                 // [launcher]: only in multi-level cases
  std::vector<SwapSpec> swaps;           // [[swap]]: only in multi-level cases
  LimitsSpec limits;                     // [limits]
  bool operator==(const CaseSpec&) const = default;
};

}  // namespace mlcg::config
