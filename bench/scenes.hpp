#pragma once
// The benchmark scenes, written once for MLCG (case TOML) and once for LIGGGHTS (data file + input
// script) from the same numbers.
#include <array>
#include <cstdint>
#include <filesystem>
#include <string>

#include "geometry.hpp"
#include "snapshot.hpp"

namespace mlcg::bench {

// The paper's material (Queteschiner et al. 2017, Table 1), as cases/silo_small/reference.toml.
struct Material {
  double youngs_modulus = 2.5e7;  // particles and walls [Pa]
  double poisson_ratio = 0.25;
  double density = 1000.0;        // particles [kg/m^3]
  double restitution = 0.5;       // particle-particle and particle-wall
  double friction_pp = 0.2;
  double friction_pw = 0.175;
};

struct BenchParams {
  SiloGeometry geometry;
  Material material;
  int particles = 29451;
  double radius = 1.4e-3;          // [m]
  double dt = 1e-6;                // measured runs [s]
  double skin = 0.7e-3;            // neighbour skin of both codes [m] (0.5 radius)
  long steps = 5000;
  // Preparation of the settled bed (our solver; cached).
  double prepare_dt = 9e-6;        // < 20 % of the Rayleigh time (9.6e-6 s)
  double settle_speed = 0.005;     // mass-weighted mean speed [m/s] that counts as settled
  double settle_extra = 0.02;      // simulated seconds after that
  double settle_latest = 2.0;      // give up waiting at this time (with a warning)
  std::int64_t seed = 2017;
  // The measured pour: the empty silo filled at the silo_small reference's rate (and the bed
  // preparation's), whose neighbour rebuilds (27 % of its filling time) the scene is there to measure,
  // for pour_time at dt: 10,000 particles in 50,000 steps, about 12 s on one core.
  double pour_rate = 200000.0;     // [particles/s]
  double pour_time = 0.05;         // [s]
  // Batches of 200 instead of the automatic 10 ms (2000): the first automatic batch asks for more than
  // the bottom of the cone holds, and each particle that finds no place costs 200 candidates tested
  // against the STL mesh (27 s of a 40 s run before a1df6ac made those tests cheap), time spent once at
  // the start instead of in the filling.
  double pour_interval = 0.001;    // [s]
};

enum class Scene { Bed, Discharge };
const char* scene_name(Scene s);
const char* scene_title(Scene s);

struct Files {
  std::filesystem::path silo_stl, lid_stl;
};

// A path as a TOML basic string (backslashes and quotes escaped).
std::string toml_quoted(const std::filesystem::path& p);
// The materials ("particle", walls "steel"), their interactions, the contact model and the domain.
std::string materials_and_domain(const BenchParams& p, const std::array<double, 3>& lo,
                                 const std::array<double, 3>& hi);
// One [[levels]] entry.
std::string level_block(const char* name, double dt, int ranks, double skin);
// Pouring `count` particles at `rate` [1/s] in batches every `interval` [s] (0 = automatic) close above
// the heap into `region` (a TOML inline table).
std::string pour_into(const BenchParams& p, const std::string& region, long count, double rate, double interval);
// pour_into and the end: an event "settled" when the mean speed is below p.settle_speed (latest
// p.settle_latest), + p.settle_extra.
std::string pour_and_settle(const BenchParams& p, const std::string& region, long count);
// A measured run's end: at `end`, with only the final output.
std::string fixed_end(double end);
// A measured run's start and end: the particles of bed_h5 at rest, then fixed_end(end).
std::string start_from_bed(const std::filesystem::path& bed_h5, double end);
// Fill the silo (lid closed) by pouring close above the heap and settle it, at prepare_dt.
std::string prepare_case(const BenchParams& p, const Files& f);
// A measured MLCG scene: the bed snapshot, the silo mesh (+ lid for Scene::Bed), dt, skin, steps,
// no probes or grids, minimal output.
std::string mlcg_case(const BenchParams& p, const Files& f, Scene s, int ranks, const std::filesystem::path& bed_h5);
// The measured pour (MLCG only): the empty silo, lid closed, filled as prepare_case fills it but at dt,
// for p.pour_time.
std::string pour_case(const BenchParams& p, const Files& f, int ranks);
// LIGGGHTS: the same particles (ids 1..n in snapshot order, velocities and spins included).
void write_liggghts_data(const std::filesystem::path& file, const BenchParams& p, const Snapshot& bed);
std::string liggghts_input(const BenchParams& p, const Files& f, Scene s, int ranks,
                           const std::filesystem::path& data_file);

}  // namespace mlcg::bench
