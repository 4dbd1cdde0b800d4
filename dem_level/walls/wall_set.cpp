#include "walls/wall_set.hpp"

#include <stdexcept>

namespace mlcg {

int WallSet::add_analytic(const std::string& name, int material, const AnalyticWall& w) {
  if (!meshes_.empty()) throw std::logic_error("WallSet: add analytic walls before meshes");
  Info in;
  in.name = name;
  in.material = material;
  in.prim_begin = next_prim_;
  in.prim_end = ++next_prim_;
  analytic_.push_back(w);
  analytic_wall_.push_back(static_cast<int>(info_.size()));
  info_.push_back(in);
  return static_cast<int>(info_.size()) - 1;
}

int WallSet::add_mesh(const std::string& name, int material, std::shared_ptr<const TriangleMesh> mesh) {
  Info in;
  in.name = name;
  in.material = material;
  in.is_mesh = true;
  in.mesh = static_cast<int>(meshes_.size());
  in.prim_begin = next_prim_;
  next_prim_ += static_cast<int32_t>(mesh->triangles());
  in.prim_end = next_prim_;
  meshes_.push_back(std::move(mesh));
  info_.push_back(in);
  return static_cast<int>(info_.size()) - 1;
}

int WallSet::find(const std::string& name) const {
  for (size_t w = 0; w < info_.size(); ++w)
    if (info_[w].name == name) return static_cast<int>(w);
  return -1;
}

int WallSet::wall_of_prim(int32_t p) const {
  if (p < analytic_count()) return analytic_wall_[static_cast<size_t>(p)];
  for (size_t w = 0; w < info_.size(); ++w)
    if (p >= info_[w].prim_begin && p < info_[w].prim_end) return static_cast<int>(w);
  return -1;
}

void WallSet::build_candidates(const Particles& p, double skin, bool with_history) {
  const size_t n = p.n_local();
  first.assign(n + 1, 0);
  prim.clear();
  WallGeom g;
  for (size_t i = 0; i < n; ++i) {
    const double reach = p.radius[i] + skin;
    for (int32_t a = 0; a < analytic_count(); ++a) {
      if (!info_[static_cast<size_t>(analytic_wall_[static_cast<size_t>(a)])].active) continue;
      if (analytic_[static_cast<size_t>(a)].closest(p.x[i], g) && g.dist < reach) prim.push_back(a);
    }
    for (const auto& in : info_) {
      if (!in.is_mesh || !in.active) continue;
      scratch_.clear();
      meshes_[static_cast<size_t>(in.mesh)]->query(p.x[i], reach, scratch_);
      for (int32_t t : scratch_) prim.push_back(in.prim_begin + t);
    }
    first[i + 1] = static_cast<int32_t>(prim.size());
  }
  if (with_history) hist.assign(prim.size(), Vec3{});
  else hist.clear();
}

void WallSet::save_history(const Particles& p, ContactHistory& out) const {
  const size_t n = p.size();
  out.clear(n);
  if (hist.empty()) return;
  const size_t nl = first.size() - 1;
  for (size_t i = 0; i < n; ++i) {
    if (i < nl)
      for (int32_t k = first[i]; k < first[i + 1]; ++k) {
        const Vec3 h = hist[static_cast<size_t>(k)];
        if (h == Vec3{}) continue;
        out.key.push_back(history_key(prim[static_cast<size_t>(k)]));
        out.value.push_back(h);
      }
    out.first[i + 1] = static_cast<int32_t>(out.key.size());
  }
}

void WallSet::load_history(const ContactHistory& in) {
  if (hist.empty()) return;
  const size_t nl = first.size() - 1;
  for (size_t i = 0; i < nl && i < in.particles(); ++i) {
    if (in.first[i] == in.first[i + 1]) continue;
    for (int32_t k = first[i]; k < first[i + 1]; ++k)
      hist[static_cast<size_t>(k)] = in.find(i, history_key(prim[static_cast<size_t>(k)]));
  }
}

}  // namespace mlcg
