#pragma once
// Triangle-mesh wall geometry for sphere–mesh contacts.
//
// The constructor welds coincident vertices, records for every edge how many
// triangles share it and for every vertex its valence, and bins the triangles
// into a uniform grid for query(). contacts() turns the closest points of a
// set of candidate triangles into the distinct contacts of a sphere: one per
// local minimum of the distance to the mesh, so a sphere rolling over a flat or
// smoothly tessellated surface never feels seams, while convex edges/corners
// give one edge/vertex contact and concave corners one contact per face.
//
// Feature keys (Contact::feature), type in the top 2 bits:
//   face   : (1 << 62) | triangle index
//   edge   : (2 << 62) | (lo << 31) | hi      lo < hi welded vertex ids (< 2^31)
//   vertex : (3 << 62) | welded vertex id
// The mesh is double-sided: the contact normal points from the surface to the
// sphere centre on whichever side the centre is.
#include <algorithm>
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "core/vec3.hpp"
#include "walls/stl_reader.hpp"

namespace mlcg {

class TriangleMesh {
 public:
  enum FeatureType : uint32_t { kFace = 1, kEdge = 2, kVertex = 3 };
  static constexpr uint64_t face_key(uint32_t tri) { return (uint64_t(kFace) << 62) | tri; }
  static constexpr uint64_t edge_key(uint32_t v0, uint32_t v1) {
    const uint64_t lo = v0 < v1 ? v0 : v1, hi = v0 < v1 ? v1 : v0;
    return (uint64_t(kEdge) << 62) | (lo << 31) | hi;
  }
  static constexpr uint64_t vertex_key(uint32_t v) { return (uint64_t(kVertex) << 62) | v; }
  static constexpr FeatureType feature_type(uint64_t key) { return FeatureType(key >> 62); }

  // Welds vertices closer than weld_tolerance * (bounding-box diagonal) into one.
  // Throws std::runtime_error naming `name` for an empty mesh, a non-finite
  // vertex, or a degenerate triangle (given by 1-based index).
  TriangleMesh(const std::vector<RawTriangle>& tris, const std::string& name, double weld_tolerance = 1e-9);

  size_t triangles() const { return tri_.size(); }
  size_t vertices() const { return vert_.size(); }  // welded vertices
  const std::string& name() const { return name_; }
  Vec3 bbox_min() const { return bmin_; }
  Vec3 bbox_max() const { return bmax_; }

  const Vec3& vertex(uint32_t v) const { return vert_[v]; }
  std::array<uint32_t, 3> triangle_vertices(int32_t t) const { return {tri_[t].v[0], tri_[t].v[1], tri_[t].v[2]}; }
  const Vec3& normal(int32_t t) const { return tri_[t].n; }  // unit, right-hand rule of the vertex order
  uint32_t valence(uint32_t v) const { return valence_[v]; }
  // Number of triangles sharing edge k = (v[k], v[(k+1)%3]) of triangle t.
  uint32_t edge_triangles(int32_t t, int k) const { return tri_[t].eadj[k]; }

  Vec3 closest_point(int32_t tri, const Vec3& p) const;
  double distance(int32_t tri, const Vec3& p) const;  // Euclidean distance from p to triangle tri

  // Every triangle whose distance to p is < d, ascending. `out` is cleared first.
  void query(const Vec3& p, double d, std::vector<int32_t>& out) const;
  // Whether some triangle is closer to p than d (query() without the list).
  bool any_within(const Vec3& p, double d) const;
  // Every triangle whose bounding box meets the box [lo, hi], in no particular order: the candidates
  // of a segment test. `out` is cleared first.
  void query_box(const Vec3& lo, const Vec3& hi, std::vector<int32_t>& out) const;

