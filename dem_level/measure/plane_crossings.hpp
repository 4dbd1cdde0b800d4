#pragma once
// Crossings of a plane by particle centres, shared by the mass-flow probes and
// the coupling's boundary faces.
//
// Only particles near the plane can cross it before the next neighbour-list
// rebuild (no particle moves more than skin/2 between rebuilds), so refresh()
// keeps a short candidate list (indices of local particles, valid until the
// next rebuild) with each one's side and position, and check() looks at those
// only. A centre moving from s <= 0 to s > 0 (s = signed distance along the
// normal) crosses forward, from s > 0 to s <= 0 backward.
#include <cstdint>
#include <vector>

#include "core/particles.hpp"

namespace mlcg {

class PlaneCrossings {
 public:
  PlaneCrossings() = default;
  PlaneCrossings(const Vec3& point, const Vec3& unit_normal) : point_(point), normal_(unit_normal) {}

  double distance(const Vec3& x) const { return dot(x - point_, normal_); }
  const Vec3& point() const { return point_; }
  const Vec3& normal() const { return normal_; }

  // After a rebuild: candidates are the local particles within `band` of the
  // plane for which keep(x, s) holds (s = signed distance of x). from > 0: only
  // particles [from, n_local) are new since the last refresh (appended without a
  // rebuild), the others' candidacy stands.
  template <class Keep>
  void refresh(const Particles& p, double band, Keep keep, size_t from = 0) {
    if (from == 0) {
      cand_.clear();
      side_.clear();
      prev_.clear();
    }
    for (size_t i = from; i < p.n_local(); ++i) {
      const double s = distance(p.x[i]);
      if (s > band || s < -band) continue;
      if (!keep(p.x[i], s)) continue;
      cand_.push_back(static_cast<int32_t>(i));
      side_.push_back(s);
      prev_.push_back(p.x[i]);
    }
  }

  // After positions changed: on_cross(i, forward, s_now, x_before) for every
  // candidate whose centre crossed the plane since the last call.
  template <class OnCross>
  void check(const Particles& p, OnCross on_cross) {
    for (size_t c = 0; c < cand_.size(); ++c) {
      const auto i = static_cast<size_t>(cand_[c]);
      const double s = distance(p.x[i]);
      const double before = side_[c];
      const Vec3 x_before = prev_[c];
      side_[c] = s;
      prev_[c] = p.x[i];
      const bool forward = before <= 0.0 && s > 0.0;
      const bool backward = before > 0.0 && s <= 0.0;
      if (forward || backward) on_cross(i, forward, s, x_before);
    }
  }

  // Where the centre crossed, from its position before and now (both sides of the plane).
  Vec3 crossing_point(const Vec3& x_before, const Vec3& x_now) const {
    const double sb = distance(x_before), sa = distance(x_now);
    const double t = sb / (sb - sa);  // sb and sa lie on different sides: sb != sa
    return x_before + t * (x_now - x_before);
  }

  size_t candidates() const { return cand_.size(); }

 private:
  Vec3 point_, normal_{0, 0, 1};
  std::vector<int32_t> cand_;
  std::vector<double> side_;
  std::vector<Vec3> prev_;
};

}  // namespace mlcg
