#pragma once
// Chooses, once per run, the compiled force routine for the case's contact
// model (normal x tangential x rolling sub-models) and whether this step
// accumulates stress for measurements.
#include <vector>

#include "contact/model.hpp"
#include "core/material.hpp"
#include "core/particles.hpp"
#include "forces/contact_stats.hpp"
#include "neighbor/neighbor_list.hpp"
#include "walls/wall_set.hpp"

namespace mlcg {

struct ForceContext {
  Particles& p;
  NeighborList& nl;
  WallSet& walls;
  const MaterialTable& mt;
  double dt;
  std::vector<double>& stress6;     // 6 per particle; filled only on stress steps
  std::vector<Vec3>& wall_force;    // per wall
  ContactStats stats;
};

using ForceRoutine = void (*)(ForceContext&, bool with_stress);

ForceRoutine select_force_routine(const ContactChoice& choice);
bool model_keeps_history(const ContactChoice& choice);

}  // namespace mlcg
