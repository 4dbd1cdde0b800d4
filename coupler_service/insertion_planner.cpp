#include "insertion_planner.hpp"

#include <algorithm>
#include <cmath>
#include <optional>
#include <random>
#include <stdexcept>

namespace mlcg::coupling {
namespace {

uint64_t mix(uint64_t x) {  // splitmix64 finaliser
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

}  // namespace

InsertionPlanner::InsertionPlanner(const bus::CouplingGeometry& geo, PlannerParams prm, FitsGeometry fits)
    : geo_(geo), prm_(std::move(prm)), fits_(std::move(fits)), faces_(geo.faces()), hash_(1.0) {
  if (prm_.radius_bins.size() < 2) throw std::invalid_argument("insertion planner: need at least one radius bin");
  if (!(prm_.ratio > 1.0)) throw std::invalid_argument("insertion planner: coarse-grain ratio must exceed 1");
  for (auto& f : faces_) f.histogram.assign(prm_.radius_bins.size() - 1, 0);
  hash_ = SphereHash(2.0 * prm_.radius_bins.back() / prm_.ratio);  // cells of the largest fine diameter
}

double InsertionPlanner::mass_of(double r) const { return sphere_mass(prm_.density, r); }

void InsertionPlanner::add_crossings(const std::vector<double>& mass, const std::vector<double>& momentum,
                                     const std::vector<double>& moment, const std::vector<int64_t>& histogram,
                                     const std::vector<double>& gross_mass, const std::vector<double>& speed_mass) {
  const size_t nf = faces_.size(), nb = prm_.radius_bins.size() - 1;
  const bool speeds = !gross_mass.empty();
  if (mass.size() != nf || momentum.size() != 3 * nf || moment.size() != 3 * nf || histogram.size() != nb * nf ||
      (speeds && (gross_mass.size() != nf || speed_mass.size() != nf)))
    throw std::invalid_argument("insertion planner: face statistics do not match the grid's " +
                                std::to_string(nf) + " faces and " + std::to_string(nb) + " radius bins");
  for (size_t f = 0; f < nf; ++f) {
    FaceState& s = faces_[f];
    s.crossed += mass[f];
    s.last_crossed = mass[f];
    s.remainder = s.crossed + s.returned - s.inserted;
    for (size_t b = 0; b < nb; ++b) s.histogram[b] += histogram[f * nb + b];
    if (mass[f] > 0.0) {
      // Favre averages of the net crossing; a net crossing is mostly one-way.
      s.velocity = Vec3{momentum[3 * f], momentum[3 * f + 1], momentum[3 * f + 2]} / mass[f];
      // One-way crossings give a mean no faster than their mean speed (to rounding): only a mix is bounded.
      const double speed = norm(s.velocity);
      const double bound = speeds && gross_mass[f] > 0.0 ? speed_mass[f] / gross_mass[f] : -1.0;
      if (bound >= 0.0 && speed > bound * (1.0 + 1e-9)) {
        s.velocity *= bound / speed;
        ++s.bounded;
      }
      const Vec3 a = Vec3{moment[3 * f], moment[3 * f + 1], moment[3 * f + 2]} / mass[f];
      if (anchored_on(f, a) && reachable(a)) {
        s.anchor = a;
        s.seen = true;
      }
    }
  }
}

bool InsertionPlanner::anchored_on(size_t f, const Vec3& a) const {
  // A top face's anchor lies in its column (a particle born below the surface counts there too); a
  // side face's within the face's rectangle, at any depth.
  if (geo_.is_top(f)) return geo_.face_column(a) == static_cast<int>(f);
  Vec3 lo, hi;
  geo_.face_slab(f, geo_.cell_size(), lo, hi);
  const double tol = 1e-9 * geo_.cell_size();
  const Vec3 n = geo_.face_inward(f);
  for (int k = 0; k < 3; ++k)
    if (n[k] == 0.0 && (a[k] < lo[k] - tol || a[k] > hi[k] + tol)) return false;
  return true;
}

bool InsertionPlanner::reachable(const Vec3& a) const {
  // The mean of a net crossing is a crossing point only when the crossing is one-way: where coarse particles
  // cross a side face both ways it can fall anywhere on the face, outside the walls too (wide_cone_junction's
  // planned region: an anchor behind the cone, and a fine particle placed outside the vessel from it). The
  // anchor must be reached from the grid's inside point without crossing a wall, as the grid's cells are.
  const auto& ip = geo_.grid().inside_point();
  return ip.size() != 3 || fits_(Vec3{ip[0], ip[1], ip[2]}, a, 0.0);
}

void InsertionPlanner::add_returned(const std::vector<double>& mass) {
  if (mass.empty()) return;
  if (mass.size() != faces_.size())
    throw std::invalid_argument("insertion planner: face_returned_mass has " + std::to_string(mass.size()) +
                                " values for " + std::to_string(faces_.size()) + " faces");
  for (size_t f = 0; f < faces_.size(); ++f) {
    if (!(mass[f] >= 0.0)) throw std::invalid_argument("insertion planner: negative returned mass");
    FaceState& s = faces_[f];
    s.returned += mass[f];
    s.last_crossed += mass[f];
    s.remainder = s.crossed + s.returned - s.inserted;
  }
}

void InsertionPlanner::unplace(const Insert& p) {
  const int f = p.face >= 0 ? p.face : geo_.face_column(p.x);
  if (f < 0) return;
  FaceState& s = faces_[static_cast<size_t>(f)];
  s.inserted -= mass_of(p.r);
  s.remainder = s.crossed + s.returned - s.inserted;
  --s.placed;
}

template <class Rng>
double InsertionPlanner::draw_radius(const FaceState& f, Rng& rng) const {
  const auto& e = prm_.radius_bins;
  int64_t total = 0;
  for (int64_t c : f.histogram) total += std::max<int64_t>(c, 0);
  size_t bin = 0;
  if (total > 0) {
    int64_t pick = static_cast<int64_t>(rng() % static_cast<uint64_t>(total));
    for (bin = 0; bin + 1 < f.histogram.size(); ++bin) {
      pick -= std::max<int64_t>(f.histogram[bin], 0);
      if (pick < 0) break;
    }
  } else {
    bin = static_cast<size_t>(rng() % f.histogram.size());
  }
  const double u = std::uniform_real_distribution<double>(0.0, 1.0)(rng);
  return (e[bin] + u * (e[bin + 1] - e[bin])) / prm_.ratio;
}

bool InsertionPlanner::likely_to_place(const FaceState& s) const {
  return s.seen && s.remainder + std::max(0.0, s.last_crossed) >= mass_of(prm_.radius_bins.front() / prm_.ratio);
}

bool InsertionPlanner::wants_occupants(uint64_t interval) const {
  if (prm_.retry_full_every > 1) return !occupant_faces(interval).empty();
  bool any = false, fresh = false;
  for (const auto& s : faces_) {
    if (!likely_to_place(s)) continue;
    any = true;
    fresh = fresh || s.short_streak == 0;
  }
  return any && (fresh || interval % 4 == 0);
}

std::vector<uint32_t> InsertionPlanner::occupant_faces(uint64_t interval) const {
  std::vector<uint32_t> out;
  if (prm_.retry_full_every <= 1) return out;
  const bool retry = (interval + 1) % prm_.retry_full_every == 0;
  for (size_t f = 0; f < faces_.size(); ++f)
    if (likely_to_place(faces_[f]) && (faces_[f].short_streak == 0 || retry)) out.push_back(static_cast<uint32_t>(f));
  return out;
}

std::mt19937_64& InsertionPlanner::rng(uint64_t interval, size_t f) {
  // Seeded on first use, not per face and interval: seeding costs more than the rest of a face that places
  // nothing (most faces, most intervals); the stream of a face's interval is the same either way.
  auto& g = rngs_[f];
  if (!g) g.emplace(mix(prm_.seed ^ mix(interval * 0x100000001b3ULL + f)));
  return *g;
}

std::vector<char> InsertionPlanner::draw_pending(uint64_t interval, const std::vector<uint32_t>& reported) {
  // Each face's next radius, drawn as its first placement would draw it: the faces whose remainder covers
  // it, and whose slab's particles the fine level reported, are the ones that try to place this interval.
  std::vector<char> tries(faces_.size(), 0), known(faces_.size(), reported.empty());
  for (const uint32_t f : reported)
    if (f < known.size()) known[f] = 1;
  rngs_.resize(faces_.size());
  for (auto& g : rngs_) g.reset();
  for (size_t f = 0; f < faces_.size(); ++f) {
    if (!known[f]) continue;
    FaceState& s = faces_[f];
    if (!s.seen) continue;
    if (s.next_radius <= 0.0) s.next_radius = draw_radius(s, rng(interval, f));
    tries[f] = s.remainder >= mass_of(s.next_radius);
  }
  return tries;
}

void InsertionPlanner::fill_hash(const std::vector<Sphere>& occupants, const std::vector<char>& tries) {
  // Only the occupants a candidate in a trying face's slab can touch: within the largest fine radius plus
  // their own of the box around those slabs. The overlap tests answer as with every occupant in the hash.
  Vec3 lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
  for (size_t f = 0; f < faces_.size(); ++f)
    if (tries[f]) {
      Vec3 a, b;
      geo_.face_slab(f, prm_.insert_depth, a, b);
      for (int k = 0; k < 3; ++k) {
        lo[k] = std::min(lo[k], a[k]);
        hi[k] = std::max(hi[k], b[k]);
      }
    }
  const double reach = prm_.radius_bins.back() / prm_.ratio;
  hash_.clear();
  for (const auto& o : occupants)
    if (bus::near_box(o.x, lo, hi, reach + o.r)) hash_.add(o);
}

std::vector<Insert> InsertionPlanner::plan(uint64_t interval, const std::vector<Sphere>& occupants,
                                           const std::vector<uint32_t>& reported) {
  std::vector<Insert> out;
  const std::vector<char> tries = draw_pending(interval, reported);
  if (std::find(tries.begin(), tries.end(), 1) == tries.end()) return out;  // most intervals place nothing
  fill_hash(occupants, tries);
  for (size_t f = 0; f < faces_.size(); ++f) {
    if (!tries[f]) continue;
    FaceState& s = faces_[f];
    Vec3 slab_lo, slab_hi;
    geo_.face_slab(f, prm_.insert_depth, slab_lo, slab_hi);
    const int axis = geo_.normal_axis(f);
    for (;;) {
      if (s.next_radius <= 0.0) s.next_radius = draw_radius(s, rng(interval, f));
      const double r = s.next_radius, m = mass_of(r);
      if (s.remainder < m) break;
      Vec3 lo = slab_lo, hi = slab_hi;  // a whole sphere inside the slab along the normal
      lo[axis] += r;
      hi[axis] -= r;
      if (hi[axis] < lo[axis]) throw std::runtime_error("insertion planner: insert_depth is smaller than a fine diameter");
      std::uniform_real_distribution<double> ux(lo.x, hi.x), uy(lo.y, hi.y), uz(lo.z, hi.z);
      bool placed = false;
      const int attempts = s.short_streak > 0 ? prm_.attempts_when_full : prm_.attempts;
      for (int a = 0; a < attempts && !placed; ++a) {
        auto& g = rng(interval, f);
        const Vec3 x{ux(g), uy(g), uz(g)};
        if (hash_.overlaps(x, r) || !fits_(s.anchor, x, r)) continue;
        hash_.add(x, r);
        out.push_back({x, r, s.velocity, static_cast<int>(f)});
        s.inserted += m;
        s.remainder = s.crossed + s.returned - s.inserted;
        ++s.placed;
        s.next_radius = 0.0;
        s.short_streak = 0;
        placed = true;
      }
      if (!placed) {
        ++s.short_intervals;
        ++s.short_streak;
        break;
      }
    }
  }
  return out;
}

}  // namespace mlcg::coupling
