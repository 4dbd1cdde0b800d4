#pragma once
// Small sphere helpers shared by the level, the insertion and the coupler.
//
// sphere_mass is the one formula for a particle's mass: the level stores it,
// the coupler books inserted mass with it, so both sides agree to the bit.
// SphereHash is a uniform hash grid over spheres for overlap tests (SSI
// insertion, the coupler's insertion planner, measuring insertion overlaps).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <unordered_map>
#include <vector>

#include "core/vec3.hpp"

namespace mlcg {

// A sphere: a particle's centre and radius (what overlap tests need of it).
struct Sphere {
  Vec3 x;
  double r;
};

inline double sphere_volume(double r) { return 4.0 / 3.0 * std::numbers::pi * r * r * r; }
inline double sphere_mass(double density, double r) { return density * sphere_volume(r); }

class SphereHash {
 public:
  // cell: edge of the hash cells, best about the largest diameter stored.
  explicit SphereHash(double cell) : inv_(1.0 / cell) {}
  // Moves keep the cells (and so filled_'s pointers); a copy would not.
  SphereHash(SphereHash&&) = default;
  SphereHash& operator=(SphereHash&&) = default;
  SphereHash(const SphereHash&) = delete;
  SphereHash& operator=(const SphereHash&) = delete;

  // Stores a sphere; its index is the number stored before it.
  void add(const Vec3& x, double r) {
    auto& bucket = map_[key(cell(x.x), cell(x.y), cell(x.z))];
    if (bucket.empty()) filled_.push_back(&bucket);  // a map's elements stay put when it grows
    bucket.push_back(spheres_.size());
    spheres_.push_back({x, r});
    r_max_ = std::max(r_max_, r);
  }
  void add(const Sphere& s) { add(s.x, s.r); }
  size_t size() const { return spheres_.size(); }
  // Forgets every sphere but keeps the cells' storage, so refilling a hash over the
  // same region (the coupler plans an insertion every interval) allocates nothing. Only
  // the cells filled since the last clear are visited, not every cell ever used (walking
  // those was 44 % of the planner's time).
  void clear() {
    for (auto* bucket : filled_) bucket->clear();
    filled_.clear();
    spheres_.clear();
    r_max_ = 0.0;
  }

  // Calls f(index, x_k, r_k) for the stored spheres that may overlap the sphere
  // (x, r), i.e. those in the cells within r + the largest stored radius, until
  // f returns true; returns whether it did.
  template <class F>
  bool find_near(const Vec3& x, double r, F&& f) const {
    const int64_t n = static_cast<int64_t>(std::ceil((r + r_max_) * inv_));
    const int64_t ix = cell(x.x), iy = cell(x.y), iz = cell(x.z);
    for (int64_t dz = -n; dz <= n; ++dz)
      for (int64_t dy = -n; dy <= n; ++dy)
        for (int64_t dx = -n; dx <= n; ++dx) {
          const auto it = map_.find(key(ix + dx, iy + dy, iz + dz));
          if (it == map_.end()) continue;
          for (size_t k : it->second)
            if (f(k, spheres_[k].x, spheres_[k].r)) return true;
        }
    return false;
  }

  // True if a stored sphere overlaps (x, r).
  bool overlaps(const Vec3& x, double r) const {
    return find_near(x, r, [&](size_t, const Vec3& y, double ry) { return norm2(x - y) < (r + ry) * (r + ry); });
  }

 private:
  // Saturates far outside +-2^52 cells (and NaN, at the low end): a position far off, or a cell tiny against
  // it, must not overflow the conversion; such spheres only share a cell.
  int64_t cell(double c) const {
    constexpr double kMax = 4503599627370496.0;  // 2^52
    const double q = std::floor(c * inv_);
    return q >= -kMax && q <= kMax ? static_cast<int64_t>(q) : q > 0.0 ? int64_t{1} << 52 : -(int64_t{1} << 52);
  }
  static int64_t key(int64_t a, int64_t b, int64_t c) {
    return ((a & 0x1FFFFF) << 42) | ((b & 0x1FFFFF) << 21) | (c & 0x1FFFFF);
  }
  double inv_;
  double r_max_ = 0.0;
  std::vector<Sphere> spheres_;
  std::unordered_map<int64_t, std::vector<size_t>> map_;
  std::vector<std::vector<size_t>*> filled_;  // the cells holding a sphere
};

}  // namespace mlcg
