#pragma once
// The walls of a case as a WallSet: analytic walls first (their primitive ids
// come before the meshes'), then every STL mesh, scaled and offset. Shared by
// every level and by the coupler (which clips its grids to the geometry).
#include "config/case_spec.hpp"
#include "core/material.hpp"
#include <memory>

#include "walls/triangle_mesh.hpp"
#include "walls/wall_set.hpp"

namespace mlcg {

// Throws std::runtime_error naming the file for an unreadable or broken STL.
WallSet walls_from_case(const config::CaseSpec& cs, const MaterialTable& mt);

// One mesh wall's STL, read relative to the case's folder, scaled and offset. Throws as above.
std::shared_ptr<const TriangleMesh> mesh_from_case(const config::CaseSpec& cs, const config::WallSpec& w);

}  // namespace mlcg
