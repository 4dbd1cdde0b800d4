// STL reading and sphere–triangle-mesh contact geometry.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <functional>
#include <numbers>
#include <fstream>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "files.hpp"
#include "walls/stl_reader.hpp"
#include "walls/triangle_mesh.hpp"

using namespace mlcg;
namespace fs = std::filesystem;
using Contact = TriangleMesh::Contact;
using mlcg::test::TempDir;
constexpr double kS = std::numbers::sqrt2 / 2;

namespace {

// Unit cube [0,1]^3, each face split along one diagonal, normals outward.
std::vector<RawTriangle> cube() {
  const Vec3 q[6][4] = {{{0, 0, 0}, {0, 0, 1}, {0, 1, 1}, {0, 1, 0}}, {{1, 0, 0}, {1, 1, 0}, {1, 1, 1}, {1, 0, 1}},
                        {{0, 0, 0}, {1, 0, 0}, {1, 0, 1}, {0, 0, 1}}, {{0, 1, 0}, {0, 1, 1}, {1, 1, 1}, {1, 1, 0}},
                        {{0, 0, 0}, {0, 1, 0}, {1, 1, 0}, {1, 0, 0}}, {{0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}}};
  std::vector<RawTriangle> t;
  for (auto& f : q) {
    t.push_back({f[0], f[1], f[2]});
    t.push_back({f[0], f[2], f[3]});
  }
  return t;
}

// n x n cells of size h over [0, n h]^2 at z = 0, diagonals all (i,j)-(i+1,j+1): interior valence 6.
std::vector<RawTriangle> grid(int n, double h = 1.0) {
  std::vector<RawTriangle> t;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const Vec3 p00(i * h, j * h, 0), p10((i + 1) * h, j * h, 0), p11((i + 1) * h, (j + 1) * h, 0),
          p01(i * h, (j + 1) * h, 0);
      t.push_back({p00, p10, p11});
      t.push_back({p00, p11, p01});
    }
  return t;
}

// Roof: ridge y=0, z=1 at x = -1, 0, 1; eaves z=0 at y = +-1. 8 triangles, ridge split by (0,0,1).
std::vector<RawTriangle> roof() {
  std::vector<RawTriangle> t;
  for (double side : {1.0, -1.0})
    for (int i = 0; i < 2; ++i) {
      const double x0 = i - 1.0, x1 = i;
      const Vec3 r0(x0, 0, 1), r1(x1, 0, 1), e0(x0, side, 0), e1(x1, side, 0);
      t.push_back({r0, e0, e1});
      t.push_back({r0, e1, r1});
    }
  return t;
}

std::vector<Contact> contacts_of(const TriangleMesh& m, const Vec3& p, double r) {
  std::vector<int32_t> cand;
  m.query(p, r, cand);
  std::vector<Contact> out(128);
  const int n = m.contacts(p, r, cand.data(), int(cand.size()), out.data(), int(out.size()));
  out.resize(size_t(n));
  return out;
}

void expect_vec(const Vec3& a, const Vec3& b, double tol) {
  EXPECT_NEAR(a.x, b.x, tol);
  EXPECT_NEAR(a.y, b.y, tol);
  EXPECT_NEAR(a.z, b.z, tol);
}

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "<no error>";
}

bool same(const std::vector<RawTriangle>& a, const std::vector<RawTriangle>& b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i)
    if (!(a[i].a == b[i].a && a[i].b == b[i].b && a[i].c == b[i].c)) return false;
  return true;
}

}  // namespace

TEST(StlReader, AsciiAndBinaryGiveSameCube) {
  const TempDir tmp("mesh");
  write_stl_ascii((tmp / "cube.stl").string(), cube(), "cube");
  write_stl_binary((tmp / "cube_bin.stl").string(), cube());
  EXPECT_TRUE(same(read_stl((tmp / "cube.stl").string()), cube()));
  EXPECT_TRUE(same(read_stl((tmp / "cube_bin.stl").string()), cube()));
  // Checked-in fixture: CRLF line ends, exponent notation, extra blanks.
  EXPECT_TRUE(same(read_stl(std::string(MLCG_TEST_DATA) + "/mesh/cube_ascii.stl"), cube()));
}

