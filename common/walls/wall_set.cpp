#include "walls/wall_set.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace mlcg {

int WallSet::add_analytic(const std::string& name, int material, const AnalyticWall& w) {
  if (!meshes_.empty()) throw std::logic_error("WallSet: add analytic walls before meshes");
  Info in;
  in.name = name;
  in.material = material;
  in.prim_begin = next_prim_;
  in.prim_end = ++next_prim_;
  analytic_.push_back(w);
  analytic_wall_.push_back(static_cast<int>(info_.size()));
  info_.push_back(in);
  return static_cast<int>(info_.size()) - 1;
}

int WallSet::add_mesh(const std::string& name, int material, std::shared_ptr<const TriangleMesh> mesh) {
  Info in;
  in.name = name;
  in.material = material;
  in.is_mesh = true;
  in.mesh = static_cast<int>(meshes_.size());
  in.prim_begin = next_prim_;
  next_prim_ += static_cast<int32_t>(mesh->triangles());
  in.prim_end = next_prim_;
  meshes_.push_back(std::move(mesh));
  info_.push_back(in);
  return static_cast<int>(info_.size()) - 1;
}

void WallSet::set_motion(size_t w, const Vec3& u, const Vec3& spin, const Vec3& center) {
  Info& in = info_[w];
  in.surface_velocity = u;
  in.spin = spin;
  in.spin_center = center;
  in.moving = !(u == Vec3{}) || !(spin == Vec3{});
}

void WallSet::set_rigid_motion(size_t w, const Vec3& u, const Vec3& spin, const Vec3& center) {
  Info& in = info_[w];
  if (!in.is_mesh) throw std::logic_error("WallSet: only a mesh moves rigidly");
  in.rigid = in.moving = true;
  in.move_velocity = u;
  in.move_spin = spin;
  in.move_center = center;
  const TriangleMesh& m = *meshes_[static_cast<size_t>(in.mesh)];
  in.reach = farthest_corner(m.bbox_min(), m.bbox_max(), center);
  rigid_ = true;
  set_time(time_);
}

void WallSet::set_time(double t) {
  time_ = t;
  for (Info& in : info_) {
    if (!in.rigid) continue;
    // Rodrigues: R turns by |spin| t about spin's direction.
    const double w = norm(in.move_spin), a = w * t;
    const Vec3 k = w > 0.0 ? in.move_spin * (1.0 / w) : Vec3{};
    const double c = std::cos(a), s = std::sin(a), C = 1.0 - c;
    in.rot[0] = {c + k.x * k.x * C, k.x * k.y * C - k.z * s, k.x * k.z * C + k.y * s};
    in.rot[1] = {k.y * k.x * C + k.z * s, c + k.y * k.y * C, k.y * k.z * C - k.x * s};
    in.rot[2] = {k.z * k.x * C - k.y * s, k.z * k.y * C + k.x * s, c + k.z * k.z * C};
    const Vec3 centre = in.move_center + in.move_velocity * t;
    in.shift = centre - in.turn(in.move_center);
    in.surface_velocity = in.move_velocity;
    in.spin = in.move_spin;
    in.spin_center = centre;
  }
}

double WallSet::moved_since_build() const {
  double d = 0.0;
  const double dt = std::fabs(time_ - build_time_);
  for (const Info& in : info_)
    if (in.rigid) d = std::max(d, (norm(in.move_velocity) + norm(in.move_spin) * in.reach) * dt);
  return d;
}

int WallSet::find(const std::string& name) const {
  for (size_t w = 0; w < info_.size(); ++w)
    if (info_[w].name == name) return static_cast<int>(w);
  return -1;
}

int WallSet::wall_of_prim(int32_t p) const {
  if (p < analytic_count()) return analytic_wall_[static_cast<size_t>(p)];
  for (size_t w = 0; w < info_.size(); ++w)
    if (p >= info_[w].prim_begin && p < info_[w].prim_end) return static_cast<int>(w);
  return -1;
}

