#include "walls/triangle_mesh.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <new>
#include <stdexcept>
#include <unordered_map>

namespace mlcg {
namespace {

constexpr double kClassTol = 1e-10;  // feature classification tolerance, relative to edge lengths
constexpr double kDegenerate = 1e-12;  // |ab x ac| / max_edge^2 below this: zero area
constexpr double kOnSurface = 1e-10;   // dist / scale below this: centre on the surface
// A projection this far inside every edge line (relative to the longest edge) is in the face's region with
// no edge within kClassTol, whatever the rounding of classify's barycentric tests.
constexpr double kFaceInside = 1e-8;
constexpr int kStackCandidates = 64;

struct CellKey {
  int64_t i, j, k;
  bool operator==(const CellKey&) const = default;
};
struct CellKeyHash {
  size_t operator()(const CellKey& c) const {
    uint64_t h = uint64_t(c.i) * 0x9E3779B97F4A7C15ull;
    h ^= uint64_t(c.j) * 0xC2B2AE3D27D4EB4Full + (h << 6) + (h >> 2);
    h ^= uint64_t(c.k) * 0x165667B19E3779F9ull + (h << 6) + (h >> 2);
    return size_t(h);
  }
};

Vec3 vmin(const Vec3& a, const Vec3& b) { return {std::min(a.x, b.x), std::min(a.y, b.y), std::min(a.z, b.z)}; }
Vec3 vmax(const Vec3& a, const Vec3& b) { return {std::max(a.x, b.x), std::max(a.y, b.y), std::max(a.z, b.z)}; }

}  // namespace

TriangleMesh::TriangleMesh(const std::vector<RawTriangle>& tris, const std::string& name, double weld_tolerance)
    : name_(name) {
  if (tris.empty()) throw std::runtime_error(name + ": mesh has no triangles");
  if (tris.size() > size_t(std::numeric_limits<int32_t>::max()))
    throw std::runtime_error(name + ": too many triangles");
  bmin_ = Vec3(std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(),
               std::numeric_limits<double>::infinity());
  bmax_ = -bmin_;
  for (size_t t = 0; t < tris.size(); ++t) {
    for (const Vec3* v : {&tris[t].a, &tris[t].b, &tris[t].c}) {
      if (!finite(*v))
        throw std::runtime_error(name + ": triangle " + std::to_string(t + 1) + " has a non-finite vertex");
      bmin_ = vmin(bmin_, *v);
      bmax_ = vmax(bmax_, *v);
    }
  }
  weld_and_measure(tris, weld_tolerance);
  build_topology();
  build_grid();
}

// Vertices welded on a hash grid of cells >= the weld distance; each triangle's normal, edge lengths,
// heights and classification tolerances. A degenerate triangle (after welding) is refused.
void TriangleMesh::weld_and_measure(const std::vector<RawTriangle>& tris, double weld_tolerance) {
  const std::string& name = name_;
  const double diag = norm(bmax_ - bmin_);
  const double tol = std::max(weld_tolerance, 0.0) * diag;
  const double cell = std::max(tol, diag > 0 ? diag * 1e-12 : 1.0);
  std::unordered_map<CellKey, std::vector<uint32_t>, CellKeyHash> bins;
  auto weld = [&](const Vec3& v) -> uint32_t {
    const Vec3 r = (v - bmin_) / cell;
    const CellKey c{int64_t(std::floor(r.x)), int64_t(std::floor(r.y)), int64_t(std::floor(r.z))};
    for (int64_t di = -1; di <= 1; ++di)
      for (int64_t dj = -1; dj <= 1; ++dj)
        for (int64_t dk = -1; dk <= 1; ++dk) {
          auto it = bins.find({c.i + di, c.j + dj, c.k + dk});
          if (it == bins.end()) continue;
          for (uint32_t id : it->second)
            if (norm2(vert_[id] - v) <= tol * tol) return id;
        }
    if (vert_.size() >= (size_t(1) << 31)) throw std::runtime_error(name_ + ": too many vertices");
    vert_.push_back(v);
    bins[c].push_back(uint32_t(vert_.size() - 1));
    return uint32_t(vert_.size() - 1);
  };

  tri_.resize(tris.size());
  for (size_t i = 0; i < tris.size(); ++i) {
    Tri& t = tri_[i];
    t.v[0] = weld(tris[i].a);
    t.v[1] = weld(tris[i].b);
    t.v[2] = weld(tris[i].c);
    for (int k = 0; k < 3; ++k) t.x[k] = vert_[t.v[k]];
    const Vec3 nn = cross(t.x[1] - t.x[0], t.x[2] - t.x[0]);
    const double area2 = norm(nn);
    double lmax = 0.0;
    for (int k = 0; k < 3; ++k) {
      t.len[k] = norm(t.x[(k + 1) % 3] - t.x[k]);
      lmax = std::max(lmax, t.len[k]);
    }
    if (t.v[0] == t.v[1] || t.v[1] == t.v[2] || t.v[2] == t.v[0] || !(area2 > kDegenerate * lmax * lmax))
      throw std::runtime_error(name + ": triangle " + std::to_string(i + 1) +
                               " is degenerate (zero area relative to its edge lengths, after welding)");
    t.n = nn / area2;
    t.scale = lmax;
    for (int k = 0; k < 3; ++k) {
      t.h[k] = area2 / t.len[k];
      t.tole[k] = kClassTol * t.len[k];
      t.m[k] = cross(t.n, t.x[(k + 1) % 3] - t.x[k]) / t.len[k];
    }
  }
}

// Edge -> triangle counts, vertex valence and tolerance.
void TriangleMesh::build_topology() {
  std::unordered_map<uint64_t, uint32_t> edges;
  edges.reserve(tri_.size() * 2);
  valence_.assign(vert_.size(), 0);
  std::vector<double> vtol(vert_.size(), std::numeric_limits<double>::infinity());
  for (const Tri& t : tri_)
    for (int k = 0; k < 3; ++k) {
      ++edges[edge_key(t.v[k], t.v[(k + 1) % 3])];
      ++valence_[t.v[k]];
      // Vertex tolerance <= every incident edge tolerance, so a point not near any
      // edge is never near a vertex.
      vtol[t.v[k]] = std::min(vtol[t.v[k]], kClassTol * t.len[k]);
      vtol[t.v[(k + 1) % 3]] = std::min(vtol[t.v[(k + 1) % 3]], kClassTol * t.len[k]);
    }
  for (Tri& t : tri_)
    for (int k = 0; k < 3; ++k) {
      t.eadj[k] = edges[edge_key(t.v[k], t.v[(k + 1) % 3])];
      t.tolv[k] = vtol[t.v[k]];
    }
}

void TriangleMesh::build_grid() {
  const size_t n = tri_.size();
  tri_lo_.resize(n);
  tri_hi_.resize(n);
  plane_.resize(n);
  for (size_t i = 0; i < n; ++i) {
    const Tri& t = tri_[i];
    plane_[i].n = t.n;
    plane_[i].d = dot(t.x[0], t.n);
    for (int k = 0; k < 3; ++k) plane_[i].edge[k] = {t.m[k], dot(t.x[k], t.m[k])};
  }
  double hsum = 0.0;
  for (size_t i = 0; i < n; ++i) {
    const Tri& t = tri_[i];
    tri_lo_[i] = vmin(vmin(t.x[0], t.x[1]), t.x[2]);
    tri_hi_[i] = vmax(vmax(t.x[0], t.x[1]), t.x[2]);
    const Vec3 e = tri_hi_[i] - tri_lo_[i];
    hsum += std::max(e.x, std::max(e.y, e.z));
  }
  // Cells of half the mean triangle size, at most ~16 cells per triangle: a query about a particle
  // near the wall then visits a few triangles per cell (with cells of the whole mean size, finding the
  // wall candidates took 61 % of the rebuild time while the bench's silo fills; rebuilds 0.65 -> 0.56 s).
  const Vec3 ext = bmax_ - bmin_;
  double h = std::max(0.5 * hsum / double(n), 1e-12 * norm(ext));
  const double max_cells = 16.0 * double(n) + 64.0;
  for (;;) {
    double cells = 1.0;
    for (int a = 0; a < 3; ++a) cells *= std::max(1.0, std::ceil(ext[a] / h));
    if (cells <= max_cells) break;
    h *= 1.25;
  }
  grid_h_ = h;
  grid_lo_ = bmin_;
  for (int a = 0; a < 3; ++a) grid_n_[a] = int32_t(std::max(1.0, std::ceil(ext[a] / h)));
  const size_t ncell = size_t(grid_n_[0]) * grid_n_[1] * grid_n_[2];

  auto cell_range = [&](size_t i, int32_t lo[3], int32_t hi[3]) {
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::clamp(int32_t(std::floor((tri_lo_[i][a] - grid_lo_[a]) / h)), 0, grid_n_[a] - 1);
      hi[a] = std::clamp(int32_t(std::floor((tri_hi_[i][a] - grid_lo_[a]) / h)), 0, grid_n_[a] - 1);
    }
  };
  auto cell_index = [&](int32_t i, int32_t j, int32_t k) { return (size_t(k) * grid_n_[1] + j) * grid_n_[0] + i; };
  grid_start_.assign(ncell + 1, 0);
  int32_t lo[3], hi[3];
  for (size_t t = 0; t < n; ++t) {
    cell_range(t, lo, hi);
    for (int a = 0; a < 3; ++a) tri_[t].cell_lo[a] = lo[a];
    for (int32_t k = lo[2]; k <= hi[2]; ++k)
      for (int32_t j = lo[1]; j <= hi[1]; ++j)
        for (int32_t i = lo[0]; i <= hi[0]; ++i) ++grid_start_[cell_index(i, j, k) + 1];
  }
  for (size_t c = 0; c < ncell; ++c) grid_start_[c + 1] += grid_start_[c];
  grid_tris_.resize(size_t(grid_start_[ncell]));
  std::vector<int32_t> fill(grid_start_.begin(), grid_start_.end() - 1);
  for (size_t t = 0; t < n; ++t) {
    cell_range(t, lo, hi);
    for (int32_t k = lo[2]; k <= hi[2]; ++k)
      for (int32_t j = lo[1]; j <= hi[1]; ++j)
        for (int32_t i = lo[0]; i <= hi[0]; ++i) grid_tris_[size_t(fill[cell_index(i, j, k)]++)] = int32_t(t);
  }
}

