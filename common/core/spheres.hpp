#pragma once
// Small sphere helpers shared by the level, the insertion and the coupler.
//
// sphere_mass is the one formula for a particle's mass: the level stores it,
// the coupler books inserted mass with it, so both sides agree to the bit.
// SphereHash is a uniform hash grid over spheres for overlap tests (SSI
// insertion, the coupler's insertion planner, measuring insertion overlaps).
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <vector>

#include "core/vec3.hpp"

namespace mlcg {

// A sphere: a particle's centre and radius (what overlap tests need of it).
struct Sphere {
  Vec3 x;
  double r;
};

inline constexpr double kSphereVolumeFactor = 4.0 / 3.0 * std::numbers::pi;  // V = kSphereVolumeFactor r^3
inline double sphere_volume(double r) { return kSphereVolumeFactor * r * r * r; }
inline double sphere_mass(double density, double r) { return density * sphere_volume(r); }

class SphereHash {
 public:
  // cell: edge of the hash cells, best about the largest diameter stored.
  explicit SphereHash(double cell) : inv_(1.0 / cell) {}

  // Stores a sphere; its index is the number stored before it.
  void add(const Vec3& x, double r) {
    if (2 * (used_.size() + 1) > slots_.size()) grow();
    const auto idx = static_cast<uint32_t>(spheres_.size());
    const int64_t k = key(cell(x.x), cell(x.y), cell(x.z));
    Slot& s = slots_[probe(k)];
    if (s.head == kNone) {
      s = {k, idx, idx};
      used_.push_back(static_cast<uint32_t>(&s - slots_.data()));
    } else {
      next_[s.tail] = idx;  // appended: a cell's spheres are visited in the order they were stored
      s.tail = idx;
    }
    next_.push_back(kNone);
    spheres_.push_back({x, r});
    r_max_ = std::max(r_max_, r);
  }
  void add(const Sphere& s) { add(s.x, s.r); }
  size_t size() const { return spheres_.size(); }
  // Forgets every sphere but keeps the table, so refilling a hash over the same region
  // (the coupler plans an insertion every interval) allocates nothing. Only the cells
  // filled since the last clear are visited.
  void clear() {
    for (uint32_t h : used_) slots_[h].head = kNone;
    used_.clear();
    next_.clear();
    spheres_.clear();
    r_max_ = 0.0;
  }

  // Calls f(index, x_k, r_k) for the stored spheres that may overlap the sphere
  // (x, r), i.e. those in the cells within r + the largest stored radius, until
  // f returns true; returns whether it did. Cells are visited z-, then y-, then
  // x-major, a cell's spheres in the order they were stored.
  template <class F>
  bool find_near(const Vec3& x, double r, F&& f) const {
    if (used_.empty()) return false;
    const int64_t n = static_cast<int64_t>(std::ceil((r + r_max_) * inv_));
    const int64_t ix = cell(x.x), iy = cell(x.y), iz = cell(x.z);
    for (int64_t dz = -n; dz <= n; ++dz)
      for (int64_t dy = -n; dy <= n; ++dy)
        for (int64_t dx = -n; dx <= n; ++dx) {
          const Slot& s = slots_[probe(key(ix + dx, iy + dy, iz + dz))];
          for (uint32_t k = s.head; k != kNone; k = next_[k])
            if (f(size_t{k}, spheres_[k].x, spheres_[k].r)) return true;
        }
    return false;
  }

  // True if a stored sphere overlaps (x, r). The answer does not depend on the order the cells are
  // visited in, so x's own cell goes first: in a crowded slab it usually holds the sphere that rejects a
  // candidate, and the other 26 look-ups are skipped (the coupler's planner tests many such candidates).
  bool overlaps(const Vec3& x, double r) const {
    if (used_.empty()) return false;
    const auto hit = [&](const Slot& s) {
      for (uint32_t k = s.head; k != kNone; k = next_[k]) {
        const double d = r + spheres_[k].r;
        if (norm2(x - spheres_[k].x) < d * d) return true;
      }
      return false;
    };
    const int64_t n = static_cast<int64_t>(std::ceil((r + r_max_) * inv_));
    const int64_t ix = cell(x.x), iy = cell(x.y), iz = cell(x.z);
    if (hit(slots_[probe(key(ix, iy, iz))])) return true;
    for (int64_t dz = -n; dz <= n; ++dz)
      for (int64_t dy = -n; dy <= n; ++dy)
        for (int64_t dx = -n; dx <= n; ++dx)
          if ((dx != 0 || dy != 0 || dz != 0) && hit(slots_[probe(key(ix + dx, iy + dy, iz + dz))])) return true;
    return false;
  }

 private:
  // An open-addressing table of the filled cells (linear probing, at most half full): a cell's
  // spheres form a list through next_. An unordered_map of vectors cost the coupler's planner
  // most of its time in the 27 look-ups per overlap test.
  static constexpr uint32_t kNone = 0xFFFFFFFFu;
  struct Slot {
    int64_t key = 0;
    uint32_t head = kNone, tail = kNone;
  };
  size_t probe(int64_t k) const {  // the slot holding k, or the empty one where it would go
    const size_t mask = slots_.size() - 1;
    size_t h = static_cast<size_t>((static_cast<uint64_t>(k) * 0x9E3779B97F4A7C15ULL) >> shift_) & mask;
    while (slots_[h].head != kNone && slots_[h].key != k) h = (h + 1) & mask;
    return h;
  }
  void grow() {
    std::vector<Slot> old = std::move(slots_);
    const size_t size = old.empty() ? 64 : 2 * old.size();
    slots_.assign(size, Slot{});
    shift_ = 64 - std::countr_zero(size);
    for (uint32_t& h : used_) {
      const Slot s = old[h];
      h = static_cast<uint32_t>(probe(s.key));
      slots_[h] = s;
    }
  }
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
  int shift_ = 64;
  std::vector<Sphere> spheres_;
  std::vector<Slot> slots_;
  std::vector<uint32_t> next_;  // per sphere: the next one in its cell
  std::vector<uint32_t> used_;  // the slots holding a cell
};

}  // namespace mlcg
