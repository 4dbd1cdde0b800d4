#pragma once
// Where each level of a hierarchy resolves the scene: a fine level's particles live in its coupling
// region's box (min rounded outward to whole cells, as the coupler builds it) and are removed when they
// leave it, so a measurement there is the fine level's only inside that box. A level holds a point
// when one of the regions it is the fine side of contains the point and that region's coarse level
// holds it too; a level that is no region's fine side (the coarsest) holds every point.
#include <string>

#include "config/case_spec.hpp"

namespace mlcg::config {

struct RegionBox {
  Vec3 lo, hi;
  bool contains(const Vec3& p) const;
  double distance(const Vec3& p) const;  // 0 inside
  RegionBox grown_to(const Vec3& p) const;  // the smallest box holding this one and p
};

RegionBox region_box(const CouplingRegionSpec& r);

// Index into cs.levels of the finest level (smallest alpha) that holds p; the first level of a
// single-level case.
size_t resolving_level(const CaseSpec& cs, const Vec3& p);

}  // namespace mlcg::config