// Closest point on a triangle by Voronoi regions (after Ericson, Real-Time
// Collision Detection, 5.1.5), also reporting the region and barycentrics.
Vec3 TriangleMesh::closest(const Tri& t, const Vec3& p, Region& region, double bary[3]) {
  const Vec3& a = t.x[0];
  const Vec3& b = t.x[1];
  const Vec3& c = t.x[2];
  const Vec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = dot(ab, ap), d2 = dot(ac, ap);
  auto set = [&](Region r, double u, double v, double w) {
    region = r;
    bary[0] = u, bary[1] = v, bary[2] = w;
  };
  if (d1 <= 0 && d2 <= 0) return set(kRegA, 1, 0, 0), a;
  const Vec3 bp = p - b;
  const double d3 = dot(ab, bp), d4 = dot(ac, bp);
  if (d3 >= 0 && d4 <= d3) return set(kRegB, 0, 1, 0), b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) {
    const double s = d1 / (d1 - d3);
    return set(kRegAB, 1 - s, s, 0), a + ab * s;
  }
  const Vec3 cp = p - c;
  const double d5 = dot(ab, cp), d6 = dot(ac, cp);
  if (d6 >= 0 && d5 <= d6) return set(kRegC, 0, 0, 1), c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) {
    const double s = d2 / (d2 - d6);
    return set(kRegCA, 1 - s, 0, s), a + ac * s;
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
    const double s = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    return set(kRegBC, 0, 1 - s, s), b + (c - b) * s;
  }
  const double inv = 1.0 / (va + vb + vc);
  const double v = vb * inv, w = vc * inv;
  set(kRegFace, 1 - v - w, v, w);
  return a + ab * v + ac * w;
}