TEST(StlReader, BinaryStartingWithSolidIsBinary) {
  const TempDir tmp("mesh");
  const std::string f = (tmp / "solid_header.stl").string();
  write_stl_binary(f, cube(), "solid cube exported by a CAD tool");
  std::ifstream in(f, std::ios::binary);
  std::string head(5, ' ');
  in.read(head.data(), 5);
  ASSERT_EQ(head, "solid");
  EXPECT_TRUE(same(read_stl(f), cube()));
}

TEST(StlReader, TruncatedBinaryNamesExpectedAndFoundBytes) {
  const TempDir tmp("mesh");
  for (const std::string header : {"solid but binary", "plain binary"}) {
    const std::string f = (tmp / "trunc.stl").string();
    write_stl_binary(f, cube(), header);
    fs::resize_file(f, 84 + 50 * 12 - 10);
    const std::string msg = error_of([&] { read_stl(f); });
    EXPECT_NE(msg.find("trunc.stl"), std::string::npos) << msg;
    EXPECT_NE(msg.find("684"), std::string::npos) << msg;
    EXPECT_NE(msg.find("674"), std::string::npos) << msg;
  }
}

TEST(StlReader, MalformedAsciiLineNamesFileLineAndExpectation) {
  const TempDir tmp("mesh");
  const std::string f = (tmp / "bad.stl").string();
  write_stl_ascii(f, cube(), "cube");
  // Lines: 1 solid, 2 facet, 3 outer loop, 4-6 vertex, 7 endloop, 8 endfacet, 9 facet, 10 outer loop, 11 vertex...
  std::vector<std::string> lines;
  {
    std::ifstream in(f);
    for (std::string l; std::getline(in, l);) lines.push_back(l);
  }
  lines[11] = "      vertx 1 2";
  {
    std::ofstream out(f);
    for (auto& l : lines) out << l << "\n";
  }
  const std::string msg = error_of([&] { read_stl(f); });
  EXPECT_NE(msg.find("bad.stl:12:"), std::string::npos) << msg;
  EXPECT_NE(msg.find("expected 'vertex x y z'"), std::string::npos) << msg;
  EXPECT_NE(msg.find("found 'vertx 1 2'"), std::string::npos) << msg;

  // A number that does not parse is also reported on its line.
  lines[11] = "      vertex 1 2 abc";
  {
    std::ofstream out(f);
    for (auto& l : lines) out << l << "\n";
  }
  EXPECT_NE(error_of([&] { read_stl(f); }).find("bad.stl:12:"), std::string::npos);
}

TEST(StlReader, EmptyMeshIsError) {
  const TempDir tmp("mesh");
  const std::string f = (tmp / "empty.stl").string();
  {
    std::ofstream out(f);
    out << "solid nothing\nendsolid nothing\n";
  }
  EXPECT_NE(error_of([&] { read_stl(f); }).find("empty.stl"), std::string::npos);
  write_stl_binary(f, {});
  EXPECT_NE(error_of([&] { read_stl(f); }).find("no triangles"), std::string::npos);
  EXPECT_NE(error_of([&] { TriangleMesh({}, "none.stl"); }).find("none.stl"), std::string::npos);
}

TEST(TriangleMesh, DegenerateTriangleRefusedWithIndex) {
  auto t = grid(1);
  t.push_back({{0, 0, 1}, {1, 1, 1}, {2, 2, 1}});  // collinear: triangle 3
  const std::string msg = error_of([&] { TriangleMesh(t, "walls.stl"); });
  EXPECT_NE(msg.find("walls.stl"), std::string::npos) << msg;
  EXPECT_NE(msg.find("triangle 3 "), std::string::npos) << msg;
  // Two vertices closer than the weld tolerance collapse the triangle too.
  auto u = grid(1);
  u.insert(u.begin(), RawTriangle{{0, 0, 1}, {1, 0, 1}, {1 + 1e-13, 0, 1}});
  EXPECT_NE(error_of([&] { TriangleMesh(u, "w.stl"); }).find("triangle 1 "), std::string::npos);
}

