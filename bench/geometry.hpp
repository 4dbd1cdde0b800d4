#pragma once
// The silo of cases/silo_small as STL triangle meshes, shared by MLCG and LIGGGHTS.
#include <array>
#include <filesystem>
#include <string>
#include <vector>

namespace mlcg::bench {

struct SiloGeometry {
  double orifice_radius = 0.02;    // cone radius at z = 0
  double radius = 0.135;           // cylinder radius (cone radius at z = cone_height)
  double cone_height = 0.2;        // cone from z = 0 to here
  double top = 0.4;                // cylinder from cone_height to here (open top)
  double lid_radius = 0.03;        // disk at z = 0 closing the orifice
  int segments = 96;               // polygon sides around the axis
  double max_aspect = 4.0;         // axial ring length <= this x the local polygon side
  // Simulation box (as cases/silo_small): both codes remove particles that leave it.
  std::array<double, 3> box_min{-0.14, -0.14, -0.05};
  std::array<double, 3> box_max{0.14, 0.14, 0.41};
};

struct Triangle {
  std::array<double, 3> a, b, c;
};

std::vector<Triangle> silo_wall_triangles(const SiloGeometry& g);  // cone + cylinder
std::vector<Triangle> lid_triangles(const SiloGeometry& g);        // the disk at z = 0
// ASCII STL, written under a temporary name and renamed.
void write_stl(const std::filesystem::path& file, const std::string& solid, const std::vector<Triangle>& tris);

}  // namespace mlcg::bench
