#pragma once
// Meshes made of square cells, written as ASCII STL, for scenes whose openings the tests know exactly:
// a plate of n_u x n_v cells without the cells a predicate marks (holes, slots).
#include <filesystem>
#include <fstream>
#include <functional>
#include <vector>

#include "core/vec3.hpp"

namespace mlcg::test {

struct Quad {
  Vec3 a, b, c, d;  // counter-clockwise
};

inline void plate(std::vector<Quad>& out, Vec3 origin, Vec3 u, Vec3 v, int n_u, int n_v, double h,
                  const std::function<bool(int, int)>& hole = [](int, int) { return false; }) {
  for (int i = 0; i < n_u; ++i)
    for (int j = 0; j < n_v; ++j) {
      if (hole(i, j)) continue;
      const Vec3 p = origin + (i * h) * u + (j * h) * v;
      out.push_back({p, p + h * u, p + h * u + h * v, p + h * v});
    }
}

inline void write_stl(const std::filesystem::path& file, const std::vector<Quad>& quads) {
  std::ofstream f(file);
  f.precision(17);
  auto tri = [&](const Vec3& a, const Vec3& b, const Vec3& c) {
    f << "facet normal 0 0 0\nouter loop\n";
    for (const Vec3* p : {&a, &b, &c}) f << "vertex " << p->x << " " << p->y << " " << p->z << "\n";
    f << "endloop\nendfacet\n";
  };
  f << "solid test\n";
  for (const Quad& q : quads) {
    tri(q.a, q.b, q.c);
    tri(q.a, q.c, q.d);
  }
  f << "endsolid test\n";
}

// Whether cell (i, j) lies in [i0, i1) x [j0, j1).
inline bool in_box(int i, int j, int i0, int i1, int j0, int j1) { return i >= i0 && i < i1 && j >= j0 && j < j1; }

}  // namespace mlcg::test