namespace {

// Whether the segment a-b crosses a surface of revolution (its meridian
// segment turned about the axis), solved in closed form: along the segment the
// axial coordinate s is linear in u and rho^2 quadratic. On a frustum
// (ds != 0) the generating line gives rho = L(u), linear, so a crossing is a
// root of rho^2 - L^2 with L >= 0; on a disk or annulus (ds = 0) it is where s
// reaches s0. Either way the crossing point must lie on the wall's own segment
// (0 <= t <= 1). A segment that only touches the surface does not cross it.
// (Classifying the two ends by the side of their own feet, as a march did,
// misses a segment that enters the solid beyond a junction: both ends project
// past the wall's ends.)
bool segment_crosses_revolution(const RevolutionWall& w, const Vec3& a, const Vec3& b) {
  const Vec3 d = b - a, ra = a - w.c;
  const double sa = dot(ra, w.a), sd = dot(d, w.a);
  const Vec3 pa = ra - sa * w.a, pd = d - sd * w.a;  // radial parts: rho(u) = |pa + u pd|
  const double dr = w.rho1 - w.rho0, ds = w.s1 - w.s0;
  const auto rho_at = [&](double u) { return std::sqrt(norm2(pa + u * pd)); };
  const auto on_wall = [](double t) { return t >= 0.0 && t <= 1.0; };
  if (ds == 0.0) {
    if (dr == 0.0 || sd == 0.0) return false;
    const double u = (w.s0 - sa) / sd;
    return u >= 0.0 && u <= 1.0 && on_wall((rho_at(u) - w.rho0) / dr);
  }
  const double k = dr / ds;                           // rho on the line: rho0 + k (s - s0)
  const double al = w.rho0 + k * (sa - w.s0), be = k * sd;  // L(u) = al + be u
  const double qa = norm2(pd) - be * be, qb = 2.0 * (dot(pa, pd) - al * be), qc = norm2(pa) - al * al;
  double roots[2];
  int n = 0;
  if (std::fabs(qa) < 1e-14 * (norm2(pd) + be * be)) {
    if (qb != 0.0) roots[n++] = -qc / qb;
  } else {
    const double disc = qb * qb - 4.0 * qa * qc;
    if (disc <= 0.0) return false;  // no root, or a tangent touch
    const double sq = std::sqrt(disc), q = -0.5 * (qb + std::copysign(sq, qb));
    roots[n++] = q / qa;
    if (q != 0.0) roots[n++] = qc / q;
  }
  for (int i = 0; i < n; ++i) {
    const double u = roots[i];
    if (!(u >= 0.0 && u <= 1.0) || al + be * u < 0.0) continue;
    if (on_wall((sa + u * sd - w.s0) / ds)) return true;
  }
  return false;
}

bool segment_hits_triangle(const Vec3& a, const Vec3& b, const Vec3& p0, const Vec3& p1, const Vec3& p2) {
  // Moeller-Trumbore on the segment a + t (b - a), t in [0, 1].
  const Vec3 d = b - a, e1 = p1 - p0, e2 = p2 - p0;
  const Vec3 h = cross(d, e2);
  const double det = dot(e1, h);
  if (std::fabs(det) < 1e-300) return false;
  const double inv = 1.0 / det;
  const Vec3 s = a - p0;
  const double u = dot(s, h) * inv;
  if (u < 0.0 || u > 1.0) return false;
  const Vec3 q = cross(s, e1);
  const double v = dot(d, q) * inv;
  if (v < 0.0 || u + v > 1.0) return false;
  const double t = dot(e2, q) * inv;
  return t >= 0.0 && t <= 1.0;
}

}  // namespace

bool WallSet::touches(const Vec3& x, double r) const {
  WallGeom g;
  for (int32_t k = 0; k < analytic_count(); ++k) {
    if (!info_[static_cast<size_t>(analytic_wall_[static_cast<size_t>(k)])].active) continue;
    if (analytic_[static_cast<size_t>(k)].closest(x, g) && g.dist < r) return true;
  }
  for (const auto& in : info_)
    if (in.is_mesh && in.active && meshes_[static_cast<size_t>(in.mesh)]->any_within(in.to_body(x), r)) return true;
  return false;
}

double WallSet::overlap(const Vec3& x, double r) const {
  double worst = 0.0;
  WallGeom g;
  for (int32_t k = 0; k < analytic_count(); ++k) {
    if (!info_[static_cast<size_t>(analytic_wall_[static_cast<size_t>(k)])].active) continue;
    if (analytic_[static_cast<size_t>(k)].closest(x, g)) worst = std::max(worst, r - g.dist);
  }
  std::vector<int32_t> tris;
  for (const auto& in : info_) {
    if (!in.is_mesh || !in.active) continue;
    const TriangleMesh& m = *meshes_[static_cast<size_t>(in.mesh)];
    const Vec3 xb = in.to_body(x);
    m.query(xb, r, tris);
    for (int32_t t : tris) worst = std::max(worst, r - m.distance(t, xb));
  }
  return worst;
}

