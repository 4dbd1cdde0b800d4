#include "scene/walls_from_case.hpp"

#include <cmath>
#include <filesystem>
#include <memory>
#include <stdexcept>
#include <string>

#include "walls/stl_reader.hpp"
#include "walls/triangle_mesh.hpp"

namespace mlcg {
namespace {

Vec3 unit(const Vec3& a) { return a / norm(a); }

AnalyticWall make_analytic(const config::WallSpec& w) {
  AnalyticWall a;
  if (w.type == config::WallType::Plane) {
    a.kind = AnalyticWall::Kind::Plane;
    a.plane = {w.point, unit(w.normal)};
    return a;
  }
  a.kind = AnalyticWall::Kind::Revolution;
  RevolutionWall& r = a.rev;
  r.c = w.center;
  r.a = unit(w.axis);
  switch (w.type) {
    case config::WallType::Cylinder:
      r.rho0 = r.rho1 = w.radius;
      r.s0 = w.bottom;
      r.s1 = w.top;
      r.rim0 = w.rim_bottom;
      r.rim1 = w.rim_top;
      break;
    case config::WallType::Cone:
      r.rho0 = w.radius_bottom;
      r.rho1 = w.radius_top;
      r.s0 = w.bottom;
      r.s1 = w.top;
      r.rim0 = w.rim_bottom;
      r.rim1 = w.rim_top;
      break;
    default:  // disk: the segment from the axis (or the hole's edge) to the rim, in the plane through center
      r.rho0 = w.inner_radius;
      r.rho1 = w.radius;
      r.s0 = r.s1 = 0.0;
      r.rim0 = w.inner_radius > 0.0;  // the hole's edge, like an orifice's rim
      r.rim1 = true;
      break;
  }
  return a;
}

// A belt mesh slides along itself: its velocity must lie in every triangle's plane, or the surface would move
// through itself (the geometry stays in place).
void check_belt_mesh(const config::WallSpec& w, size_t index, const TriangleMesh& m) {
  const double u = norm(w.surface_velocity);
  for (size_t t = 0; t < m.triangles(); ++t) {
    const double along = dot(w.surface_velocity, m.normal(static_cast<int32_t>(t)));
    if (std::abs(along) > 1e-6 * u)
      throw std::runtime_error(w.loc.str() + ": walls[" + std::to_string(index) + "].surface_velocity: has " +
                               std::to_string(along) + " m/s along the normal of triangle " + std::to_string(t) +
                               " of " + w.file + "; a mesh moves as a belt only along every one of its triangles "
                               "(a flat belt): split the belt's flat part into its own mesh");
  }
}

}  // namespace

WallSet walls_from_case(const config::CaseSpec& cs, const MaterialTable& mt) {
  WallSet walls;
  const auto set_motion = [&](int k, const config::WallSpec& w) {
    if (w.moving()) walls.set_motion(static_cast<size_t>(k), w.surface_velocity, unit(w.axis) * w.angular_velocity, w.center);
  };
  for (const auto& w : cs.walls) {
    if (w.type == config::WallType::Mesh) continue;
    set_motion(walls.add_analytic(w.name, mt.index_of(w.material), make_analytic(w)), w);
  }
  for (size_t i = 0; i < cs.walls.size(); ++i) {
    const auto& w = cs.walls[i];
    if (w.type != config::WallType::Mesh) continue;
    auto mesh = mesh_from_case(cs, w);
    if (w.moving()) check_belt_mesh(w, i, *mesh);
    const int k = walls.add_mesh(w.name, mt.index_of(w.material), std::move(mesh));
    set_motion(k, w);
    if (w.moves_rigidly()) walls.set_rigid_motion(static_cast<size_t>(k), w.move_velocity, w.move_angular_velocity, w.move_center);
  }
  return walls;
}

std::shared_ptr<const TriangleMesh> mesh_from_case(const config::CaseSpec& cs, const config::WallSpec& w) {
  const std::filesystem::path file = std::filesystem::path(cs.dir) / w.file;
  auto tris = read_stl(file.string());
  for (auto& t : tris) {
    t.a = t.a * w.scale + w.offset;
    t.b = t.b * w.scale + w.offset;
    t.c = t.c * w.scale + w.offset;
  }
  return std::make_shared<const TriangleMesh>(tris, file.string());
}

}  // namespace mlcg
