#include "coupling/face_flux.hpp"

#include <algorithm>
#include <cmath>

namespace mlcg::coupling {

int face_radius_bin(const std::vector<double>& e, double r) {
  if (e.size() < 2) return -1;
  const int last = static_cast<int>(e.size()) - 2;
  const auto b = static_cast<int>(std::upper_bound(e.begin(), e.end(), r) - e.begin()) - 1;
  return std::clamp(b, 0, last);
}

FaceFlux::FaceFlux(const bus::CouplingGeometry& geo)
    : geo_(geo), nf_(geo.faces()), edges_(geo.grid().radius_bins().begin(), geo.grid().radius_bins().end()),
      plane_(Vec3{0.0, 0.0, geo.top()}, Vec3{0.0, 0.0, -1.0}) {
  nb_ = edges_.size() >= 2 ? edges_.size() - 1 : 1;
  const Vec3 lo = geo.box_lo(), hi = geo.box_hi();
  for (const bus::Side s : geo.open_sides()) {
    const bool low = s == bus::Side::XLo || s == bus::Side::YLo || s == bus::Side::Bottom;
    sides_.push_back({s, PlaneCrossings(low ? lo : hi, bus::CouplingGeometry::inward(s))});
  }
  reset();
}

void FaceFlux::reset() {
  mass.assign(nf_, 0.0);
  momentum.assign(3 * nf_, 0.0);
  moment.assign(3 * nf_, 0.0);
  histogram.assign(nf_ * nb_, 0);
  gross_mass.assign(nf_, 0.0);
  speed_mass.assign(nf_, 0.0);
}

void FaceFlux::refresh(const Particles& p, double band, size_t from) {
  const Vec3 lo = geo_.box_lo(), hi = geo_.box_hi();
  plane_.refresh(p, band, [&](const Vec3& x, double) { return bus::near_box(x, lo, hi, band, false); }, from);
  for (auto& sp : sides_)
    sp.plane.refresh(p, band, [&](const Vec3& x, double) { return bus::near_box(x, lo, hi, band); }, from);
}

void FaceFlux::add(size_t f, double m, const Vec3& v, const Vec3& x, double r, int sign) {
  const Vec3 mv = m * v, mx = m * x;
  mass[f] += m;
  for (size_t a = 0; a < 3; ++a) {
    momentum[3 * f + a] += mv[static_cast<int>(a)];
    moment[3 * f + a] += mx[static_cast<int>(a)];
  }
  gross_mass[f] += std::fabs(m);
  speed_mass[f] += std::fabs(m) * norm(v);
  const int b = std::max(0, face_radius_bin(edges_, r));
  histogram[f * nb_ + static_cast<size_t>(b)] += sign;
}

void FaceFlux::check(const Particles& p) {
  plane_.check(p, [&](size_t i, bool down, double, const Vec3& before) {
    const Vec3 xc = plane_.crossing_point(before, p.x[i]);
    const int f = geo_.face_column(xc);
    if (f < 0) return;
    add(static_cast<size_t>(f), down ? p.mass[i] : -p.mass[i], p.v[i], xc, p.radius[i], down ? 1 : -1);
  });
  if (!sides_.empty()) check_sides(p);
}

void FaceFlux::check_sides(const Particles& p) {
  const double eps = 1e-9 * geo_.cell_size();
  for (auto& sp : sides_)
    sp.plane.check(p, [&](size_t i, bool in, double, const Vec3& before) {
      const Vec3 xc = sp.plane.crossing_point(before, p.x[i]);
      const int c = geo_.locate(xc + eps * sp.plane.normal());  // the cell just inside
      if (c < 0) return;
      const int f = geo_.side_face(static_cast<size_t>(c), sp.side);
      if (f < 0) return;
      add(static_cast<size_t>(f), in ? p.mass[i] : -p.mass[i], p.v[i], xc, p.radius[i], in ? 1 : -1);
    });
}

void FaceFlux::add_born(const Vec3& x, const Vec3& v, double m, double r) {
  if (geo_.locate(x) < 0) return;  // counted where the region's mass is counted: in an active cell
  int f = geo_.face_column(x);
  if (f < 0) f = geo_.exit_face(x);
  if (f >= 0) add(static_cast<size_t>(f), m, v, x, r, 1);
}

void FaceFlux::reduce(const Comm& comm) {
  if (comm.serial()) return;
  std::vector<double> all;
  const auto parts = double_sums();
  for (const auto* v : parts) all.insert(all.end(), v->begin(), v->end());
  comm.sum_in_place(all.data(), all.size());
  auto at = all.begin();
  for (auto* v : parts) {
    std::copy(at, at + static_cast<long>(v->size()), v->begin());
    at += static_cast<long>(v->size());
  }
  comm.sum_in_place(histogram.data(), histogram.size());
}

}  // namespace mlcg::coupling
