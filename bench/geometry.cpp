#include "geometry.hpp"

#include <cmath>
#include <fstream>
#include <numbers>
#include <stdexcept>

#include <fmt/format.h>

namespace mlcg::bench {

namespace {

using P = std::array<double, 3>;

// One ring of `segments` vertices at radius r and height z; each vertex is computed once so that
// neighbouring triangles share bit-identical coordinates.
std::vector<P> ring(double r, double z, int segments) {
  std::vector<P> v(static_cast<size_t>(segments));
  for (int i = 0; i < segments; ++i) {
    const double a = 2.0 * std::numbers::pi * i / segments;
    v[static_cast<size_t>(i)] = {r * std::cos(a), r * std::sin(a), z};
  }
  return v;
}

void band(const std::vector<P>& lo, const std::vector<P>& hi, std::vector<Triangle>& out) {
  const size_t n = lo.size();
  for (size_t i = 0; i < n; ++i) {
    const size_t j = (i + 1) % n;
    out.push_back({lo[i], lo[j], hi[j]});
    out.push_back({lo[i], hi[j], hi[i]});
  }
}

}  // namespace

std::vector<Triangle> silo_wall_triangles(const SiloGeometry& g) {
  const double side = 2.0 * std::numbers::pi / g.segments;  // polygon side per unit radius
  std::vector<Triangle> tris;
  // Cone: rings in geometric progression of the radius, so that every band's slant length is about
  // max_aspect x its polygon side (no slivers at the narrow orifice end).
  const double dr = g.radius - g.orifice_radius;
  const double slant_per_dr = std::sqrt(1.0 + (g.cone_height / dr) * (g.cone_height / dr));
  const double q = g.max_aspect * side / slant_per_dr;
  const int n_cone = std::max(1, static_cast<int>(std::ceil(std::log(g.radius / g.orifice_radius) / std::log1p(q))));
  std::vector<P> lo = ring(g.orifice_radius, 0.0, g.segments);
  for (int k = 1; k <= n_cone; ++k) {
    const double r = k == n_cone ? g.radius : g.orifice_radius * std::pow(g.radius / g.orifice_radius, double(k) / n_cone);
    const double z = k == n_cone ? g.cone_height : g.cone_height * (r - g.orifice_radius) / dr;
    std::vector<P> hi = ring(r, z, g.segments);
    band(lo, hi, tris);
    lo = std::move(hi);
  }
  // Cylinder: equal bands.
  const double h = g.top - g.cone_height;
  const int n_cyl = std::max(1, static_cast<int>(std::ceil(h / (g.max_aspect * side * g.radius))));
  for (int k = 1; k <= n_cyl; ++k) {
    const double z = k == n_cyl ? g.top : g.cone_height + h * k / n_cyl;
    std::vector<P> hi = ring(g.radius, z, g.segments);
    band(lo, hi, tris);
    lo = std::move(hi);
  }
  return tris;
}

std::vector<Triangle> lid_triangles(const SiloGeometry& g) {
  std::vector<Triangle> tris;
  const std::vector<P> rim = ring(g.lid_radius, 0.0, g.segments);
  const P c{0.0, 0.0, 0.0};
  for (size_t i = 0; i < rim.size(); ++i) tris.push_back({c, rim[i], rim[(i + 1) % rim.size()]});
  return tris;
}

void write_stl(const std::filesystem::path& file, const std::string& solid, const std::vector<Triangle>& tris) {
  const auto tmp = std::filesystem::path(file.string() + ".tmp");
  {
    std::ofstream f(tmp);
    if (!f) throw std::runtime_error("cannot write " + tmp.string());
    f << "solid " << solid << "\n";
    for (const auto& t : tris) {
      const P u{t.b[0] - t.a[0], t.b[1] - t.a[1], t.b[2] - t.a[2]};
      const P v{t.c[0] - t.a[0], t.c[1] - t.a[1], t.c[2] - t.a[2]};
      P n{u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
      const double len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
      for (auto& x : n) x = len > 0 ? x / len : 0.0;
      f << fmt::format("facet normal {:.9g} {:.9g} {:.9g}\n outer loop\n", n[0], n[1], n[2]);
      for (const P* p : {&t.a, &t.b, &t.c}) f << fmt::format("  vertex {} {} {}\n", (*p)[0], (*p)[1], (*p)[2]);
      f << " endloop\nendfacet\n";
    }
    f << "endsolid " << solid << "\n";
    if (!f) throw std::runtime_error("cannot write " + tmp.string());
  }
  std::filesystem::rename(tmp, file);
}

}  // namespace mlcg::bench