bool WallSet::crosses(const Vec3& a, const Vec3& b) const {
  const double len = std::sqrt(norm2(b - a));
  for (int32_t k = 0; k < analytic_count(); ++k) {
    if (!info_[static_cast<size_t>(analytic_wall_[static_cast<size_t>(k)])].active) continue;
    const AnalyticWall& w = analytic_[static_cast<size_t>(k)];
    if (w.kind == AnalyticWall::Kind::Plane) {
      const double da = dot(a - w.plane.p, w.plane.n), db = dot(b - w.plane.p, w.plane.n);
      if ((da > 0.0) != (db > 0.0)) return true;
      continue;
    }
    if (segment_crosses_revolution(w.rev, a, b)) return true;
  }
  // Only triangles whose boxes meet the segment's (widened by a rounding margin) can be hit: for the
  // insertion's vertical segments a thin column, where a sphere about the midpoint held most of a silo.
  thread_local std::vector<int32_t> tris;  // insertion asks this for every candidate: no allocation per call
  const Vec3 margin{1e-9 * len, 1e-9 * len, 1e-9 * len};
  for (const auto& in : info_) {
    if (!in.is_mesh || !in.active) continue;
    const Vec3 ab = in.to_body(a), bb = in.to_body(b);  // a rigid motion keeps a segment straight
    const Vec3 lo = Vec3{std::min(ab.x, bb.x), std::min(ab.y, bb.y), std::min(ab.z, bb.z)} - margin;
    const Vec3 hi = Vec3{std::max(ab.x, bb.x), std::max(ab.y, bb.y), std::max(ab.z, bb.z)} + margin;
    const TriangleMesh& m = *meshes_[static_cast<size_t>(in.mesh)];
    m.query_box(lo, hi, tris);
    for (int32_t t : tris) {
      const auto v = m.triangle_vertices(t);
      if (segment_hits_triangle(ab, bb, m.vertex(v[0]), m.vertex(v[1]), m.vertex(v[2]))) return true;
    }
  }
  return false;
}

void WallSet::build_candidates(const Particles& p, double skin, bool with_history) {
  first.assign(1, 0);
  prim.clear();
  near.clear();
  hist.clear();
  build_time_ = time_;
  append_candidates(p, 0, skin, with_history);
}

void WallSet::append_candidates(const Particles& p, size_t first_new, double skin, bool with_history) {
  if (first.size() != first_new + 1)
    throw std::logic_error("WallSet::append_candidates: the candidates do not end where the new particles start");
  WallGeom g;
  for (size_t i = first_new; i < p.n_local(); ++i) {
    const double reach = p.radius[i] + skin;
    for (int32_t a = 0; a < analytic_count(); ++a) {
      if (!info_[static_cast<size_t>(analytic_wall_[static_cast<size_t>(a)])].active) continue;
      if (analytic_[static_cast<size_t>(a)].closest(p.x[i], g) && g.dist < reach) prim.push_back(a);
    }
    for (const auto& in : info_) {
      if (!in.is_mesh || !in.active) continue;
      scratch_.clear();
      meshes_[static_cast<size_t>(in.mesh)]->query(in.to_body(p.x[i]), reach, scratch_);
      for (int32_t t : scratch_) prim.push_back(in.prim_begin + t);
    }
    first.push_back(static_cast<int32_t>(prim.size()));
    if (first[i + 1] > first[i]) near.push_back(static_cast<int32_t>(i));
  }
  if (with_history) hist.resize(prim.size(), Vec3{});
  else hist.clear();
}

void WallSet::save_history(const Particles& p, ContactHistory& out) const {
  const size_t n = p.size();
  out.clear(n);
  if (hist.empty()) return;
  const size_t nl = first.size() - 1;
  for (size_t i = 0; i < n; ++i) {
    if (i < nl)
      for (int32_t k = first[i]; k < first[i + 1]; ++k) {
        const Vec3 h = hist[static_cast<size_t>(k)];
        if (h == Vec3{}) continue;
        out.key.push_back(history_key(prim[static_cast<size_t>(k)]));
        out.value.push_back(h);
      }
    out.first[i + 1] = static_cast<int32_t>(out.key.size());
  }
}

void WallSet::load_history(const ContactHistory& in) {
  if (hist.empty()) return;
  const size_t nl = first.size() - 1;
  for (size_t i = 0; i < nl && i < in.particles(); ++i) {
    if (in.first[i] == in.first[i + 1]) continue;
    for (int32_t k = first[i]; k < first[i + 1]; ++k)
      hist[static_cast<size_t>(k)] = in.find(i, history_key(prim[static_cast<size_t>(k)]));
  }
}

}  // namespace mlcg
