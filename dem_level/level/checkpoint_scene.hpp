#pragma once
// What a level checkpoint depends on, recorded with it ("scene/record", JSON)
// and compared with the case on restart, before step 1: materials by name with
// their properties, interactions, the contact model, gravity, the domain, walls,
// insertions and the particles the case places, probes, grids and events by
// name. A checkpoint of another scene is refused with every difference named
// ("material 'particle' density 1000 in the checkpoint, 2000 in the case").
// Changes that are harmless are matched by name instead: materials in another
// order, probes, grids and events added (they start afresh) or removed.
#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "config/case_spec.hpp"

namespace mlcg {

// The record of the case as level `level` runs it; `explicit_particles` is how many
// particles the case places on this level ([[particles]] and [initial]).
nlohmann::json scene_record(const config::CaseSpec& cs, const config::LevelSpec& level, int64_t explicit_particles);

// Every difference that makes the checkpoint another scene, one phrase each; empty when it may continue.
std::vector<std::string> scene_differences(const nlohmann::json& saved, const nlohmann::json& now);

// For each entry of the case (in its order), the index of the entry of the same name in the
// checkpoint, or -1 when the checkpoint has none. `kind` is "materials", "walls", "insertions",
// "probes", "grids" or "events". A checkpoint without a record is taken to be in the case's order.
std::vector<int> saved_index(const nlohmann::json& saved, const nlohmann::json& now, const std::string& kind);

// Where each entry of the case is found in the checkpoint (saved_index of every kind), and the
// case's index of each material the checkpoint's particles refer to.
struct SceneMap {
  std::vector<int> walls, insertions, probes, grids, events;
  std::vector<int> material_of_saved;
  size_t saved_probes = 0;
};
SceneMap scene_map(const nlohmann::json& saved, const nlohmann::json& now);

}  // namespace mlcg
