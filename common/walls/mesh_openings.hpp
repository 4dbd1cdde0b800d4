#pragma once
// The openings a triangle mesh leaves: each closed loop of boundary edges (edges that belong to one
// triangle only), measured as a flat opening: its centre, plane, extents, and how the mesh's surface
// meets it (does the surface continue around the loop, as around a hole, or inside it, as inside the
// outer edge of a plate; does it rise or fall from the loop, as a funnel's wall from its bottom).
//
// Contract: geometry of one mesh only. Whether an opening is an outlet (which way the flow leaves,
// whether another wall covers it, whether an event opens it) is decided from the whole scene
// (scene/outlets.hpp). A closed mesh has no openings; loops are listed in the order their first
// boundary edge appears in the mesh's triangles.
#include <string>
#include <vector>

#include "core/vec3.hpp"
#include "walls/triangle_mesh.hpp"

namespace mlcg {

struct MeshOpening {
  enum class Shape { Circle, Rectangle, Polygon };
  Vec3 center;          // the area centroid of the loop's polygon [m]
  Vec3 normal;          // unit normal of the loop's best plane (the right-hand rule of the loop's order)
  Shape shape = Shape::Polygon;
  double width = 0.0;   // a circle's diameter; else the narrowest extent across the loop [m]
  double length = 0.0;  // a circle's diameter; else the extent along the narrowest extent's edge [m]
  double area = 0.0;    // of the loop's polygon, projected on its plane [m^2]
  double flatness = 0.0;  // the largest distance of a loop vertex from the plane [m]
  // The mean unit direction from each boundary edge into its triangle (weighted by edge length), split:
  double rise = 0.0;     // along `normal`, in [-1, 1]: > 0 the surface continues to the +normal side
  double outward = 0.0;  // away from `center` in the plane, in [-1, 1]: > 0 around a hole, < 0 inside an outer edge
  size_t edges = 0;
  std::string shape_text() const;  // "circle", "rectangle", "polygon"
};

std::vector<MeshOpening> mesh_openings(const TriangleMesh& mesh);

}  // namespace mlcg
