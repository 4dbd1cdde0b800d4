#pragma once
// The time-step guard of one level from the case alone, without building the level: what `mlcg check`
// prints and refuses. It hands check_stability (stability.hpp) the inputs Level::setup hands it: the
// insertions' kinds (insertion_kind, shared with the level), the placed particles ([[particles]],
// [initial]), the walls' materials and the fall height (guard_height, shared).
#include <cstdint>
#include <vector>

#include "config/case_spec.hpp"
#include "core/material.hpp"
#include "core/particles.hpp"
#include "scene/materials_from_case.hpp"
#include "stability/stability.hpp"

namespace mlcg {

// The particles an insertion makes at coarse-grain ratio `alpha`: material, extreme radii, speed.
ParticleKind insertion_kind(const config::InsertionSpec& in, double alpha, const MaterialTable& mt);

// The particles of an [initial] file as one kind of `material`: extreme radii, fastest speed.
ParticleKind initial_kind(const std::vector<ParticleInit>& list, int material);

// The height over which a particle can fall before an impact: the domain along gravity.
double guard_height(const config::CaseSpec& cs);

struct LevelPreview {
  StabilityReport stability;
  int64_t placed = 0;     // particles the case places on this level ([[particles]], [initial]); 0 on a fine level
  bool fills_scene = true;  // the level takes the case's particles (a single level, or a hierarchy's coarsest)
  double r_min = 0.0, r_max = 0.0;  // smallest and largest particle radius of the level [m]; 0 without particles
};

// Throws StabilityError with the level's own message when the guard refuses dt, std::runtime_error
// when [initial] file cannot be read (the level's message too).
LevelPreview preview_level(const config::CaseSpec& cs, const config::LevelSpec& lvl);

}  // namespace mlcg
