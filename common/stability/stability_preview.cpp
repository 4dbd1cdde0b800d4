#include "stability/stability_preview.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "scene/walls_from_case.hpp"
#include "stability/initial_state.hpp"

namespace mlcg {

ParticleKind insertion_kind(const config::InsertionSpec& in, double alpha, const MaterialTable& mt) {
  ParticleKind k;
  k.material = mt.index_of(in.material);
  k.r_min = in.radius.smallest() * alpha;
  k.r_max = in.radius.largest() * alpha;
  k.speed = norm(in.velocity);
  return k;
}

ParticleKind initial_kind(const std::vector<ParticleInit>& list, int material) {
  ParticleKind kind{material, std::numeric_limits<double>::max(), 0.0, 0.0};
  for (const ParticleInit& pi : list) {
    kind.r_min = std::min(kind.r_min, pi.radius);
    kind.r_max = std::max(kind.r_max, pi.radius);
    kind.speed = std::max(kind.speed, norm(pi.v));
  }
  return kind;
}

double guard_height(const config::CaseSpec& cs) {
  const double g = norm(cs.gravity);
  const Vec3 gdir = g > 0.0 ? cs.gravity / g : Vec3{0, 0, -1};
  return std::fabs(dot(cs.domain.max - cs.domain.min, gdir));
}

LevelPreview preview_level(const config::CaseSpec& cs, const config::LevelSpec& lvl) {
  LevelPreview out;
  const MaterialTable mt = materials_of_case(cs);
  // As Level::setup: in a hierarchy the case's particles fill the coarsest level only, but every
  // level's guard counts their kinds.
  for (const auto& l : cs.levels) out.fills_scene = out.fills_scene && (!cs.coupling || l.alpha <= lvl.alpha);
  std::vector<ParticleKind> kinds, explicit_kinds;
  std::vector<PlacedParticle> placed;
  for (const auto& in : cs.insertions) kinds.push_back(insertion_kind(in, lvl.alpha, mt));
  int64_t id = 0;
  for (const auto& ps : cs.particles) {
    const int mat = mt.index_of(ps.material);
    const double r = ps.radius * lvl.alpha;
    explicit_kinds.push_back({mat, r, r, norm(ps.velocity)});
    placed.push_back({{ps.position, r}, mat, id++});
  }
  if (cs.initial) {
    const int mat = mt.index_of(cs.initial->material);
    const auto list = read_initial_particles(*cs.initial, cs.domain, mat, mt.material(mat).density);
    for (const ParticleInit& pi : list) placed.push_back({{pi.x, pi.radius}, mat, pi.id});
    if (!list.empty()) explicit_kinds.push_back(initial_kind(list, mat));
  }
  for (const auto& k : merge_kinds(explicit_kinds)) kinds.push_back(k);
  for (const auto& k : kinds) {
    out.r_min = out.r_min > 0.0 ? std::min(out.r_min, k.r_min) : k.r_min;
    out.r_max = std::max(out.r_max, k.r_max);
  }
  const WallSet walls = walls_from_case(cs, mt);
  std::vector<int> wall_mats;
  for (size_t w = 0; w < walls.walls(); ++w) wall_mats.push_back(walls.info(w).material);
  out.stability = check_stability(cs, lvl, mt, kinds, wall_mats, guard_height(cs), initial_overlaps(placed, mt));
  if (out.fills_scene) out.placed = static_cast<int64_t>(placed.size());
  return out;
}

}  // namespace mlcg