TEST(TriangleMesh, WeldsCubeAndCountsTopology) {
  auto t = cube();
  t[3].b.x += 1e-12;  // below the weld tolerance (1e-9 of the diagonal)
  const TriangleMesh m(t, "cube");
  EXPECT_EQ(m.triangles(), 12u);
  EXPECT_EQ(m.vertices(), 8u);
  expect_vec(m.bbox_min(), {0, 0, 0}, 0);
  expect_vec(m.bbox_max(), {1, 1, 1}, 2e-12);
  for (int i = 0; i < 12; ++i) {
    for (int k = 0; k < 3; ++k) EXPECT_EQ(m.edge_triangles(i, k), 2u);
    // Outward normals: right-hand rule of the vertex order.
    const auto v = m.triangle_vertices(i);
    const Vec3 c = (m.vertex(v[0]) + m.vertex(v[1]) + m.vertex(v[2])) / 3.0;
    EXPECT_GT(dot(m.normal(i), c - Vec3(0.5, 0.5, 0.5)), 0.0);
  }
  const TriangleMesh g(grid(4), "grid");
  EXPECT_EQ(g.vertices(), 25u);
  uint32_t sum = 0, six = 0;
  for (uint32_t v = 0; v < g.vertices(); ++v) sum += g.valence(v), six += g.valence(v) == 6;
  EXPECT_EQ(sum, 3u * 32u);
  EXPECT_EQ(six, 9u);  // the 3 x 3 interior vertices
}

TEST(TriangleMesh, ClosestPointIsMinimalOverSamples) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int trial = 0; trial < 200; ++trial) {
    const RawTriangle t{{u(rng), u(rng), u(rng)}, {u(rng), u(rng), u(rng)}, {u(rng), u(rng), u(rng)}};
    const TriangleMesh m({t}, "one");
    const Vec3 p(2 * u(rng), 2 * u(rng), 2 * u(rng));
    const double d = m.distance(0, p);
    double best = 1e300;
    const int n = 60;
    for (int i = 0; i <= n; ++i)
      for (int j = 0; i + j <= n; ++j) {
        const double a = double(i) / n, b = double(j) / n;
        best = std::min(best, norm(p - (t.a + (t.b - t.a) * a + (t.c - t.a) * b)));
      }
    EXPECT_LE(d, best + 1e-12);
    EXPECT_GE(d, best - 0.05);  // the sample grid is within ~0.05 of every point
  }
}

// 300 random triangles of assorted sizes added to tris (a triangle soup in [0, 3]^3).
void add_soup(std::vector<RawTriangle>& tris, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(0, 1);
  for (int i = 0; i < 300; ++i) {
    const Vec3 c(3 * u(rng), 3 * u(rng), 3 * u(rng));
    const double s = 0.02 + 0.5 * u(rng) * u(rng);
    tris.push_back({c, c + Vec3(s * u(rng), s * u(rng), s * u(rng)), c + Vec3(-s * u(rng), s * u(rng), -s * u(rng))});
  }
}

