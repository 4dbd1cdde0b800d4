#include "scene/outlets.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <optional>

#include "scene/walls_from_case.hpp"
#include "walls/mesh_openings.hpp"
#include "walls/triangle_mesh.hpp"

namespace mlcg {
namespace {

using config::CaseSpec;
using config::Outlet;
using config::OutletScan;
using config::WallSpec;
using config::WallType;

// Two openings within this share of the larger width are one place (a junction, or one opening twice).
constexpr double kSamePlace = 0.1;
// A wall within this share of an opening's width of its centre, in its plane, covers it (lids sit a
// millimetre or so below the opening they close).
constexpr double kCoverReach = 0.25;
// An opening whose mesh wall rises or falls from it by more than this (mean direction cosine) has a side;
// below it the wall lies flat around it (a hole in a plate).
constexpr double kSided = 0.3;
// Facing upward beyond this (cosine with gravity, below -sin 15 degrees): an inlet, not an outlet.
constexpr double kUpward = -0.26;
// A rectangle at least this many times as long as wide is a slot (cases/hoppers/wedge_slot: 30 x 45 mm);
// the tolerance keeps a mesh's rounding from turning it back into a rectangle.
constexpr double kSlotAspect = 1.5 * (1.0 - 1e-9);

struct Opening {
  Vec3 center, plane;  // plane: unit normal of its plane
  double width = 0.0, length = 0.0;
  std::string shape, what;
  int side = 0;        // +1 / -1: the wall continues to the +plane / -plane side; 0: flat around it
  size_t wall = 0;     // index into cs.walls
  bool gone = false;
};

// Which event removes each wall ("" = none).
std::map<std::string, std::string> removing_events(const CaseSpec& cs) {
  std::map<std::string, std::string> out;
  for (const auto& e : cs.events)
    for (const auto& w : e.remove_walls) out.emplace(w, e.name);
  return out;
}

void analytic_openings(const CaseSpec& cs, size_t i, std::vector<Opening>& out) {
  const WallSpec& w = cs.walls[i];
  const Vec3 a = normalized(w.axis);
  const std::string kind = w.type == WallType::Cone ? "cone" : "cylinder";
  auto end = [&](double s, double r, int side, const char* which) {
    if (r > 0.0)
      out.push_back({w.center + s * a, a, 2 * r, 2 * r, "circle",
                     fmt::format("the {} of {} '{}'", which, kind, w.name), side, i});
  };
  if (w.type == WallType::Cone) {
    end(w.bottom, w.radius_bottom, +1, "bottom");
    end(w.top, w.radius_top, -1, "top");
  } else if (w.type == WallType::Cylinder) {
    end(w.bottom, w.radius, +1, "bottom");
    end(w.top, w.radius, -1, "top");
  } else if (w.type == WallType::Disk && w.inner_radius > 0.0) {
    out.push_back({w.center, a, 2 * w.inner_radius, 2 * w.inner_radius, "circle",
                   fmt::format("the hole of disk '{}'", w.name), 0, i});
  }
}

void mesh_openings_of(const TriangleMesh& mesh, const WallSpec& w, size_t i, std::vector<Opening>& out) {
  for (const MeshOpening& m : mesh_openings(mesh)) {
    const int side = m.rise > kSided ? 1 : m.rise < -kSided ? -1 : 0;
    if (side == 0 && m.outward <= 0.0) continue;  // the outer edge of a flat plate: the mesh ends there
    const std::string shape = m.shape == MeshOpening::Shape::Rectangle && m.length >= kSlotAspect * m.width ? "slot"
                                                                                                      : m.shape_text();
    out.push_back({m.center, m.normal, m.width, m.length, shape,
                   fmt::format("a {} hole ({} edges) in mesh '{}'", shape, m.edges, w.name), side, i});
  }
}

bool parallel(const Vec3& a, const Vec3& b) { return std::abs(dot(a, b)) > 0.95; }

// A cylinder's bottom over a cone's top: the walls continue on opposite sides, both gone. One opening seen
// twice (a cone's bottom and a floor's hole of the same circle): the later one goes.
void remove_junctions(std::vector<Opening>& o) {
  for (size_t i = 0; i < o.size(); ++i)
    for (size_t j = i + 1; j < o.size(); ++j) {
      const double w = std::max(o[i].width, o[j].width);
      if (o[i].gone || o[j].gone || !parallel(o[i].plane, o[j].plane) || norm(o[i].center - o[j].center) > kSamePlace * w ||
          std::abs(o[i].width - o[j].width) > kSamePlace * w)
        continue;
      const int side_j = dot(o[i].plane, o[j].plane) > 0.0 ? o[j].side : -o[j].side;
      if (o[i].side * side_j < 0) o[i].gone = true;
      o[j].gone = true;
    }
}

// An opening with a smaller one inside it, in its plane (a barrel's bottom around a floor's hole).
void remove_narrowed(std::vector<Opening>& o) {
  std::vector<bool> narrowed(o.size(), false);
  for (size_t i = 0; i < o.size(); ++i)
    for (size_t j = 0; j < o.size() && !narrowed[i]; ++j) {
      if (i == j || o[j].gone || o[i].gone || !parallel(o[i].plane, o[j].plane) || o[j].width >= 0.9 * o[i].width)
        continue;
      const Vec3 d = o[j].center - o[i].center;
      const double off_plane = std::abs(dot(d, o[i].plane));
      narrowed[i] = off_plane <= kCoverReach * o[i].width && norm(d - dot(d, o[i].plane) * o[i].plane) <= 0.5 * o[i].width;
    }
  for (size_t i = 0; i < o.size(); ++i)
    if (narrowed[i]) o[i].gone = true;
}

Vec3 fill_point(const CaseSpec& cs) {
  if (!cs.insertions.empty()) return 0.5 * (cs.insertions.front().region.min + cs.insertions.front().region.max);
  if (!cs.particles.empty()) return cs.particles.front().position;
  return 0.5 * (cs.domain.min + cs.domain.max);
}

Vec3 outward(const Opening& o, const Vec3& fill) {
  if (o.side != 0) return -static_cast<double>(o.side) * o.plane;
  return dot(fill - o.center, o.plane) < 0.0 ? o.plane : -o.plane;
}

// Whether wall w (not o's own) closes o: a disk over its centre, a plane or a mesh through it.
bool covers(const WallSpec& w, const TriangleMesh* mesh, const Opening& o) {
  const double reach = kCoverReach * o.width;
  switch (w.type) {
    case WallType::Disk: {
      const Vec3 a = normalized(w.axis), d = o.center - w.center;
      const double r = norm(d - dot(d, a) * a);
      return parallel(a, o.plane) && std::abs(dot(d, a)) <= reach && r <= w.radius && r >= w.inner_radius;
    }
    case WallType::Plane:
      return parallel(normalized(w.normal), o.plane) && std::abs(dot(o.center - w.point, normalized(w.normal))) <= reach;
    case WallType::Mesh:
      return mesh && mesh->any_within(o.center, reach);
    default:
      return false;
  }
}

// The openings' verdicts: outlets (with what opens them) or notes on why not.
struct Verdicts {
  const CaseSpec& cs;
  const std::vector<std::shared_ptr<const TriangleMesh>>& meshes;
  std::map<std::string, std::string> removed_by;
  Vec3 fill, down;
  OutletScan& scan;
  std::vector<bool> lid_used;

