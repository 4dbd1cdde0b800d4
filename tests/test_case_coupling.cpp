// The coupler's grids read from a case where the walls move: an open bottom under a drum's layer, and a drum
// given as a mesh turning as a whole, a mesh travelling as a whole (from_case.cpp). The grids of outlet scenes are test_coupler.cpp's.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

#include "config/case_parser.hpp"
#include "coupler.hpp"
#include "from_case.hpp"

using namespace mlcg;
using namespace mlcg::coupling;

// A fine layer over a coarse bulk (cases/drum with `open_bottom`): the bottom faces are those of the bottom
// layer's cells under which the drum goes on, none where the drum's wall closes the box's bottom; without
// open_bottom the bottom has no boundary face at all.
TEST(CaseCoupling, AnOpenBottomHasAFaceUnderEveryBottomCellTheDrumGoesOnBelow) {
  config::CaseSpec cs = config::load_case(std::string(MLCG_SOURCE_DIR) + "/cases/drum/mlcg.toml");
  auto& r = cs.coupling->regions.at(0);
  r.min = {-0.035, -0.015, -0.035};
  r.max = {0.035, 0.015, 0.005};
  r.cell_size = 0.01;
  EXPECT_EQ(coupling_from_case(cs).cfg.regions.at(0).grid.bottom_faces_size(), 0);
  r.open_bottom = true;
  const bus::CouplingGeometry geo(coupling_from_case(cs).cfg.regions.at(0).grid);
  size_t bottom = 0, bottom_cells = 0;
  for (size_t c = 0; c < geo.cells(); ++c) bottom_cells += geo.cell_lo(c).z < -0.0349;
  for (size_t f = 0; f < geo.faces(); ++f) {
    if (geo.side_of_face(f) != bus::Side::Bottom) continue;
    ++bottom;
    Vec3 lo, hi;
    geo.face_slab(f, 0.0, lo, hi);
    EXPECT_DOUBLE_EQ(lo.z, -0.035);
    // The drum (radius 4 cm about the y axis) goes on below z = -0.035 only over |x| < 1.94 cm.
    EXPECT_LT(std::min(std::fabs(lo.x), std::fabs(hi.x)), std::sqrt(0.04 * 0.04 - 0.035 * 0.035))
        << "face over x from " << lo.x << " to " << hi.x;
  }
  // The 5 columns over |x| < 2.5 cm, 3 across y; the bottom cells at x = +-3 cm lie inside the drum in part, but
  // the drum's wall closes their bottom.
  EXPECT_EQ(bottom, 15u);
  EXPECT_EQ(bottom_cells, 21u);
}

// A drum given as a mesh turning as a whole (cases/drum/mesh_mlcg.toml): the slice's cells are the same at every
// pose, so the case is accepted and the coupler gets the walls' pose for each interval's insertion; the same
// drum turning about an axis 1 cm off its own sweeps through the slice's cells and is refused, naming the region.
TEST(CaseCoupling, AMeshTurningAsAWholeTakesPartWhereTheRegionsCellsStayTheSame) {
  config::CaseSpec cs = config::load_case(std::string(MLCG_SOURCE_DIR) + "/cases/drum/mesh_mlcg.toml");
  const CaseCoupling cc = coupling_from_case(cs);
  ASSERT_TRUE(static_cast<bool>(cc.pose));
  // Posed at t = pi/3 s (a quarter turn at 1.5 rad/s, right-handed about +y: +x goes to -z), the mesh the
  // insertions are tested against is where the drum has turned.
  const int w = cc.walls->find("drum");
  ASSERT_GE(w, 0);
  cc.pose(std::numbers::pi / 3.0);
  const Vec3 far = cc.walls->info(static_cast<size_t>(w)).to_world({0.04, 0.0, 0.0});
  EXPECT_NEAR(far.x, 0.0, 1e-12);
  EXPECT_NEAR(far.z, -0.04, 1e-12);
  for (auto& wall : cs.walls)
    if (wall.name == "drum") wall.move_center = {0.01, 0.0, 0.0};
  try {
    coupling_from_case(cs);
    ADD_FAILURE() << "a drum turning off its axis was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("a mesh moving as a whole changes this region's cells"), std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("mesh_mlcg.toml:"), std::string::npos) << e.what();
  }
}

// A mesh travelling as a whole in a hierarchy (move_velocity): the regions' cells are found once, so the case is
// accepted where the mesh stays more than a cell from every region's box up to the run's end, and refused, naming
// the region and when, where it sweeps through one. The drum at rest, a second copy of its mesh 30 cm off along x stands in
// for a part moving in the coarse bulk: travelling away it is accepted (and posed where it has gone); travelling
// at the slice it reaches the region's box at t = 2.35 s (centre at x = 6.5 cm) and is refused there; a case whose
// end is no time cannot be checked and is refused.
TEST(CaseCoupling, AMeshTravellingAsAWholeTakesPartWhereItStaysAwayFromTheRegions) {
  config::CaseSpec cs = config::load_case(std::string(MLCG_SOURCE_DIR) + "/cases/drum/mesh_mlcg.toml");
  ASSERT_DOUBLE_EQ(cs.time.end, 4.0);
  config::WallSpec part;
  for (auto& w : cs.walls)
    if (w.name == "drum") {
      w.move_angular_velocity = {};  // the drum at rest: only the travelling part is posed
      part = w;
    }
  ASSERT_EQ(part.name, "drum");
  part.name = "part";
  part.offset = part.offset + Vec3{0.3, 0.0, 0.0};
  part.move_angular_velocity = {};
  part.move_center = part.offset;
  const auto with_part = [&](const Vec3& u) {
    config::CaseSpec c = cs;
    part.move_velocity = u;
    c.walls.push_back(part);
    return c;
  };
  const CaseCoupling away = coupling_from_case(with_part({0.1, 0.0, 0.0}));
  const int w = away.walls->find("part");
  ASSERT_GE(w, 0);
  away.pose(1.0);
  EXPECT_NEAR(away.walls->info(static_cast<size_t>(w)).to_world(part.offset).x, 0.4, 1e-12);
  try {
    coupling_from_case(with_part({-0.1, 0.0, 0.0}));
    ADD_FAILURE() << "a mesh travelling through the slice was accepted";
  } catch (const std::invalid_argument& e) {
    const std::string what = e.what(), at = "as it moves (at t = ";
    ASSERT_NE(what.find("a mesh moving as a whole changes this region's cells"), std::string::npos) << what;
    EXPECT_NE(what.find("mesh_mlcg.toml:"), std::string::npos) << what;
    const double t = std::stod(what.substr(what.find(at) + at.size()));
    EXPECT_GT(t, 2.3) << what;  // the part is more than a cell away before it reaches the box
    EXPECT_LT(t, 2.7) << what;
  }
  config::CaseSpec no_end = with_part({0.1, 0.0, 0.0});
  no_end.time.end = -1.0;
  no_end.time.end_event.clear();
  try {
    coupling_from_case(no_end);
    ADD_FAILURE() << "a travelling mesh in a case without an end time was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("whose end is not a time"), std::string::npos) << e.what();
  }
}
