#include "insertion/inserter.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

namespace mlcg {

double Inserter::particle_mass(double r) const { return sphere_mass(prm_.density, r); }

double Inserter::draw_radius(std::mt19937_64& rng) const {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  switch (prm_.dist) {
    case InsertionParams::Dist::Constant: return prm_.r_const;
    case InsertionParams::Dist::Uniform: return prm_.r_min + (prm_.r_max - prm_.r_min) * u(rng);
    case InsertionParams::Dist::Discrete: {
      const double q = u(rng);
      for (size_t k = 0; k < prm_.values.size(); ++k)
        if (q < prm_.cumulative[k]) return prm_.values[k];
      return prm_.values.back();
    }
  }
  return prm_.r_const;
}

bool Inserter::in_footprint(const Vec3& x, double margin, const Vec3& lo, const Vec3& hi) const {
  if (prm_.cylinder) {
    const double dx = x.x - prm_.cx, dy = x.y - prm_.cy;
    const double R = prm_.cyl_radius + margin;
    return dx * dx + dy * dy <= R * R;
  }
  return x.x >= lo.x - margin && x.x <= hi.x + margin && x.y >= lo.y - margin && x.y <= hi.y + margin;
}

double Inserter::heap_top(const Particles& p, double g_mag) const {
  // Falling particles are not part of the heap: only those slower than half the pouring speed.
  const double slow = 0.5 * std::max(norm(prm_.velocity), std::sqrt(2.0 * g_mag * std::max(prm_.follow_gap, 1e-3)));
  double heap = -std::numeric_limits<double>::infinity();
  for (size_t i = 0; i < p.n_local(); ++i)
    if (in_footprint(p.x[i], 0.0, prm_.lo, prm_.hi) && norm2(p.v[i]) < slow * slow)
      heap = std::max(heap, p.x[i].z + p.radius[i]);
  return heap;
}

void Inserter::batch_region(double heap, Vec3& lo, Vec3& hi) const {
  lo = prm_.lo;
  hi = prm_.hi;
  if (!follows_heap()) return;
  // The region is the envelope; each batch uses a slab of it just above the heap.
  lo.z = std::isfinite(heap) ? std::max(prm_.lo.z, heap + prm_.follow_gap) : prm_.lo.z;
  hi.z = std::min(prm_.hi.z, lo.z + prm_.follow_height);
  lo.z = std::min(lo.z, std::max(prm_.lo.z, hi.z - prm_.follow_height));
}

void Inserter::nearby(const Particles& p, const Vec3& lo, const Vec3& hi, double reach,
                      std::vector<Sphere>& out) const {
  for (size_t i = 0; i < p.n_local(); ++i) {
    const Vec3& x = p.x[i];
    if (x.z < lo.z - reach || x.z > hi.z + reach || !in_footprint(x, reach, lo, hi)) continue;
    out.push_back({x, p.radius[i]});
  }
}

std::optional<std::vector<ParticleInit>> Inserter::place_batch(const std::vector<Sphere>& obstacles, double reach,
                                                               const Vec3& lo, const Vec3& hi, const WallSet& walls,
                                                               std::mt19937_64& rng, int64_t& next_id,
                                                               const std::function<bool()>& stop,
                                                               const std::function<void(int64_t, int64_t)>& progress) {
  // How many particles this batch asks for: the rate's share up to the batch end, plus carried ones.
  int64_t due_total = prm_.target;
  if (prm_.rate > 0.0)
    due_total = std::min<int64_t>(
        prm_.target, static_cast<int64_t>(std::floor(prm_.rate * prm_.interval * static_cast<double>(st_.batch + 1))));
  const int64_t fresh = std::max<int64_t>(0, due_total - st_.requested);
  st_.requested += fresh;
  const int64_t want = st_.pending + fresh;
  ++st_.batch;

  SphereHash grid(std::max(reach, 1e-12));
  for (const auto& s : obstacles) grid.add(s);

  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<ParticleInit> placed;
  int64_t unplaced = 0;
  for (int64_t k = 0; k < want; ++k) {
    if (stop && stop()) return std::nullopt;
    if (progress && k > 0 && k % kProgressEvery == 0) progress(k, want);
    const double r = draw_radius(rng);
    bool ok = false;
    Vec3 x;
    for (int a = 0; a < prm_.max_attempts && !ok; ++a) {
      if (prm_.cylinder) {
        const double R = prm_.cyl_radius - r;
        if (R < 0.0) break;
        const double rr = R * std::sqrt(u(rng)), th = 2.0 * std::numbers::pi * u(rng);
        x = {prm_.cx + rr * std::cos(th), prm_.cy + rr * std::sin(th), lo.z + r + (hi.z - lo.z - 2 * r) * u(rng)};
      } else {
        x = {lo.x + r + (hi.x - lo.x - 2 * r) * u(rng), lo.y + r + (hi.y - lo.y - 2 * r) * u(rng),
             lo.z + r + (hi.z - lo.z - 2 * r) * u(rng)};
      }
      ok = !grid.overlaps(x, r) && !walls.touches(x, r) && !walls.crosses(x, {x.x, x.y, prm_.hi.z});
    }
    if (!ok) {
      ++unplaced;
      continue;
    }
    grid.add(x, r);
    ParticleInit pi;
    pi.id = next_id++;
    pi.material = prm_.material;
    pi.radius = r;
    pi.density = prm_.density;
    pi.x = x;
    pi.v = prm_.velocity;
    placed.push_back(pi);
    st_.placed_mass += particle_mass(r);
  }
  st_.placed += static_cast<int64_t>(placed.size());
  st_.pending = unplaced;
  st_.stalled = (placed.empty() && unplaced > 0) ? st_.stalled + 1 : 0;
  if (st_.stalled >= prm_.max_stalled_batches) finish();
  if (st_.requested >= prm_.target && st_.pending == 0) st_.done = true;
  return placed;
}

void Inserter::finish() {
  const int64_t lost = st_.pending + (prm_.target - st_.requested);
  st_.failed += lost;
  st_.requested = prm_.target;
  const double r_typ = prm_.dist == InsertionParams::Dist::Constant ? prm_.r_const : 0.5 * (prm_.r_min + prm_.r_max);
  st_.failed_mass_estimate += static_cast<double>(lost) * particle_mass(r_typ);
  st_.pending = 0;
  st_.done = true;
}

}  // namespace mlcg

namespace mlcg {
void Inserter::abandon_pending() {
  if (st_.pending == 0) return;
  const double r_typ = prm_.dist == InsertionParams::Dist::Constant ? prm_.r_const : 0.5 * (prm_.r_min + prm_.r_max);
  st_.failed += st_.pending;
  st_.failed_mass_estimate += static_cast<double>(st_.pending) * particle_mass(r_typ);
  st_.pending = 0;
}
}  // namespace mlcg