  struct Contact {
    Vec3 point;        // closest point on the mesh surface
    Vec3 normal;       // unit vector from `point` towards p
    double dist;       // |p - point|
    int32_t owner;     // index into the candidate array of the owning triangle (lowest reporting index)
    uint64_t feature;  // feature key, see above
  };
  // Distinct contacts of the sphere (p, r) with the candidate triangles cand[0..ncand),
  // which must be distinct and include every triangle within r of p (e.g. from query()).
  // Writes at most max_out contacts, ordered by owner; returns how many were written.
  int contacts(const Vec3& p, double r, const int32_t* cand, int ncand, Contact* out, int max_out) const;

 private:
  struct Tri {
    Vec3 x[3];               // welded vertex positions
    Vec3 n;                  // unit normal
    uint32_t v[3];           // welded vertex ids
    uint32_t eadj[3];        // triangles sharing edge k = (v[k], v[k+1])
    double len[3];           // |edge k|
    double h[3];             // 2 * area / |edge k|: distance of the opposite vertex to edge k
    double tole[3];          // classification tolerance of edge k (relative to its length)
    double tolv[3];          // classification tolerance of vertex k
    Vec3 m[3];               // unit in-plane normal of edge k, pointing into the triangle
    double scale;            // longest edge
    int32_t cell_lo[3];      // first grid cell of the bounding box
  };
  struct Hit {              // per-candidate closest feature
    uint64_t key;
    double dist;
    Vec3 point;
    uint32_t need;          // reporters needed for acceptance: edge triangles / valence (1 for a face)
  };
  enum Region { kRegA, kRegB, kRegC, kRegAB, kRegBC, kRegCA, kRegFace };

  // Closest point of t to p, its Voronoi region and barycentric coordinates.
  static Vec3 closest(const Tri& t, const Vec3& p, Region& region, double bary[3]);
  Hit classify(int32_t tri, const Vec3& p) const;
  Hit face_hit(int32_t tri, const Vec3& p) const;  // p's projection onto the face of tri
  bool within(int32_t tri, const Vec3& p, double d) const;  // distance(tri, p) < d
  // visit(t) for each triangle whose bounding box meets [lo, hi], once, until it returns true;
  // returns whether one did.
  template <class Visit>
  bool visit_box(const Vec3& lo, const Vec3& hi, Visit&& visit) const;
  // The constructor's steps: welded vertices and measured triangles, then the edge and vertex topology.
  void weld_and_measure(const std::vector<RawTriangle>& tris, double weld_tolerance);
  void build_topology();
  void build_grid();

  std::string name_;
  std::vector<Tri> tri_;
  std::vector<Vec3> vert_;
  std::vector<uint32_t> valence_;
  Vec3 bmin_, bmax_;
  // Uniform bin grid: cell (i, j, k) holds grid_tris_[grid_start_[c] .. grid_start_[c+1]).
  Vec3 grid_lo_;
  double grid_h_ = 1.0;
  int32_t grid_n_[3] = {1, 1, 1};
  std::vector<int32_t> grid_start_, grid_tris_;
  std::vector<Vec3> tri_lo_, tri_hi_;  // triangle bounding boxes
  // Each triangle's plane n.x = d and its three edge lines m_k.x = e_k (m_k the inward in-plane
  // normal), apart from the large Tri records, in two cache lines: the pre-tests reject most
  // candidates with these (the records of a 4,000-triangle silo do not fit in L2).
  struct alignas(64) Plane {
    Vec3 n;
    double d;
    struct Edge {
      Vec3 m;
      double e;
    } edge[3];
    double distance(const Vec3& p) const { return dot(p, n) - d; }
    // How far p's projection lies inside the nearest edge line; negative outside the triangle, where
    // minus it is how far the projection lies outside the farthest edge line.
    double inside(const Vec3& p) const {
      double in = dot(p, edge[0].m) - edge[0].e;
      for (int k = 1; k < 3; ++k) in = std::min(in, dot(p, edge[k].m) - edge[k].e);
      return in;
    }
  };
  std::vector<Plane> plane_;
};

}  // namespace mlcg
