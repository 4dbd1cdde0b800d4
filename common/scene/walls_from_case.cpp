#include "scene/walls_from_case.hpp"

#include <filesystem>
#include <memory>

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

}  // namespace

WallSet walls_from_case(const config::CaseSpec& cs, const MaterialTable& mt) {
  WallSet walls;
  for (const auto& w : cs.walls) {
    if (w.type == config::WallType::Mesh) continue;
    walls.add_analytic(w.name, mt.index_of(w.material), make_analytic(w));
  }
  for (const auto& w : cs.walls)
    if (w.type == config::WallType::Mesh) walls.add_mesh(w.name, mt.index_of(w.material), mesh_from_case(cs, w));
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