TEST(TriangleMesh, QueryMatchesBruteForce) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(0, 1);
  auto tris = grid(6, 0.5);
  for (auto& t : roof()) tris.push_back({t.a + Vec3(1.5, 1.5, 0.2), t.b + Vec3(1.5, 1.5, 0.2), t.c + Vec3(1.5, 1.5, 0.2)});
  add_soup(tris, rng);
  const TriangleMesh m(tris, "soup", 0.0);
  std::vector<int32_t> got, want;
  size_t total = 0;
  for (int q = 0; q < 2000; ++q) {
    const Vec3 p(5 * u(rng) - 1, 5 * u(rng) - 1, 5 * u(rng) - 1);
    const double d = q % 100 == 0 ? 10.0 : 0.01 + 0.6 * u(rng);
    m.query(p, d, got);
    want.clear();
    for (int32_t t = 0; t < int32_t(m.triangles()); ++t)
      if (m.distance(t, p) < d) want.push_back(t);
    ASSERT_EQ(got, want) << "query " << q;
    ASSERT_EQ(m.any_within(p, d), !want.empty()) << "query " << q;
    total += got.size();
  }
  EXPECT_GT(total, 2000u);  // the test actually exercised non-empty answers
}

// query_box: exactly the triangles whose bounding boxes (from their vertices) meet the box, for thin
// boxes (the vertical segments insertion tests), flat ones and a box around everything.
TEST(TriangleMesh, QueryBoxMatchesBruteForce) {
  std::mt19937_64 rng(12);
  std::uniform_real_distribution<double> u(0, 1);
  auto tris = grid(6, 0.5);
  add_soup(tris, rng);
  const TriangleMesh m(tris, "soup", 0.0);
  std::vector<int32_t> got, want;
  size_t total = 0;
  for (int q = 0; q < 2000; ++q) {
    Vec3 lo(5 * u(rng) - 1, 5 * u(rng) - 1, 5 * u(rng) - 1), hi = lo;
    if (q % 3 == 0) hi.z += 3 * u(rng);                      // a vertical segment
    else if (q % 3 == 1) hi += Vec3(u(rng), u(rng), 0.0);    // a flat box
    else hi += Vec3(0.3 * u(rng), 0.3 * u(rng), 0.3 * u(rng));
    if (q == 0) lo = {-10, -10, -10}, hi = {10, 10, 10};
    m.query_box(lo, hi, got);
    std::sort(got.begin(), got.end());
    want.clear();
    for (int32_t t = 0; t < int32_t(m.triangles()); ++t) {
      const auto v = m.triangle_vertices(t);
      bool meets = true;
      for (int a = 0; a < 3; ++a) {
        const double mn = std::min({m.vertex(v[0])[a], m.vertex(v[1])[a], m.vertex(v[2])[a]});
        const double mx = std::max({m.vertex(v[0])[a], m.vertex(v[1])[a], m.vertex(v[2])[a]});
        meets = meets && mx >= lo[a] && mn <= hi[a];
      }
      if (meets) want.push_back(t);
    }
    ASSERT_EQ(got, want) << "box " << q;
    total += got.size();
  }
  EXPECT_GT(total, m.triangles() + 200);  // besides the box around everything, non-empty answers
}

TEST(Contacts, FaceInteriorGivesOneContact) {
  const TriangleMesh c(cube(), "cube"), s(grid(1), "square"), g(grid(4), "grid");
  auto k = contacts_of(c, {0.3, 0.6, 1.2}, 0.25);
  ASSERT_EQ(k.size(), 1u);
  EXPECT_NEAR(k[0].dist, 0.2, 1e-14);
  expect_vec(k[0].normal, {0, 0, 1}, 1e-14);
  expect_vec(k[0].point, {0.3, 0.6, 1.0}, 1e-14);
  EXPECT_EQ(TriangleMesh::feature_type(k[0].feature), TriangleMesh::kFace);
  k = contacts_of(s, {0.7, 0.2, -0.1}, 0.15);  // below the square: normal points down
  ASSERT_EQ(k.size(), 1u);
  EXPECT_NEAR(k[0].dist, 0.1, 1e-14);
  expect_vec(k[0].normal, {0, 0, -1}, 1e-14);
  k = contacts_of(g, {2.3, 1.6, 0.3}, 0.4);
  ASSERT_EQ(k.size(), 1u);
  EXPECT_NEAR(k[0].dist, 0.3, 1e-14);
  EXPECT_TRUE(contacts_of(g, {2.3, 1.6, 0.5}, 0.4).empty());  // out of reach
}

