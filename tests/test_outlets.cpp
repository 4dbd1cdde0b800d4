// The scene's outlets found from its walls (scene/outlets.hpp): holes in an STL floor and a slot in an
// STL side wall, each with its position, outward normal, shape and size; the region rules judged in each
// outlet's own frame (config/region_rules.hpp): one region per outlet, a side-wall region along the
// outlet's normal, the 1.0 D0 edge; and which level each probe is read from (config/regions.hpp).
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <string>
#include <vector>

#include "config/case_parser.hpp"
#include "config/region_rules.hpp"
#include "config/regions.hpp"
#include "scene/outlets.hpp"
#include "case_parser_support.hpp"
#include "files.hpp"
#include "messages.hpp"
#include "stl_support.hpp"

namespace {

using namespace mlcg::config;
namespace fs = std::filesystem;
using mlcg::Vec3;
using mlcg::test::in_box;
using mlcg::test::plate;
using mlcg::test::Quad;
using mlcg::test::write_stl;

// ---- meshes made of square cells -------------------------------------------------------

// The meshes are written into a folder the test makes, a TempDir: per test process (ctest runs this binary's
// tests in parallel processes: a shared folder raced), removed when the test passes.
using mlcg::test::TempDir;


// A floor 0.2 x 0.1 m at z = 0 of 5 mm cells with two square holes: 3 cm at x = -0.05, 2 cm at x = 0.04.
void two_hole_floor(const fs::path& file) {
  std::vector<Quad> q;
  plate(q, {-0.1, -0.05, 0.0}, {1, 0, 0}, {0, 1, 0}, 40, 20, 0.005,
        [](int i, int j) { return in_box(i, j, 7, 13, 7, 13) || in_box(i, j, 26, 30, 8, 12); });
  write_stl(file, q);
}

// An open-topped box bin 0.1 m wide and high, of 5 mm cells, with a slot 4 cm long and 1.5 cm high at the
// foot of its +x wall (from z = 5 mm to 2 cm).
void side_slot_bin(const fs::path& file) {
  std::vector<Quad> q;
  const double h = 0.005;
  plate(q, {-0.05, -0.05, 0.0}, {0, 1, 0}, {1, 0, 0}, 20, 20, h);                       // floor
  plate(q, {-0.05, -0.05, 0.0}, {1, 0, 0}, {0, 0, 1}, 20, 20, h);                       // -y wall
  plate(q, {-0.05, 0.05, 0.0}, {0, 0, 1}, {1, 0, 0}, 20, 20, h);                        // +y wall
  plate(q, {-0.05, -0.05, 0.0}, {0, 0, 1}, {0, 1, 0}, 20, 20, h);                       // -x wall
  plate(q, {0.05, -0.05, 0.0}, {0, 1, 0}, {0, 0, 1}, 20, 20, h,                          // +x wall, the slot
        [](int i, int j) { return in_box(i, j, 6, 14, 1, 4); });
  write_stl(file, q);
}


// A case around one mesh: lids removed by event 'open', a fill above the floor, `more` appended.
std::string case_text(const std::string& mesh, const std::string& lids, const std::string& more) {
  return std::string("title = \"outlets\"\n") + case_parser_test::one_material("0.5", "0.3") + R"(
[domain]
min = [-0.12, -0.07, -0.06]
max = [0.12, 0.07, 0.12]

[[walls]]
name = "vessel"
type = "mesh"
material = "m"
file = ")" + mesh + "\"\n" + lids + R"(
[[insertion]]
name = "fill"
material = "m"
region = { type = "box", min = [-0.04, -0.04, 0.03], max = [0.04, 0.04, 0.09] }
radius = 1e-3
count = 100

[[events]]
name = "open"
at = 0.1
remove_walls = ["lid_a", "lid_b"]

[time]
end = 0.2
)" + more;
}

