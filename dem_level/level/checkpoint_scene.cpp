// The scene a level checkpoint was written for, and the differences that make
// another case unable to continue from it (see checkpoint_scene.hpp).
#include "level/checkpoint_scene.hpp"

#include <algorithm>
#include <map>

#include <fmt/format.h>

namespace mlcg {

namespace {

using nlohmann::json;

json vec(const Vec3& v) { return json::array({v.x, v.y, v.z}); }

// A value as a person reads it: 1000, 'glass', [0, 0, -9.81].
std::string show(const json& v) {
  if (v.is_number()) return fmt::format("{:.12g}", v.get<double>());
  if (v.is_string()) {  // appended: "'" + std::string&& trips a GCC 12 -Wrestrict false positive
    std::string s = "'";
    return s.append(v.get<std::string>()).append("'");
  }
  if (v.is_boolean()) return v.get<bool>() ? "true" : "false";
  if (v.is_array()) {
    std::string s = "[";
    for (size_t i = 0; i < v.size(); ++i) s.append(i ? ", " : "").append(show(v[i]));
    return s.append("]");
  }
  return v.dump();
}

// Entries of one kind, each an object with a "name", by name.
std::map<std::string, json> by_name(const json& list) {
  std::map<std::string, json> out;
  if (list.is_array())
    for (const auto& e : list) out[e.value("name", "")] = e;
  return out;
}

// Compares the entries of `kind` (e.g. "material") by name and by each property. An entry only in
// the case or only in the checkpoint is a difference unless `may_come_and_go`.
void compare_named(const json& saved, const json& now, const std::string& key, const std::string& kind,
                   bool may_come_and_go, std::vector<std::string>& out) {
  const auto a = by_name(saved.value(key, json::array())), b = by_name(now.value(key, json::array()));
  for (const auto& [name, was] : a) {
    const auto it = b.find(name);
    if (it == b.end()) {
      if (!may_come_and_go) out.push_back(fmt::format("{} '{}' is in the checkpoint but not in the case", kind, name));
      continue;
    }
    for (const auto& [prop, value] : was.items())
      if (prop != "name" && it->second.contains(prop) && it->second[prop] != value)
        out.push_back(fmt::format("{} '{}' {} {} in the checkpoint, {} in the case", kind, name, prop, show(value),
                                  show(it->second[prop])));
  }
  if (may_come_and_go) return;
  for (const auto& [name, is] : b)
    if (!a.count(name)) out.push_back(fmt::format("{} '{}' is in the case but not in the checkpoint", kind, name));
}

}  // namespace

json scene_record(const config::CaseSpec& cs, const config::LevelSpec& level, int64_t explicit_particles) {
  json r;
  r["level"] = level.name;
  r["gravity"] = vec(cs.gravity);
  r["domain"] = json::array({vec(cs.domain.min), vec(cs.domain.max)});
  r["contact"] = cs.contact.tangential + " tangential, " + cs.contact.rolling + " rolling" +
                 (cs.contact.clamp_normal ? ", normal force clamped" : "");
  r["explicit_particles"] = explicit_particles;
  for (const auto& m : cs.materials)
    r["materials"].push_back({{"name", m.name}, {"youngs_modulus", m.youngs_modulus},
                              {"poisson_ratio", m.poisson_ratio}, {"density", m.density}});
  for (const auto& in : cs.interactions) {
    const auto pair = std::minmax(in.a, in.b);
    r["interactions"].push_back({{"name", pair.first + "' and '" + pair.second}, {"restitution", in.restitution},
                                 {"friction", in.friction}, {"rolling_friction", in.rolling_friction}});
  }
  for (const auto& w : cs.walls)
    r["walls"].push_back({{"name", w.name}, {"type", static_cast<int>(w.type)}, {"material", w.material}});
  for (const auto& in : cs.insertions)
    r["insertions"].push_back({{"name", in.name}, {"material", in.material}, {"count", in.count}, {"mass", in.mass}});
  for (const auto& p : cs.probes)
    r["probes"].push_back({{"name", p.name}, {"point", vec(p.point)}, {"normal", vec(p.normal)}, {"radius", p.radius},
                           {"sample_rate", p.sample_rate}});
  for (const auto& g : cs.grids)
    r["grids"].push_back({{"name", g.name}, {"min", vec(g.min)}, {"max", vec(g.max)}, {"cell_size", g.cell_size}});
  for (const auto& e : cs.events) r["events"].push_back({{"name", e.name}});
  return r;
}

std::vector<std::string> scene_differences(const json& saved, const json& now) {
  std::vector<std::string> out;
  for (const char* k : {"level", "gravity", "domain", "contact", "explicit_particles"})
    if (saved.contains(k) && now.contains(k) && saved[k] != now[k])
      out.push_back(fmt::format("{} {} in the checkpoint, {} in the case",
                                std::string(k) == "explicit_particles" ? "particles placed by the case" : k,
                                show(saved[k]), show(now[k])));
  compare_named(saved, now, "materials", "material", false, out);
  compare_named(saved, now, "interactions", "interaction between", false, out);
  compare_named(saved, now, "walls", "wall", false, out);
  compare_named(saved, now, "insertions", "insertion", false, out);
  // A probe, grid or event may be added (it starts afresh) or left out; one kept must be the same.
  compare_named(saved, now, "probes", "probe", true, out);
  compare_named(saved, now, "grids", "grid", true, out);
  return out;
}

std::vector<int> saved_index(const json& saved, const json& now, const std::string& kind) {
  const json& want = now.value(kind, json::array());
  std::vector<int> out;
  for (size_t i = 0; i < want.size(); ++i) {
    if (!saved.contains(kind) && !saved.contains("materials")) {  // no record: the same order
      out.push_back(static_cast<int>(i));
      continue;
    }
    const json& had = saved.value(kind, json::array());
    int at = -1;
    for (size_t j = 0; j < had.size(); ++j)
      if (had[j].value("name", "") == want[i].value("name", "")) at = static_cast<int>(j);
    out.push_back(at);
  }
  return out;
}

SceneMap scene_map(const json& saved, const json& now) {
  SceneMap m;
  m.walls = saved_index(saved, now, "walls");
  m.insertions = saved_index(saved, now, "insertions");
  m.probes = saved_index(saved, now, "probes");
  m.grids = saved_index(saved, now, "grids");
  m.events = saved_index(saved, now, "events");
  m.saved_probes = saved.contains("materials") ? saved.value("probes", json::array()).size() : m.probes.size();
  const auto materials = saved_index(saved, now, "materials");
  const size_t had = saved.contains("materials") ? saved["materials"].size() : materials.size();
  m.material_of_saved.assign(had, -1);
  for (size_t i = 0; i < materials.size(); ++i)
    if (materials[i] >= 0) m.material_of_saved[static_cast<size_t>(materials[i])] = static_cast<int>(i);
  return m;
}

}  // namespace mlcg