Vec3 TriangleMesh::closest_point(int32_t tri, const Vec3& p) const {
  Region r;
  double bary[3];
  return closest(tri_[size_t(tri)], p, r, bary);
}

double TriangleMesh::distance(int32_t tri, const Vec3& p) const { return norm(p - closest_point(tri, p)); }

// Closest feature of triangle `tri` to p. Edge and vertex points are recomputed
// from the welded positions in a canonical (triangle-independent) way, so all
// triangles reporting one feature report bitwise the same point and distance.
TriangleMesh::Hit TriangleMesh::classify(int32_t tri, const Vec3& p) const {
  const Tri& t = tri_[size_t(tri)];
  Region region;
  double bary[3];
  closest(t, p, region, bary);
  int vert = -1, edge = -1;
  switch (region) {
    case kRegA: vert = 0; break;
    case kRegB: vert = 1; break;
    case kRegC: vert = 2; break;
    case kRegAB: edge = 0; break;
    case kRegBC: edge = 1; break;
    case kRegCA: edge = 2; break;
    case kRegFace: {
      // Within the tolerance of an edge -> that edge (the nearest, if several).
      double best = std::numeric_limits<double>::infinity();
      for (int k = 0; k < 3; ++k) {
        const double d = bary[(k + 2) % 3] * t.h[k];
        if (d <= t.tole[k] && d < best) best = d, edge = k;
      }
      break;
    }
  }
  if (edge >= 0) {
    int k0 = edge, k1 = (edge + 1) % 3;
    if (t.v[k1] < t.v[k0]) std::swap(k0, k1);
    const Vec3 e = t.x[k1] - t.x[k0];
    const double len = t.len[edge];
    const double s = dot(p - t.x[k0], e) / (len * len);
    if (s * len <= t.tolv[k0]) {
      vert = k0;
    } else if ((1 - s) * len <= t.tolv[k1]) {
      vert = k1;
    } else {
      const Vec3 q = t.x[k0] + e * s;
      return {edge_key(t.v[k0], t.v[k1]), norm(p - q), q, t.eadj[edge]};
    }
  }
  if (vert >= 0) {
    const Vec3& q = t.x[vert];
    return {vertex_key(t.v[vert]), norm(p - q), q, valence_[t.v[vert]]};
  }
  return face_hit(tri, p);
}

