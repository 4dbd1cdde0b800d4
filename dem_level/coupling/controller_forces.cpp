#include "coupling/controller_forces.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "core/spheres.hpp"

namespace mlcg::coupling {

namespace {
// Volume fraction of the sparsest layer that still takes its full share of the traction. Below it
// a particle takes no more than its share in such a layer (a few particles never carry the whole
// traction); a loose bed (about 0.55) lies above it, so a bed carries the whole traction.
constexpr double kPhiFloor = 0.4;
}  // namespace

ControllerForces::ControllerForces(const bus::CouplingGeometry& geo)
    : geo_(geo), top_(geo.top()), depth_(geo.grid().fade_depth()), wsum_(geo.faces(), 0.0) {
  // The traction acts on the part of a face inside the walls: a face half cut by the cone carries half.
  for (size_t f = 0; f < geo.faces(); ++f) area_.push_back(geo.cell_size() * geo.cell_size() * geo.inside_area(f));
}

void ControllerForces::set_traction(std::vector<double> traction, std::vector<double> speed_limit) {
  const size_t nf = geo_.faces();
  if (!traction.empty() && traction.size() != nf)
    throw std::invalid_argument("traction has " + std::to_string(traction.size()) + " values, the grid " +
                                std::to_string(nf) + " boundary faces");
  if (!speed_limit.empty() && speed_limit.size() != nf)
    throw std::invalid_argument("speed_limit has " + std::to_string(speed_limit.size()) + " values, the grid " +
                                std::to_string(nf) + " boundary faces");
  traction_ = std::move(traction);
  vmax_ = std::move(speed_limit);
  traction_on_ = false;
  for (double t : traction_) traction_on_ = traction_on_ || t != 0.0;
  traction_on_ = traction_on_ && depth_ > 0.0;
  wsum_.assign(nf, 0.0);
}

void ControllerForces::set_acceleration(std::vector<double> acceleration) {
  const size_t nc = geo_.cells();
  if (!acceleration.empty() && acceleration.size() != 3 * nc)
    throw std::invalid_argument("acceleration has " + std::to_string(acceleration.size()) + " values, expected 3 x " +
                                std::to_string(nc) + " active cells");
  accel_.assign(acceleration.empty() ? 0 : nc, Vec3{});
  accel_on_ = false;
  for (size_t c = 0; c < accel_.size(); ++c) {
    accel_[c] = {acceleration[3 * c], acceleration[3 * c + 1], acceleration[3 * c + 2]};
    accel_on_ = accel_on_ || !(accel_[c] == Vec3{});
  }
}

double ControllerForces::weight(const Vec3& x, double r, int& face) const {
  face = -1;
  const double s = top_ - x.z;
  if (!(s >= 0.0 && s < depth_)) return 0.0;
  face = geo_.face_column(x);
  if (face < 0) return 0.0;
  return sphere_volume(r) * (1.0 - s / depth_);
}

void ControllerForces::normalise(const Particles& p, const Comm& comm) {
  const size_t nf = geo_.faces();
  wsum_.assign(nf, 0.0);
  if (!traction_on_) return;  // the same on every rank: the commands are
  std::vector<double> sums(nf + 2, 0.0);  // weights per face, then sum of radii and count in the zone
  // The candidate lists hold every particle apply() can press, in increasing order: the same sums.
  const size_t mt = near_valid_ ? near_top_.size() : p.n_local();
  for (size_t q = 0; q < mt; ++q) {
    const size_t i = near_valid_ ? near_top_[q] : q;
    int f = -1;
    const double w = weight(p.x[i], p.radius[i], f);
    if (f < 0) continue;
    sums[static_cast<size_t>(f)] += w;
    sums[nf] += p.radius[i];
    sums[nf + 1] += 1.0;
  }
  const size_t ms = geo_.open_sides().empty() ? 0 : near_valid_ ? near_side_.size() : p.n_local();
  const auto& sides = geo_.open_sides();
  for (size_t q = 0; q < ms; ++q) {
    const size_t i = near_valid_ ? near_side_[q] : q;
    const uint32_t mask = near_valid_ ? near_side_mask_[q] : ~0u;
    int cell = -2;  // located once per particle, on its first side within the fade depth
    for (size_t k = 0; k < sides.size(); ++k) {
      if (!(mask >> k & 1u)) continue;
      int f = -1;
      const double w = side_weight(p.x[i], p.radius[i], sides[k], cell, f);
      if (f >= 0) sums[static_cast<size_t>(f)] += w;
    }
  }
  comm.sum_in_place(sums.data(), sums.size());
  // The floor is the weight of a layer at kPhiFloor flush with the boundary: its centres lie one
  // radius or more below the surface, so it weighs phi h^2 (D - r)^2 / (2 D), not phi h^2 D / 2.
  const double r = sums[nf + 1] > 0.0 ? sums[nf] / sums[nf + 1] : 0.0;
  const double reach = std::max(depth_ - r, 0.5 * depth_);
  const double floor = kPhiFloor * reach * reach / (2.0 * depth_);
  for (size_t f = 0; f < nf; ++f) wsum_[f] = std::max(sums[f], floor * area_[f]);
}

double ControllerForces::side_weight(const Vec3& x, double r, bus::Side side, int& cell, int& face) const {
  face = -1;
  const double s = geo_.depth_inside(side, x);
  if (!(s >= 0.0 && s < depth_)) return 0.0;
  if (cell == -2) cell = geo_.locate(x);
  if (cell < 0) return 0.0;
  face = geo_.side_face(static_cast<size_t>(cell), side);
  return face < 0 ? 0.0 : sphere_volume(r) * (1.0 - s / depth_);
}

uint32_t ControllerForces::sides_within_reach(const Vec3& x, double band) const {
  // Until the next refresh x stays within the cube of half-edge band around it; with 2 band below a cell's
  // edge the cells that cube touches are those of its corners. A side whose cells there have no boundary
  // face (closed by the walls, outside the vessel) presses nothing.
  const bool corners = 2.0 * band < geo_.cell_size();
  const auto& sides = geo_.open_sides();
  uint32_t mask = 0;
  for (size_t k = 0; k < sides.size(); ++k) {
    const double s = geo_.depth_inside(sides[k], x);
    if (!(s > -band && s < depth_ + band)) continue;
    bool reach = !corners;
    for (int c = 0; c < 8 && !reach; ++c) {
      const Vec3 y{x.x + (c & 1 ? band : -band), x.y + (c & 2 ? band : -band), x.z + (c & 4 ? band : -band)};
      const int cell = geo_.locate(y);
      reach = cell >= 0 && geo_.side_face(static_cast<size_t>(cell), sides[k]) >= 0;
    }
    if (reach) mask |= 1u << k;
  }
  return mask;
}

void ControllerForces::refresh(const Particles& p, double band, size_t from) {
  if (from == 0) {
    near_top_.clear();
    near_side_.clear();
    near_side_mask_.clear();
  }
  for (size_t i = from; i < p.n_local(); ++i) {
    const double s = top_ - p.x[i].z;
    if (s > -band && s < depth_ + band) near_top_.push_back(static_cast<uint32_t>(i));
    if (geo_.open_sides().empty()) continue;
    if (const uint32_t mask = sides_within_reach(p.x[i], band)) {
      near_side_.push_back(static_cast<uint32_t>(i));
      near_side_mask_.push_back(mask);
    }
  }
  near_valid_ = true;
}

Vec3 ControllerForces::limited(const Vec3& F, const Vec3& v, size_t f) const {
  if (vmax_.empty()) return F;
  const double v2 = norm2(v), fv = dot(F, v);
  if (v2 > 0.0 && v2 >= vmax_[f] * vmax_[f] && fv > 0.0) return F - (fv / v2) * v;
  return F;
}

void ControllerForces::apply_sides(Particles& p) const {
  // An open side is pressed like the top: its traction along the inward normal, on the particles
  // within the fade depth inside it, shared by weight.
  const auto& sides = geo_.open_sides();
  const size_t m = near_valid_ ? near_side_.size() : p.n_local();
  for (size_t q = 0; q < m; ++q) {
    const size_t i = near_valid_ ? near_side_[q] : q;
    const uint32_t mask = near_valid_ ? near_side_mask_[q] : ~0u;  // the sides it can be pressed by
    int cell = -2;
    for (size_t k = 0; k < sides.size(); ++k) {
      if (!(mask >> k & 1u)) continue;
      int f = -1;
      const double w = side_weight(p.x[i], p.radius[i], sides[k], cell, f);
      if (f < 0) continue;
      const auto fs = static_cast<size_t>(f);
      if (wsum_[fs] <= 0.0 || traction_[fs] == 0.0) continue;
      p.f[i] += limited((traction_[fs] * area_[fs] * w / wsum_[fs]) * geo_.face_inward(fs), p.v[i], fs);
    }
  }
}

void ControllerForces::apply(Particles& p, const std::vector<uint32_t>* in_box) const {
  const size_t n = p.n_local();
  if (traction_on_) {
    const size_t m = near_valid_ ? near_top_.size() : n;
    for (size_t q = 0; q < m; ++q) {
      const size_t i = near_valid_ ? near_top_[q] : q;
      int f = -1;
      const double w = weight(p.x[i], p.radius[i], f);
      if (f < 0) continue;
      const auto fs = static_cast<size_t>(f);
      if (wsum_[fs] <= 0.0 || traction_[fs] == 0.0) continue;
      Vec3 F{0.0, 0.0, -traction_[fs] * area_[fs] * w / wsum_[fs]};
      if (!vmax_.empty()) {
        const Vec3& v = p.v[i];
        const double v2 = norm2(v), fv = dot(F, v);
        if (v2 > 0.0 && v2 >= vmax_[fs] * vmax_[fs] && fv > 0.0) F -= (fv / v2) * v;
      }
      p.f[i] += F;
    }
  }
  if (traction_on_ && !geo_.open_sides().empty()) apply_sides(p);
  if (accel_on_) {
    const size_t m = in_box ? in_box->size() : n;
    for (size_t q = 0; q < m; ++q) {
      const size_t i = in_box ? (*in_box)[q] : q;
      const int c = geo_.locate(p.x[i]);
      if (c < 0) continue;
      p.f[i] += p.mass[i] * accel_[static_cast<size_t>(c)];
    }
  }
}

}  // namespace mlcg::coupling