std::string lid(const std::string& name, Vec3 c, Vec3 axis, double r) {
  char buf[400];
  std::snprintf(buf, sizeof buf,
                "\n[[walls]]\nname = \"%s\"\ntype = \"disk\"\nmaterial = \"m\"\ncenter = [%g, %g, %g]\n"
                "axis = [%g, %g, %g]\nradius = %g\n",
                name.c_str(), c.x, c.y, c.z, axis.x, axis.y, axis.z, r);
  return buf;
}

const char* kOneLevel = "\n[[levels]]\nname = \"level0\"\nalpha = 1.0\ndt = 1e-5\n";

// The mesh is written into `d`, where the case's walls read it.
CaseSpec two_hole_case(const TempDir& d, const std::string& more) {
  two_hole_floor(d / "floor.stl");
  const std::string lids = lid("lid_a", {-0.05, 0, -0.001}, {0, 0, 1}, 0.025) + lid("lid_b", {0.04, 0, -0.001}, {0, 0, 1}, 0.018);
  const fs::path file = d / "case.toml";
  return parse_case(case_text("floor.stl", lids, more), file.string());
}

CaseSpec side_slot_case(const TempDir& d, const std::string& more) {
  side_slot_bin(d / "bin.stl");
  const std::string lids = lid("lid_a", {0.051, 0, 0.0125}, {1, 0, 0}, 0.025) + lid("lid_b", {0, 0, -0.05}, {0, 0, 1}, 0.001);
  return parse_case(case_text("bin.stl", lids, more), (d / "case.toml").string());
}

using mlcg::test::all;
using mlcg::test::has;

void expect_vec(const Vec3& got, const Vec3& want, double tol, const std::string& what) {
  EXPECT_NEAR(got.x, want.x, tol) << what;
  EXPECT_NEAR(got.y, want.y, tol) << what;
  EXPECT_NEAR(got.z, want.z, tol) << what;
}

// ---- outlets from the geometry ------------------------------------------------------------

TEST(Outlets, TwoHolesInAnStlFloorEachUnderItsLid) {
  const TempDir d("test_outlets_floor");
  const auto scan = mlcg::find_outlets(two_hole_case(d, kOneLevel));
  ASSERT_EQ(scan.outlets.size(), 2u) << all(scan.notes);
  const Outlet& a = scan.outlets[0];
  const Outlet& b = scan.outlets[1];
  expect_vec(a.center, {-0.05, 0.0, 0.0}, 1e-12, "hole a");
  expect_vec(b.center, {0.04, 0.0, 0.0}, 1e-12, "hole b");
  expect_vec(a.normal, {0, 0, -1}, 1e-12, "hole a: the flow leaves downward, away from the fill");
  expect_vec(b.normal, {0, 0, -1}, 1e-12, "hole b");
  EXPECT_NEAR(a.width, 0.03, 1e-12);
  EXPECT_NEAR(a.length, 0.03, 1e-12);
  EXPECT_NEAR(b.width, 0.02, 1e-12);
  EXPECT_EQ(a.shape, "rectangle");
  EXPECT_EQ(a.from, "lid 'lid_a' over a rectangle hole (24 edges) in mesh 'vessel'");
  EXPECT_EQ(b.from, "lid 'lid_b' over a rectangle hole (16 edges) in mesh 'vessel'");
  EXPECT_EQ(a.opened_by, "event 'open' (removes wall 'lid_a')");
  EXPECT_FALSE(scan.given);
}