TriangleMesh::Hit TriangleMesh::face_hit(int32_t tri, const Vec3& p) const {
  const Tri& t = tri_[size_t(tri)];
  const double s = dot(p - t.x[0], t.n);
  return {face_key(uint32_t(tri)), std::abs(s), p - t.n * s, 1};
}

template <class Visit>
bool TriangleMesh::visit_box(const Vec3& lo, const Vec3& hi, Visit&& visit) const {
  int32_t c0[3], c1[3];
  for (int a = 0; a < 3; ++a) {
    if (hi[a] < bmin_[a] || lo[a] > bmax_[a]) return false;
    const double f0 = std::floor((lo[a] - grid_lo_[a]) / grid_h_);
    const double f1 = std::floor((hi[a] - grid_lo_[a]) / grid_h_);
    c0[a] = int32_t(std::clamp(f0, 0.0, double(grid_n_[a] - 1)));
    c1[a] = int32_t(std::clamp(f1, 0.0, double(grid_n_[a] - 1)));
  }
  for (int32_t k = c0[2]; k <= c1[2]; ++k)
    for (int32_t j = c0[1]; j <= c1[1]; ++j)
      for (int32_t i = c0[0]; i <= c1[0]; ++i) {
        const size_t c = (size_t(k) * grid_n_[1] + j) * grid_n_[0] + i;
        const int32_t cell[3] = {i, j, k};
        for (int32_t s = grid_start_[c]; s < grid_start_[c + 1]; ++s) {
          const int32_t t = grid_tris_[size_t(s)];
          // Visit each triangle once: in the first cell of (its cells) ∩ (the box's cells).
          const Tri& tr = tri_[size_t(t)];
          bool first = true;
          for (int a = 0; a < 3; ++a) first = first && std::max(tr.cell_lo[a], c0[a]) == cell[a];
          if (!first) continue;
          const Vec3& tlo = tri_lo_[size_t(t)];
          const Vec3& thi = tri_hi_[size_t(t)];
          if (thi.x < lo.x || thi.y < lo.y || thi.z < lo.z || tlo.x > hi.x || tlo.y > hi.y || tlo.z > hi.z) continue;
          if (visit(t)) return true;
        }
      }
  return false;
}