TEST(Contacts, SharedDiagonalEdgeOfSquareGivesOneContact) {
  const TriangleMesh s(grid(1), "square");
  for (double t : {0.5, 0.25, 0.9}) {
    auto k = contacts_of(s, {t, t, 0.2}, 0.3);
    ASSERT_EQ(k.size(), 1u) << t;
    EXPECT_EQ(TriangleMesh::feature_type(k[0].feature), TriangleMesh::kEdge);
    EXPECT_NEAR(k[0].dist, 0.2, 1e-14);
    expect_vec(k[0].normal, {0, 0, 1}, 1e-14);
    EXPECT_EQ(k[0].owner, 0);  // lowest candidate index among the two reporters
  }
}

TEST(Contacts, InteriorVertexOfGridGivesOneContact) {
  const TriangleMesh g(grid(4), "grid");
  auto k = contacts_of(g, {2, 2, 0.25}, 0.3);
  ASSERT_EQ(k.size(), 1u);
  ASSERT_EQ(TriangleMesh::feature_type(k[0].feature), TriangleMesh::kVertex);
  const uint32_t v = uint32_t(k[0].feature & ((uint64_t(1) << 62) - 1));
  EXPECT_EQ(g.valence(v), 6u);
  expect_vec(g.vertex(v), {2, 2, 0}, 0);
  EXPECT_NEAR(k[0].dist, 0.25, 1e-14);
  expect_vec(k[0].normal, {0, 0, 1}, 1e-14);
}

TEST(Contacts, SweepOverFlatGridAlwaysOneContact) {
  const TriangleMesh g(grid(4), "grid");
  const double r = 0.3, h = 0.9 * r;
  std::vector<Vec3> pts;
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(0.2, 3.8);
  for (int i = 0; i < 1000; ++i) pts.push_back({u(rng), u(rng), 0});
  // Seams: vertices, edge and diagonal points, nudged by amounts around the classification tolerance.
  for (double e : {0.0, 1e-16, 1e-13, 1e-11, 1e-10, 3e-10, 1e-9, 1e-6, -1e-16, -1e-13, -1e-10, -1e-9})
    for (Vec3 base : {Vec3(2, 2, 0), Vec3(1, 3, 0), Vec3(2.5, 2.5, 0), Vec3(2, 1.5, 0), Vec3(1.5, 3, 0)}) {
      pts.push_back(base + Vec3(e, 0, 0));
      pts.push_back(base + Vec3(0, e, 0));
      pts.push_back(base + Vec3(e, -e, 0));
      pts.push_back(base + Vec3(e, 0.5 * e, 0));
    }
  int n = 0;
  for (const Vec3& xy : pts)
    for (double side : {1.0, -1.0}) {
      const Vec3 p = xy + Vec3(0, 0, side * h);
      auto k = contacts_of(g, p, r);
      ASSERT_EQ(k.size(), 1u) << "at " << p.x << " " << p.y << " " << p.z;
      EXPECT_NEAR(k[0].dist, h, 1e-12);
      expect_vec(k[0].normal, {0, 0, side}, 1e-9);
      expect_vec(k[0].point, xy, 1e-9);
      ++n;
    }
  EXPECT_GT(n, 2000);
}