TEST(Outlets, ASlotInAnStlSideWallFacesOutOfTheBin) {
  const TempDir d("test_outlets_side");
  const auto scan = mlcg::find_outlets(side_slot_case(d, kOneLevel));
  // the slot, and the tiny lid_b far below the bin (no opening under it: its own circle)
  ASSERT_EQ(scan.outlets.size(), 2u) << all(scan.notes);
  const Outlet& s = scan.outlets[0];
  expect_vec(s.center, {0.05, 0.0, 0.0125}, 1e-12, "slot");
  expect_vec(s.normal, {1, 0, 0}, 1e-12, "slot: the flow leaves sideways, out of the bin");
  EXPECT_NEAR(s.width, 0.015, 1e-12);
  EXPECT_NEAR(s.length, 0.04, 1e-12);
  EXPECT_EQ(s.shape, "slot");
  EXPECT_EQ(s.opened_by, "event 'open' (removes wall 'lid_a')");
  // the bin's open top is an opening too, facing up: named, not taken
  EXPECT_TRUE(has(scan.notes, "faces upward ([0, 0, 1]): an inlet or an open top")) << all(scan.notes);
  EXPECT_NE(scan.outlets[1].from.find("lid 'lid_b' (no opening under it"), std::string::npos) << scan.outlets[1].from;
}

TEST(Outlets, GivenOrificesReplaceTheFoundOnesAndAreNamed) {
  const TempDir d("test_outlets_floor");
  const auto cs = two_hole_case(d, std::string(kOneLevel) + R"(
[[orifices]]
name = "left"
center = [-0.05, 0.0, 0.0]
diameter = 0.03

[[orifices]]
center = [0.05, 0.0, 0.0125]
normal = [2.0, 0.0, 0.0]
width = 0.015
length = 0.04
)");
  const auto scan = mlcg::find_outlets(cs);
  ASSERT_EQ(scan.outlets.size(), 2u);
  EXPECT_TRUE(scan.given);
  EXPECT_EQ(scan.outlets[0].name, "left");
  EXPECT_EQ(scan.outlets[1].name, "orifice1");
  expect_vec(scan.outlets[1].normal, {1, 0, 0}, 0.0, "normalised");
  EXPECT_EQ(scan.outlets[1].shape, "slot");
  EXPECT_TRUE(has(scan.notes, "found in the walls, replaced")) << all(scan.notes);
  try {
    two_hole_case(d, std::string(kOneLevel) + "\n[orifice]\ncenter = [0, 0, 0]\ndiameter = 0.03\n\n[[orifices]]\n"
                                             "center = [0, 0, 0]\ndiameter = 0.02\n");
    ADD_FAILURE() << "both [orifice] and [[orifices]] accepted";
  } catch (const CaseError& e) {
    EXPECT_NE(std::string(e.what()).find("not both"), std::string::npos) << e.what();
  }
}

// ---- the region rules in each outlet's frame ---------------------------------------------

const char* kTwoFineLevels = R"(
[[levels]]
name = "coarse"
alpha = 2.0
dt = 1e-5

[[levels]]
name = "fine_a"
alpha = 1.0
dt = 1e-5

[[levels]]
name = "fine_b"
alpha = 1.0
dt = 1e-5

[[probes]]
name = "a"
point = [-0.05, 0.0, -0.01]
radius = 0.03

[[probes]]
name = "b"
point = [0.04, 0.0, -0.01]
radius = 0.02

[[probes]]
name = "between"
point = [0.01, 0.0, -0.01]
radius = 0.01

[coupling]
interval = 1e-4

[[coupling.regions]]
coarse = "coarse"
fine = "fine_a"
min = [-0.08, -0.04, -0.02]
max = [-0.02, 0.02, 0.04]
cell_size = 0.02

[[coupling.regions]]
coarse = "coarse"
fine = "fine_b"
min = [0.02, -0.02, -0.02]
max = [0.06, 0.02, 0.04]
cell_size = 0.02
)";

