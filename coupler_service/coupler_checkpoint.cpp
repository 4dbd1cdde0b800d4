// The coupler's part of a consistent hierarchy checkpoint: every value the
// next intervals' commands depend on. The planner's random draws are seeded by
// (seed, face, interval), so faces + controllers + interval index are the whole state.
#include <cmath>
#include <stdexcept>
#include <string>

#include "coupler.hpp"

namespace mlcg::coupling {
namespace {

void put(google::protobuf::RepeatedField<double>* out, const Vec3& v) {
  out->Add(v.x);
  out->Add(v.y);
  out->Add(v.z);
}

Vec3 get(const google::protobuf::RepeatedField<double>& a, const std::string& what) {
  if (a.size() != 3) throw std::invalid_argument("coupler checkpoint: " + what + " needs 3 values");
  return {a[0], a[1], a[2]};
}

// Cumulative crossing counts stay far from int64 overflow: 2^50 is some 10^15 particles per face and bin.
constexpr int64_t kMaxCount = int64_t{1} << 50;

[[noreturn]] void damaged(const std::string& where, const std::string& what) {
  throw std::invalid_argument("coupler checkpoint: " + where + ": " + what +
                              "; the checkpoint is damaged: resume from an intact consistent set");
}

void check_finite(const std::string& where, const char* field, const google::protobuf::RepeatedField<double>& a) {
  for (int i = 0; i < a.size(); ++i)
    if (!std::isfinite(a[i])) damaged(where, std::string(field) + "[" + std::to_string(i) + "] is not a finite number");
}

// A face's state as the coupler saves it: finite numbers, counts in range, a drawn radius of the fine
// sizes (r_lo..r_hi) or none.
void check_face(const bus::FaceCheckpoint& fc, const std::string& where, double r_lo, double r_hi) {
  for (const double v : {fc.crossed(), fc.inserted(), fc.remainder(), fc.last_crossed(), fc.returned()})
    if (!std::isfinite(v)) damaged(where, "a mass that is not a finite number");
  check_finite(where, "velocity", fc.velocity());
  check_finite(where, "anchor", fc.anchor());
  for (const int64_t h : fc.histogram())
    if (h > kMaxCount || h < -kMaxCount)
      damaged(where, "a crossing count of " + std::to_string(h) + "; at most 2^50 either way");
  const double r = fc.next_radius();
  if (!(r == 0.0 || (r >= r_lo * (1.0 - 1e-12) && r <= r_hi * (1.0 + 1e-12))))
    damaged(where, "next_radius " + std::to_string(r) + " m is neither 0 nor a fine radius (" + std::to_string(r_lo) +
                       " to " + std::to_string(r_hi) + " m)");
}

// The insertion list of the commands saved: whole particles of finite values, each placed for a face of the grid.
void check_last(const bus::RegionCheckpoint& rc, const std::string& where, size_t faces) {
  check_finite(where, "last_insert", rc.last_insert());
  for (int i = 3; i < rc.last_insert_size(); i += 7)
    if (!(rc.last_insert(i) > 0.0))
      damaged(where, "last_insert particle " + std::to_string(i / 7) + " has a radius <= 0");
  for (const int32_t f : rc.last_insert_face())
    if (f < -1 || f >= static_cast<int64_t>(faces))
      damaged(where, "last_insert_face " + std::to_string(f) + " is not a face of the grid's " +
                         std::to_string(faces) + " (or -1)");
  check_finite(where, "pi_integral", rc.pi_integral());
  check_finite(where, "pi_output", rc.pi_output());
  check_finite(where, "velocity_integral", rc.velocity_integral());
}

}  // namespace

void Coupler::save(bus::CouplerCheckpoint& out) const {
  out.set_seed(cfg_.seed);
  out.clear_regions();
  for (const auto& r : regions_) {
    bus::RegionCheckpoint& rc = *out.add_regions();
    for (const auto& f : r->planner.faces()) {
      bus::FaceCheckpoint& fc = *rc.add_faces();
      fc.set_crossed(f.crossed);
      fc.set_inserted(f.inserted);
      fc.set_remainder(f.remainder);
      fc.set_placed(f.placed);
      put(fc.mutable_velocity(), f.velocity);
      put(fc.mutable_anchor(), f.anchor);
      fc.set_seen(f.seen);
      for (const int64_t h : f.histogram) fc.add_histogram(h);
      fc.set_next_radius(f.next_radius);
      fc.set_short_intervals(f.short_intervals);
      fc.set_short_streak(f.short_streak);
      fc.set_last_crossed(f.last_crossed);
      fc.set_returned(f.returned);
      fc.set_bounded(f.bounded);
    }
    for (const auto& pi : r->pi) {
      rc.add_pi_integral(pi.integral);
      rc.add_pi_output(pi.output);
    }
    for (const Vec3& v : r->vint) put(rc.mutable_velocity_integral(), v);
    for (const auto& p : r->last) {
      for (double v : {p.x.x, p.x.y, p.x.z, p.r, p.v.x, p.v.y, p.v.z}) rc.add_last_insert(v);
      rc.add_last_insert_face(p.face);
    }
  }
}

void Coupler::restore(const bus::CouplerCheckpoint& in) {
  if (in.seed() != cfg_.seed)
    throw std::invalid_argument("coupler checkpoint: written with seed " + std::to_string(in.seed()) +
                                ", the case has seed " + std::to_string(cfg_.seed));
  if (static_cast<size_t>(in.regions_size()) != regions_.size())
    throw std::invalid_argument("coupler checkpoint: has " + std::to_string(in.regions_size()) +
                                " regions, the case has " + std::to_string(regions_.size()));
  for (size_t ri = 0; ri < regions_.size(); ++ri) {
    Region& r = *regions_[ri];
    const bus::RegionCheckpoint& rc = in.regions(static_cast<int>(ri));
    const std::string where = "coupler checkpoint: region " + std::to_string(ri);
    auto& faces = r.planner.faces_mut();
    if (static_cast<size_t>(rc.faces_size()) != faces.size() || rc.pi_integral_size() != rc.faces_size() ||
        rc.pi_output_size() != rc.faces_size() || rc.last_insert_size() % 7 != 0)
      throw std::invalid_argument(where + " has " + std::to_string(rc.faces_size()) + " faces, the case's grid has " +
                                  std::to_string(faces.size()));
    check_last(rc, where, faces.size());
    const auto& bins = r.cfg.planner.radius_bins;
    for (size_t f = 0; f < faces.size(); ++f) {
      const bus::FaceCheckpoint& fc = rc.faces(static_cast<int>(f));
      check_face(fc, where + " face " + std::to_string(f), bins.front() / r.cfg.planner.ratio,
                 bins.back() / r.cfg.planner.ratio);
      FaceState& s = faces[f];
      if (static_cast<size_t>(fc.histogram_size()) != s.histogram.size())
        throw std::invalid_argument(where + ": face " + std::to_string(f) + " has another number of radius bins");
      s.crossed = fc.crossed();
      s.inserted = fc.inserted();
      s.remainder = fc.remainder();
      s.placed = fc.placed();
      s.velocity = get(fc.velocity(), "velocity");
      s.anchor = get(fc.anchor(), "anchor");
      s.seen = fc.seen();
      s.histogram.assign(fc.histogram().begin(), fc.histogram().end());
      s.next_radius = fc.next_radius();
      s.short_intervals = fc.short_intervals();
      s.short_streak = fc.short_streak();
      s.last_crossed = fc.last_crossed();
      s.returned = fc.returned();
      s.bounded = fc.bounded();
      r.pi[f].integral = rc.pi_integral(static_cast<int>(f));
      r.pi[f].output = rc.pi_output(static_cast<int>(f));
    }
    // Checkpoints written before the velocity controller had an integral carry none: it restarts at 0.
    const auto& vi = rc.velocity_integral();
    if (!vi.empty() && static_cast<size_t>(vi.size()) != 3 * r.vint.size())
      throw std::invalid_argument(where + " has " + std::to_string(vi.size() / 3) +
                                  " velocity integrals, the case's grid has " + std::to_string(r.vint.size()) +
                                  " active cells");
    for (size_t c = 0; c < r.vint.size(); ++c)
      r.vint[c] = vi.empty() ? Vec3{} : Vec3{vi[3 * c], vi[3 * c + 1], vi[3 * c + 2]};
    r.last.clear();
    for (int i = 0; i + 6 < rc.last_insert_size(); i += 7) {
      const auto& a = rc.last_insert();
      const int face = rc.last_insert_face_size() == rc.last_insert_size() / 7 ? rc.last_insert_face(i / 7) : -1;
      r.last.push_back({{a[i], a[i + 1], a[i + 2]}, a[i + 3], {a[i + 4], a[i + 5], a[i + 6]}, face});
    }
  }
}

}  // namespace mlcg::coupling