TEST(Contacts, SweepOverRotatedGridSeamsAlwaysOneContact) {
  // Tilted, shifted grid: seam points carry rounding error, which the classification tolerance absorbs.
  const double a = 0.7, b = 0.4;
  const Vec3 ex(std::cos(a), std::sin(a), 0), t(-std::sin(a) * std::cos(b), std::cos(a) * std::cos(b), std::sin(b));
  const Vec3 n = cross(ex, t), o(0.1234567, -3.3, 7.77);
  auto map = [&](const Vec3& q) { return o + ex * q.x + t * q.y + n * q.z; };
  auto tris = grid(4, 0.37);
  for (auto& tr : tris) tr = {map(tr.a), map(tr.b), map(tr.c)};
  const TriangleMesh g(tris, "tilted");
  const double r = 0.1, h = 0.09;
  std::mt19937_64 rng(13);
  std::uniform_real_distribution<double> u(0.15, 1.33), f(0, 1);
  for (int i = 0; i < 3000; ++i) {
    Vec3 q(u(rng), u(rng), h * (i % 2 ? 1 : -1));
    const double s = 0.37;
    if (i % 3 == 0) q.x = s * std::round(q.x / s);                // on a grid line
    if (i % 3 == 1) q.y = q.x;                                    // on a diagonal
    if (i % 5 == 0) q.x = s * std::round(q.x / s), q.y = s * std::round(q.y / s);  // on a vertex
    q.x += (f(rng) - 0.5) * 1e-10 * (i % 7 == 0);
    const Vec3 p = map(q);
    auto k = contacts_of(g, p, r);
    ASSERT_EQ(k.size(), 1u) << i;
    EXPECT_NEAR(k[0].dist, h, 1e-12);
    expect_vec(k[0].normal, n * (q.z > 0 ? 1 : -1), 1e-8);
  }
}

TEST(Contacts, MoreThan64CandidatesStillOneContact) {
  const TriangleMesh g(grid(30, 0.1), "fine");
  const Vec3 p(1.43, 1.57, 0.9);
  std::vector<int32_t> cand;
  g.query(p, 1.0, cand);
  ASSERT_GT(cand.size(), 64u);
  auto k = contacts_of(g, p, 1.0);
  ASSERT_EQ(k.size(), 1u);
  EXPECT_NEAR(k[0].dist, 0.9, 1e-13);
  k = contacts_of(g, {1.4, 1.5, 0.9}, 1.0);  // exactly above a vertex
  ASSERT_EQ(k.size(), 1u);
  EXPECT_EQ(TriangleMesh::feature_type(k[0].feature), TriangleMesh::kVertex);
}

TEST(Contacts, ConvexCubeEdgeGivesOneEdgeContact) {
  const TriangleMesh c(cube(), "cube");
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> z(0.02, 0.98), ang(0.01, 0.99);
  for (int i = 0; i < 300; ++i) {
    const double a = ang(rng) * std::numbers::pi / 2, d = 0.1;  // direction inside the outer quadrant x>1, y>1
    const Vec3 p(1 + d * std::cos(a), 1 + d * std::sin(a), i == 0 ? 0.5 : z(rng));
    auto k = contacts_of(c, p, 0.15);
    ASSERT_EQ(k.size(), 1u) << i;
    EXPECT_EQ(TriangleMesh::feature_type(k[0].feature), TriangleMesh::kEdge);
    EXPECT_NEAR(k[0].dist, d, 1e-14);
    expect_vec(k[0].normal, {std::cos(a), std::sin(a), 0}, 1e-12);
    expect_vec(k[0].point, {1, 1, p.z}, 1e-14);
  }
  auto k = contacts_of(c, {1.1, 1.1, 0.5}, 0.2);  // on the bisector
  ASSERT_EQ(k.size(), 1u);
  expect_vec(k[0].normal, {kS, kS, 0}, 1e-14);
  EXPECT_NEAR(k[0].dist, 0.1 * std::numbers::sqrt2, 1e-14);
}