TEST(RegionRulesPerOutlet, OneRegionPerOutletPassesAndEachIsJudgedByItsOwn) {
  const TempDir d("test_outlets_floor");
  const CaseSpec cs = two_hole_case(d, kTwoFineLevels);
  const auto r = check_region_rules(cs, mlcg::find_outlets(cs));
  EXPECT_TRUE(r.errors.empty()) << all(r.errors);
  // region 0 against hole a (D0 3 cm, top 4 cm above it: 1.33 D0, passed), region 1 against hole b
  EXPECT_FALSE(has(r.warnings, "does not contain")) << all(r.warnings);
  EXPECT_FALSE(has(r.warnings, "orifice diameters above")) << all(r.warnings);
  // but regions side by side over one coarse level read high when shallow: region 0 (1.33 D0 over hole a) gets
  // a warning that names the height to raise its top to, and no promise; region 1 (2 D0 over hole b) neither
  EXPECT_TRUE(has(r.warnings, "coupling.regions[0].coarse: level 'coarse' is the coarse level of 2 fine regions, and "
                              "this region's top is 1.33 D0 above the orifice ('outlet0'"))
      << all(r.warnings);
  EXPECT_TRUE(has(r.warnings, "raise max z to at least 0.06 m (2 D0)")) << all(r.warnings);
  EXPECT_FALSE(has(r.warnings, "coupling.regions[1].coarse: level 'coarse' is the coarse level")) << all(r.warnings);
  EXPECT_FALSE(has(r.notes, "within about 3 %")) << all(r.notes);
  // region 0 raised to 2 D0: no warning on either
  std::string deep = kTwoFineLevels;
  deep.replace(deep.find("max = [-0.02, 0.02, 0.04]"), 25, "max = [-0.02, 0.02, 0.06]");
  const CaseSpec raised = two_hole_case(d, deep);
  const auto both = check_region_rules(raised, mlcg::find_outlets(raised));
  EXPECT_TRUE(both.errors.empty()) << all(both.errors);
  EXPECT_FALSE(has(both.warnings, "fine regions")) << all(both.warnings);
  // the same region 0 alone over its coarse level: judged by hole a, with the 3 % note
  CaseSpec one = cs;
  one.coupling->regions.pop_back();
  const auto alone = check_region_rules(one, mlcg::find_outlets(one));
  EXPECT_TRUE(has(alone.notes, "coupling.regions[0].max: the region's top is z = 0.04 m, 1.33 orifice diameters above "
                               "the orifice ('outlet0', D0 = 0.03 m"))
      << all(alone.notes);
  EXPECT_FALSE(has(alone.warnings, "fine regions")) << all(alone.warnings);
}

TEST(RegionRulesPerOutlet, EachProbeIsReadWhereAFineRegionHoldsItOrNamedBeforeStepOne) {
  const TempDir d("test_outlets_floor");
  const CaseSpec cs = two_hole_case(d, kTwoFineLevels);
  EXPECT_EQ(cs.levels[resolving_level(cs, cs.probes[0].point)].name, "fine_a");
  EXPECT_EQ(cs.levels[resolving_level(cs, cs.probes[1].point)].name, "fine_b");
  EXPECT_EQ(cs.levels[resolving_level(cs, cs.probes[2].point)].name, "coarse");
  const auto r = check_region_rules(cs, mlcg::find_outlets(cs));
  EXPECT_TRUE(has(r.warnings, "probe 'between' at [0.01, 0, -0.01] lies in no fine region, so its mass flow is read "
                              "from level 'coarse' (alpha 2)"))
      << all(r.warnings);
  // the nearer region, grown to hold it
  EXPECT_TRUE(has(r.warnings, "coupling.regions[1] would hold it with min = [0.01, -0.02, -0.02], max = [0.06, 0.02, 0.04]"))
      << all(r.warnings);
  EXPECT_FALSE(has(r.warnings, "probe 'a'")) << all(r.warnings);
  EXPECT_FALSE(has(r.warnings, "probe 'b'")) << all(r.warnings);
}

