#include "config/regions.hpp"

#include <algorithm>
#include <cmath>

namespace mlcg::config {
namespace {

bool holds(const CaseSpec& cs, const std::string& level, const Vec3& p, int depth) {
  if (!cs.coupling || depth > static_cast<int>(cs.levels.size())) return true;
  bool fine_side = false;
  for (const auto& r : cs.coupling->regions) {
    if (r.fine != level) continue;
    fine_side = true;
    if (region_box(r).contains(p) && holds(cs, r.coarse, p, depth + 1)) return true;
  }
  return !fine_side;
}

}  // namespace

bool RegionBox::contains(const Vec3& p) const {
  return p.x >= lo.x && p.x <= hi.x && p.y >= lo.y && p.y <= hi.y && p.z >= lo.z && p.z <= hi.z;
}

double RegionBox::distance(const Vec3& p) const {
  double d2 = 0.0;
  for (int a = 0; a < 3; ++a) {
    const double out = std::max({lo[a] - p[a], 0.0, p[a] - hi[a]});
    d2 += out * out;
  }
  return std::sqrt(d2);
}

RegionBox RegionBox::grown_to(const Vec3& p) const {
  RegionBox b = *this;
  for (int a = 0; a < 3; ++a) {
    b.lo[a] = std::min(b.lo[a], p[a]);
    b.hi[a] = std::max(b.hi[a], p[a]);
  }
  return b;
}

RegionBox region_box(const CouplingRegionSpec& r) {
  RegionBox b{r.min, r.min};
  for (int a = 0; a < 3; ++a) {
    const double n = std::max(1.0, std::ceil((r.max[a] - r.min[a]) / r.cell_size - 1e-9));
    b.hi[a] = r.min[a] + n * r.cell_size;
  }
  return b;
}

size_t resolving_level(const CaseSpec& cs, const Vec3& p) {
  size_t best = 0;
  bool found = false;
  for (size_t l = 0; l < cs.levels.size(); ++l)
    if (holds(cs, cs.levels[l].name, p, 0) && (!found || cs.levels[l].alpha < cs.levels[best].alpha)) {
      best = l;
      found = true;
    }
  return best;
}

}  // namespace mlcg::config