TEST(Contacts, ConvexCubeCornerGivesOneVertexContact) {
  const TriangleMesh c(cube(), "cube");
  for (int corner = 0; corner < 8; ++corner) {
    const Vec3 s(corner & 1 ? 1 : -1, corner & 2 ? 1 : -1, corner & 4 ? 1 : -1);
    const Vec3 v((s.x + 1) / 2, (s.y + 1) / 2, (s.z + 1) / 2);
    const Vec3 p = v + s * 0.1 + Vec3(0.01, -0.02, 0.015) * 0.5;
    auto k = contacts_of(c, p, 0.25);
    ASSERT_EQ(k.size(), 1u) << corner;
    EXPECT_EQ(TriangleMesh::feature_type(k[0].feature), TriangleMesh::kVertex);
    expect_vec(k[0].point, v, 0);
    expect_vec(k[0].normal, normalized(p - v), 1e-14);
  }
}

TEST(Contacts, ConcaveCornerInsideCubeGivesOneContactPerFace) {
  const TriangleMesh c(cube(), "cube");
  auto k = contacts_of(c, {0.2, 0.2, 0.5}, 0.25);  // two walls
  ASSERT_EQ(k.size(), 2u);
  std::sort(k.begin(), k.end(), [](const Contact& a, const Contact& b) { return a.normal.x > b.normal.x; });
  expect_vec(k[0].normal, {1, 0, 0}, 1e-14);
  expect_vec(k[1].normal, {0, 1, 0}, 1e-14);
  for (auto& x : k) EXPECT_NEAR(x.dist, 0.2, 1e-14);
  k = contacts_of(c, {0.8, 0.2, 0.12}, 0.25);  // three walls
  ASSERT_EQ(k.size(), 3u);
  for (auto& x : k) EXPECT_EQ(TriangleMesh::feature_type(x.feature), TriangleMesh::kFace);
}

TEST(Contacts, ConvexRidgeSplitByMiddleVertexGivesOneContact) {
  const TriangleMesh m(roof(), "roof");
  auto k = contacts_of(m, {0.01, 0, 1.5}, 0.6);  // just beside the middle ridge vertex
  ASSERT_EQ(k.size(), 1u);
  EXPECT_EQ(TriangleMesh::feature_type(k[0].feature), TriangleMesh::kEdge);
  EXPECT_NEAR(k[0].dist, 0.5, 1e-14);
  expect_vec(k[0].normal, {0, 0, 1}, 1e-14);
  k = contacts_of(m, {0, 0, 1.5}, 0.6);  // exactly above it
  ASSERT_EQ(k.size(), 1u);
  EXPECT_EQ(TriangleMesh::feature_type(k[0].feature), TriangleMesh::kVertex);
  k = contacts_of(m, {0.3, 0.8, 1.0}, 0.6);  // over the y>0 slope
  ASSERT_EQ(k.size(), 1u);
  EXPECT_EQ(TriangleMesh::feature_type(k[0].feature), TriangleMesh::kFace);
  expect_vec(k[0].normal, {0, kS, kS}, 1e-14);
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<double> x(-0.9, 0.9), y(-0.45, 0.45);
  for (int i = 0; i < 500; ++i) {
    const double dx = i % 2 ? x(rng) : 1e-11 * (i - 250);
    const Vec3 p(dx, y(rng), 1.5);
    ASSERT_EQ(contacts_of(m, p, 0.8).size(), 1u) << p.x << " " << p.y;
  }
}

TEST(Contacts, CentreOnSurfaceUsesFaceNormalAndMaxOutIsRespected) {
  const TriangleMesh s(grid(1), "square");
  auto k = contacts_of(s, {0.7, 0.2, 0.0}, 0.1);
  ASSERT_EQ(k.size(), 1u);
  EXPECT_EQ(k[0].dist, 0.0);
  expect_vec(k[0].normal, {0, 0, 1}, 0);  // counter-clockwise seen from +z
  const TriangleMesh c(cube(), "cube");
  std::vector<int32_t> cand;
  c.query({0.8, 0.2, 0.15}, 0.25, cand);
  Contact out[2];
  EXPECT_EQ(c.contacts({0.8, 0.2, 0.15}, 0.25, cand.data(), int(cand.size()), out, 2), 2);
  for (auto& x : out) EXPECT_LT(x.owner, int32_t(cand.size()));
}