TEST(RegionRulesPerOutlet, ATopExactlyOneWidthAboveIsTheEdgeAndAccepted) {
  // region 0's top at z = 0.03 m: exactly 1.0 D0 over hole a (the 3 cm hole, not a lid's size)
  const TempDir d("test_outlets_floor");
  std::string text = kTwoFineLevels;
  text.replace(text.find("max = [-0.02, 0.02, 0.04]"), 25, "max = [-0.02, 0.02, 0.03]");
  text.replace(text.find("min = [-0.08, -0.04, -0.02]"), 27, "min = [-0.08, -0.04, -0.01]");
  const CaseSpec cs = two_hole_case(d, text);
  const auto r = check_region_rules(cs, mlcg::find_outlets(cs));
  EXPECT_TRUE(r.errors.empty()) << all(r.errors);
  EXPECT_TRUE(has(r.warnings, "1.00 orifice diameters above the orifice ('outlet0'")) << all(r.warnings);
  // a cell lower: refused, and the fix names a height above the one given
  text.replace(text.find("max = [-0.02, 0.02, 0.03]"), 25, "max = [-0.02, 0.02, 0.01]");
  const CaseSpec low = two_hole_case(d, text);
  const auto refused = check_region_rules(low, mlcg::find_outlets(low));
  ASSERT_EQ(refused.errors.size(), 1u) << all(refused.errors);
  EXPECT_NE(refused.errors[0].find("0.33 orifice diameters above"), std::string::npos) << refused.errors[0];
  EXPECT_NE(refused.errors[0].find("raise max z to at least 0.03 m"), std::string::npos) << refused.errors[0];
}

const char* kSideRegion = R"(
[[levels]]
name = "coarse"
alpha = 2.0
dt = 1e-5

[[levels]]
name = "fine"
alpha = 1.0
dt = 1e-5

[coupling]
interval = 1e-4

[[coupling.regions]]
coarse = "coarse"
fine = "fine"
min = [0.03, -0.04, 0.0]
max = [0.07, 0.04, 0.04]
cell_size = 0.02
)";

TEST(RegionRulesPerOutlet, ASideWallRegionIsJudgedAlongTheOutletsNormalAndNotVouchedFor) {
  const TempDir d("test_outlets_side");
  const CaseSpec cs = side_slot_case(d, kSideRegion);
  const auto r = check_region_rules(cs, mlcg::find_outlets(cs));
  EXPECT_TRUE(r.errors.empty()) << all(r.errors);
  // 2 cm into the bin from a 1.5 cm slot: 1.33 widths along -x; its top 1.83 widths above the slot's centre
  // would have passed the floor rule, but z is not the slot's frame
  EXPECT_TRUE(has(r.warnings, "coupling.regions[0].min: the region reaches 1.33 outlet widths into the vessel from "
                              "outlet 'outlet0'"))
      << all(r.warnings);
  EXPECT_TRUE(has(r.warnings, "along its inward normal [-1, 0, 0] (to its min x face at 0.03 m)")) << all(r.warnings);
  EXPECT_TRUE(has(r.warnings, "faces 90 degrees away from gravity")) << all(r.warnings);
  EXPECT_TRUE(has(r.warnings, "not vouched for")) << all(r.warnings);
  EXPECT_FALSE(has(r.notes, "within about 3 %")) << all(r.notes);
  // half as deep into the bin (1 cm = 0.67 widths): refused along the normal, with the fix in x
  std::string shallow = kSideRegion;
  shallow.replace(shallow.find("min = [0.03, -0.04, 0.0]"), 24, "min = [0.04, -0.04, 0.0]");
  const CaseSpec s = side_slot_case(d, shallow);
  const auto refused = check_region_rules(s, mlcg::find_outlets(s));
  ASSERT_EQ(refused.errors.size(), 1u) << all(refused.errors);
  EXPECT_NE(refused.errors[0].find("coupling.regions[0].min: the region reaches 0.67 outlet widths"), std::string::npos)
      << refused.errors[0];
  EXPECT_NE(refused.errors[0].find("lower min x to at most 0.0335 m"), std::string::npos) << refused.errors[0];
}

}  // namespace
