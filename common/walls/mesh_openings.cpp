#include "walls/mesh_openings.hpp"

#include <algorithm>
#include <cmath>
#include <map>

namespace mlcg {
namespace {

// A boundary edge: its two welded vertices and the triangle's third vertex (the side the surface is on).
struct BoundaryEdge {
  uint32_t a, b, opposite;
  bool used = false;
};

std::vector<BoundaryEdge> boundary_edges(const TriangleMesh& m) {
  std::vector<BoundaryEdge> out;
  for (size_t t = 0; t < m.triangles(); ++t) {
    const auto v = m.triangle_vertices(static_cast<int32_t>(t));
    for (int k = 0; k < 3; ++k)
      if (m.edge_triangles(static_cast<int32_t>(t), k) == 1) out.push_back({v[k], v[(k + 1) % 3], v[(k + 2) % 3]});
  }
  return out;
}

// The boundary edges in closed loops, each as edge indices in walking order. A vertex where two loops
// touch has four boundary edges; the walk takes any unused one, which still closes every loop.
std::vector<std::vector<size_t>> loops(std::vector<BoundaryEdge>& edges) {
  std::multimap<uint32_t, size_t> at;  // vertex -> its boundary edges
  for (size_t e = 0; e < edges.size(); ++e) {
    at.emplace(edges[e].a, e);
    at.emplace(edges[e].b, e);
  }
  std::vector<std::vector<size_t>> out;
  for (size_t first = 0; first < edges.size(); ++first) {
    if (edges[first].used) continue;
    std::vector<size_t> loop{first};
    edges[first].used = true;
    const uint32_t start = edges[first].a;
    uint32_t v = edges[first].b;
    while (v != start) {
      size_t next = edges.size();
      for (auto [it, end] = at.equal_range(v); it != end; ++it)
        if (!edges[it->second].used) next = it->second;
      if (next == edges.size()) break;  // an open chain (a non-manifold mesh): measured as it is
      edges[next].used = true;
      v = edges[next].a == v ? edges[next].b : edges[next].a;
      loop.push_back(next);
    }
    out.push_back(std::move(loop));
  }
  return out;
}

// The loop's vertices in walking order.
std::vector<Vec3> loop_points(const TriangleMesh& m, const std::vector<BoundaryEdge>& edges,
                              const std::vector<size_t>& loop) {
  std::vector<Vec3> p;
  uint32_t v = edges[loop.front()].a;
  for (size_t e : loop) {
    p.push_back(m.vertex(v));
    v = edges[e].a == v ? edges[e].b : edges[e].a;
  }
  return p;
}

// Plane, area and area centroid of the polygon (fan from its first vertex).
void measure_plane(const std::vector<Vec3>& p, MeshOpening& o) {
  Vec3 vector_area{};
  for (size_t i = 1; i + 1 < p.size(); ++i) vector_area += 0.5 * cross(p[i] - p[0], p[i + 1] - p[0]);
  o.area = norm(vector_area);
  o.normal = o.area > 0.0 ? vector_area / o.area : Vec3{0, 0, 1};
  Vec3 c{};
  double w = 0.0;
  for (size_t i = 1; i + 1 < p.size(); ++i) {
    const double a = 0.5 * dot(cross(p[i] - p[0], p[i + 1] - p[0]), o.normal);
    c += a * (p[0] + p[i] + p[i + 1]) / 3.0;
    w += a;
  }
  if (w > 0.0) {
    o.center = c / w;
  } else {
    for (const Vec3& q : p) o.center += q / static_cast<double>(p.size());
  }
  for (const Vec3& q : p) o.flatness = std::max(o.flatness, std::abs(dot(q - o.center, o.normal)));
}

// Round (every vertex at nearly the same distance from the centre): the diameter. Else the narrowest
// extent across any edge's direction (exact for a convex polygon) and the extent along that edge.
void measure_extents(const std::vector<Vec3>& p, MeshOpening& o) {
  double rmin = INFINITY, rmax = 0.0, rsum = 0.0;
  for (const Vec3& q : p) {
    const Vec3 d = q - o.center;
    const double r = norm(d - dot(d, o.normal) * o.normal);
    rmin = std::min(rmin, r);
    rmax = std::max(rmax, r);
    rsum += r;
  }
  if (p.size() >= 8 && rmax <= 1.05 * rmin) {
    o.shape = MeshOpening::Shape::Circle;
    o.width = o.length = 2.0 * rsum / static_cast<double>(p.size());
    return;
  }
  o.width = INFINITY;
  for (size_t i = 0; i < p.size(); ++i) {
    Vec3 along = p[(i + 1) % p.size()] - p[i];
    along -= dot(along, o.normal) * o.normal;
    if (norm(along) == 0.0) continue;
    along = normalized(along);
    const Vec3 across = cross(o.normal, along);
    double a0 = INFINITY, a1 = -INFINITY, l0 = INFINITY, l1 = -INFINITY;
    for (const Vec3& q : p) {
      a0 = std::min(a0, dot(q, across));
      a1 = std::max(a1, dot(q, across));
      l0 = std::min(l0, dot(q, along));
      l1 = std::max(l1, dot(q, along));
    }
    if (a1 - a0 < o.width) {
      o.width = a1 - a0;
      o.length = l1 - l0;
    }
  }
  if (o.width > o.length) std::swap(o.width, o.length);
  o.shape = std::abs(o.area - o.width * o.length) <= 0.02 * o.width * o.length ? MeshOpening::Shape::Rectangle
                                                                                : MeshOpening::Shape::Polygon;
}

// Which side of the loop the surface lies on: from each edge, the unit direction into its triangle.
void measure_surface(const TriangleMesh& m, const std::vector<BoundaryEdge>& edges, const std::vector<size_t>& loop,
                     MeshOpening& o) {
  double rise = 0.0, outward = 0.0, total = 0.0;
  for (size_t e : loop) {
    const Vec3 a = m.vertex(edges[e].a), b = m.vertex(edges[e].b), opp = m.vertex(edges[e].opposite);
    const double len = norm(b - a);
    if (len == 0.0) continue;
    const Vec3 t = (b - a) / len, mid = 0.5 * (a + b);
    Vec3 into = (opp - mid) - dot(opp - mid, t) * t;
    if (norm(into) == 0.0) continue;
    into = normalized(into);
    Vec3 radial = mid - o.center;
    radial -= dot(radial, o.normal) * o.normal;
    rise += len * dot(into, o.normal);
    if (norm(radial) > 0.0) outward += len * dot(into, normalized(radial));
    total += len;
  }
  if (total > 0.0) {
    o.rise = rise / total;
    o.outward = outward / total;
  }
}

}  // namespace

std::string MeshOpening::shape_text() const {
  return shape == Shape::Circle ? "circle" : shape == Shape::Rectangle ? "rectangle" : "polygon";
}

std::vector<MeshOpening> mesh_openings(const TriangleMesh& mesh) {
  auto edges = boundary_edges(mesh);
  std::vector<MeshOpening> out;
  for (const auto& loop : loops(edges)) {
    if (loop.size() < 3) continue;
    const auto p = loop_points(mesh, edges, loop);
    MeshOpening o;
    o.edges = loop.size();
    measure_plane(p, o);
    measure_extents(p, o);
    measure_surface(mesh, edges, loop, o);
    out.push_back(o);
  }
  return out;
}

}  // namespace mlcg