bool TriangleMesh::within(int32_t t, const Vec3& p, double d) const {
  // Cheap bounds first: the distance is at least the gap to the triangle's box and at least the
  // distance to its plane (with a margin, so that rounding never rejects what the exact test keeps).
  const Vec3 gap = vmax(vmax(tri_lo_[size_t(t)] - p, p - tri_hi_[size_t(t)]), Vec3());
  if (norm2(gap) >= d * d) return false;
  if (std::abs(plane_[size_t(t)].distance(p)) > d * (1.0 + 1e-9)) return false;
  return distance(t, p) < d;
}

void TriangleMesh::query(const Vec3& p, double d, std::vector<int32_t>& out) const {
  out.clear();
  if (!(d > 0)) return;
  visit_box(p - Vec3{d, d, d}, p + Vec3{d, d, d}, [&](int32_t t) {
    if (within(t, p, d)) out.push_back(t);
    return false;
  });
  std::sort(out.begin(), out.end());
}

bool TriangleMesh::any_within(const Vec3& p, double d) const {
  if (!(d > 0)) return false;
  return visit_box(p - Vec3{d, d, d}, p + Vec3{d, d, d}, [&](int32_t t) { return within(t, p, d); });
}

void TriangleMesh::query_box(const Vec3& lo, const Vec3& hi, std::vector<int32_t>& out) const {
  out.clear();
  visit_box(lo, hi, [&](int32_t t) {
    out.push_back(t);
    return false;
  });
}

int TriangleMesh::contacts(const Vec3& p, double r, const int32_t* cand, int ncand, Contact* out,
                           int max_out) const {
  if (ncand <= 0 || max_out <= 0) return 0;
  // Uninitialised stack storage (Hit holds Vec3s, whose default member
  // initialisers would otherwise zero all 64 entries on every call).
  alignas(Hit) unsigned char stack_buf[sizeof(Hit) * kStackCandidates];
  Hit* hits = reinterpret_cast<Hit*>(stack_buf);
  if (ncand > kStackCandidates) {
    thread_local std::vector<Hit> big;
    if (big.size() < size_t(ncand)) big.resize(size_t(ncand));
    hits = big.data();
  }
  // A triangle that is surely farther than r is not classified: its distance is at least
  // sqrt(plane distance^2 + o^2), o the distance of p's projection outside the farthest edge line
  // (the triangle lies inside all three). The margin keeps rounding from deciding a contact the
  // full test would find. (A sphere on one half of a split quad is beyond the other half's
  // diagonal: that half was classified at every step before.)
  const double r_far = r * (1.0 + 1e-9);
  for (int i = 0; i < ncand; ++i) {
    const Plane& b = plane_[size_t(cand[i])];
    const double plane = b.distance(p);
    bool far = std::abs(plane) > r_far;  // the plane alone first: most candidates end here
    double inside = 0.0;
    if (!far) {
      inside = b.inside(p);
      const double out = std::max(0.0, -inside);
      far = plane * plane + out * out > r_far * r_far;
    }
    if (far)
      new (&hits[i]) Hit{face_key(uint32_t(cand[i])), std::numeric_limits<double>::infinity(), Vec3{}, 1};
    else if (inside > kFaceInside * tri_[size_t(cand[i])].scale)
      new (&hits[i]) Hit(face_hit(cand[i], p));  // what classify finds there, without its region tests
    else
      new (&hits[i]) Hit(classify(cand[i], p));
  }

  int nout = 0;
  for (int i = 0; i < ncand && nout < max_out; ++i) {
    const Hit& h = hits[i];
    if (!(h.dist < r)) continue;
    if (feature_type(h.key) != kFace) {
      // Edge / vertex: a local minimum only if every triangle sharing the
      // feature has it as its closest point. Counting reporters from i onward
      // reaches `need` only at the first reporter, so it is reported once.
      uint32_t count = 1;
      for (int j = i + 1; j < ncand; ++j) count += hits[j].key == h.key && hits[j].dist < r;
      if (count != h.need) continue;
    }
    const Tri& t = tri_[size_t(cand[i])];
    Contact& c = out[nout++];
    c.point = h.point;
    c.dist = h.dist;
    c.owner = i;
    c.feature = h.key;
    if (h.dist <= kOnSurface * t.scale)
      c.normal = t.n;
    else if (feature_type(h.key) == kFace)
      c.normal = dot(p - t.x[0], t.n) >= 0 ? t.n : -t.n;
    else
      c.normal = (p - h.point) / h.dist;
  }
  return nout;
}

}  // namespace mlcg
