#pragma once
// The time-step guard (DESIGN.md §2): before step 1 a level computes the
// Rayleigh time of its smallest particle and the Hertz contact time and
// largest overlap at the case's largest expected impact speed, prints them,
// and refuses a dt that does not resolve them unless the case overrides the
// guard, saying why. Particles placed overlapping count: the energy stored in
// their overlaps sets the impact speed when it can throw them faster.
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "config/case_spec.hpp"
#include "core/material.hpp"
#include "core/spheres.hpp"

namespace mlcg {

struct StabilityError : std::runtime_error { using std::runtime_error::runtime_error; };

// A kind of particle the level will hold: material and its smallest and largest radius.
struct ParticleKind {
  int material = 0;
  double r_min = 0.0, r_max = 0.0;
  double speed = 0.0;  // its initial speed
};

// One kind per material: its smallest and largest radius and fastest speed. The guard's estimates
// are extreme at the extreme radii, so this is all it needs of 690,000 placed particles.
std::vector<ParticleKind> merge_kinds(const std::vector<ParticleKind>& kinds);

// A particle the case places before step 1 ([[particles]], [initial]).
struct PlacedParticle {
  Sphere s;
  int material = 0;
  int64_t id = 0;
};

// The largest overlap among the placed particles (share of the smaller radius) and
// the speed the Hertz energy stored in one particle's overlaps would give it alone.
struct InitialOverlap {
  double ratio = 0.0, speed = 0.0;
  int64_t a = -1, b = -1;  // ids of the most overlapping pair
};
InitialOverlap initial_overlaps(const std::vector<PlacedParticle>& placed, const MaterialTable& mt);

struct StabilityReport {
  double rayleigh_time = 0.0;      // of the smallest particle
  double rayleigh_radius = 0.0;
  double impact_speed = 0.0;       // used for the Hertz estimates
  bool impact_speed_estimated = false;
  bool impact_speed_from_overlaps = false;  // the initial overlaps can throw particles faster
  std::string impact_wall;         // the moving wall whose surface speed the estimate includes, if any
  double contact_time = 0.0;       // shortest Hertz contact at impact_speed
  double steps_per_contact = 0.0;
  double overlap_ratio = 0.0;      // largest Hertz overlap / radius at impact_speed
  bool overridden = false;
  std::vector<std::string> lines;  // for the log
};

// Throws StabilityError naming the case file, line and key when dt is refused.
StabilityReport check_stability(const config::CaseSpec& cs, const config::LevelSpec& lvl, const MaterialTable& mt,
                                const std::vector<ParticleKind>& kinds, const std::vector<int>& wall_materials,
                                double gravity_height, const InitialOverlap& overlaps = {});

}  // namespace mlcg