  void judge(const Opening& o) {
    const Vec3 n = outward(o, fill);
    if (norm(down) > 0.0 && dot(n, down) < kUpward) {
      scan.notes.push_back(fmt::format("{} faces upward ({}): an inlet or an open top, not an outlet", o.what, config::vec_text(n)));
      return;
    }
    Outlet out{"", o.center, n, o.shape, std::min(o.width, o.length), std::max(o.width, o.length), o.what, ""};
    for (size_t w = 0; w < cs.walls.size(); ++w) {
      if (w == o.wall || !covers(cs.walls[w], meshes[w].get(), o)) continue;
      const auto ev = removed_by.find(cs.walls[w].name);
      if (ev == removed_by.end()) {
        scan.notes.push_back(fmt::format("{} is closed by wall '{}', which no event removes", o.what, cs.walls[w].name));
        return;
      }
      lid_used[w] = true;
      out.from = fmt::format("lid '{}' over {}", cs.walls[w].name, o.what);
      out.opened_by = fmt::format("event '{}' (removes wall '{}')", ev->second, cs.walls[w].name);
    }
    scan.outlets.push_back(out);
  }

  // A removed disk over no opening: its own circle is all the scene says.
  void lone_lids() {
    for (size_t w = 0; w < cs.walls.size(); ++w) {
      const WallSpec& lid = cs.walls[w];
      if (lid.type != WallType::Disk || lid_used[w] || !removed_by.count(lid.name)) continue;
      const Opening o{lid.center, normalized(lid.axis), 2 * lid.radius, 2 * lid.radius, "circle", "", 0, w};
      scan.outlets.push_back({"", lid.center, outward(o, fill), "circle", 2 * lid.radius, 2 * lid.radius,
                              fmt::format("lid '{}' (no opening under it: its own diameter)", lid.name),
                              fmt::format("event '{}' (removes wall '{}')", removed_by[lid.name], lid.name)});
    }
  }
};

std::vector<Outlet> given_outlets(const CaseSpec& cs) {
  std::vector<Outlet> out;
  for (const auto& g : cs.orifices) {
    const bool circle = g.diameter > 0.0;
    out.push_back({g.name, g.center, g.normal, circle ? "circle" : "slot", g.size(), circle ? g.diameter : g.length,
                   fmt::format("[{}] '{}' ({})", cs.orifices.size() == 1 && g.name == "orifice" ? "orifice" : "[orifices]",
                               g.name, g.loc.str()),
                   ""});
  }
  return out;
}

}  // namespace

config::OutletScan find_outlets(const CaseSpec& cs) {
  const auto removed_by = removing_events(cs);
  std::vector<std::shared_ptr<const TriangleMesh>> meshes(cs.walls.size());
  std::vector<Opening> openings;
  for (size_t i = 0; i < cs.walls.size(); ++i) {
    const WallSpec& w = cs.walls[i];
    if (w.type == WallType::Mesh) meshes[i] = mesh_from_case(cs, w);
    if (removed_by.count(w.name)) continue;  // a lid's own edges open nothing once it is gone
    if (w.type == WallType::Mesh)
      mesh_openings_of(*meshes[i], w, i, openings);
    else
      analytic_openings(cs, i, openings);
  }
  remove_junctions(openings);
  remove_narrowed(openings);
  OutletScan scan;
  const double g = norm(cs.gravity);
  Verdicts v{cs, meshes, removed_by, fill_point(cs), g > 0.0 ? cs.gravity / g : Vec3{}, scan,
             std::vector<bool>(cs.walls.size(), false)};
  for (const Opening& o : openings)
    if (!o.gone) v.judge(o);
  v.lone_lids();
  for (size_t k = 0; k < scan.outlets.size(); ++k) scan.outlets[k].name = "outlet" + std::to_string(k);
  if (cs.orifices.empty()) return scan;
  for (const Outlet& o : scan.outlets)
    scan.notes.push_back("found in the walls, replaced by the case's [orifice] / [[orifices]]: " + config::outlet_text(o));
  scan.outlets = given_outlets(cs);
  scan.given = true;
  return scan;
}

}  // namespace mlcg
