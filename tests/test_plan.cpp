// `mlcg plan` (launcher/plan/plan.hpp) on a scene with two outlets far apart in an STL floor: it writes a variant
// with one fine region (and fine level) per outlet that passes the region rules, no wider across its outlet
// than whole cells need, each probe held by its outlet's fine level; it
// never overwrites a file; and on silo_small it plans the region the shipped hierarchy has.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "config/case_parser.hpp"
#include "config/region_rules.hpp"
#include "config/regions.hpp"
#include "case_parser_support.hpp"
#include "launch_support.hpp"
#include "scene/outlets.hpp"
#include "stl_support.hpp"

namespace {

using namespace launch_support;
using mlcg::Vec3;

// A floor 0.3 x 0.1 m of 5 mm cells with a 3 cm square hole at x = -0.08 and a 2 cm one at x = 0.08, each
// under a lid one event removes, plane walls around, a probe 1 cm under each hole.
fs::path two_outlet_case(const fs::path& dir) {
  fs::create_directories(dir);
  std::vector<mlcg::test::Quad> q;
  mlcg::test::plate(q, {-0.15, -0.05, 0.0}, {1, 0, 0}, {0, 1, 0}, 60, 20, 0.005, [](int i, int j) {
    return mlcg::test::in_box(i, j, 11, 17, 7, 13) || mlcg::test::in_box(i, j, 44, 48, 8, 12);
  });
  mlcg::test::write_stl(dir / "floor.stl", q);
  std::ofstream f(dir / "reference.toml");
  f << "title = \"two outlets in a flat STL floor\"\n" << case_parser_test::one_material("0.5", "0.3") << R"(
[[levels]]
name = "level0"
dt = 1e-5

[domain]
min = [-0.16, -0.07, -0.06]
max = [0.16, 0.07, 0.12]
)";
  for (const char* w : {"x_lo", "x_hi", "y_lo", "y_hi"}) {
    const std::string n(w);
    const bool x = n[0] == 'x', lo = n.substr(2) == "lo";
    const double at = (lo ? -1.0 : 1.0) * (x ? 0.15 : 0.05);
    f << "\n[[walls]]\nname = \"" << n << "\"\ntype = \"plane\"\nmaterial = \"m\"\npoint = [" << (x ? at : 0.0) << ", "
      << (x ? 0.0 : at) << ", 0.0]\nnormal = [" << (x ? (lo ? 1 : -1) : 0) << ", " << (x ? 0 : (lo ? 1 : -1))
      << ", 0]\n";
  }
  f << R"(
[[walls]]
name = "floor"
type = "mesh"
material = "m"
file = "floor.stl"

[[walls]]
name = "lid_a"
type = "disk"
material = "m"
center = [-0.08, 0.0, -0.001]
radius = 0.025

[[walls]]
name = "lid_b"
type = "disk"
material = "m"
center = [0.08, 0.0, -0.001]
radius = 0.018

[[insertion]]
name = "fill"
material = "m"
region = { type = "box", min = [-0.14, -0.04, 0.005], max = [0.14, 0.04, 0.06] }
radius = 1e-3
count = 2000

[[events]]
name = "open"
at = 0.1
remove_walls = ["lid_a", "lid_b"]

[[probes]]
name = "a"
point = [-0.08, 0.0, -0.01]
radius = 0.03

[[probes]]
name = "b"
point = [0.08, 0.0, -0.01]
radius = 0.02

[time]
end = 0.2
)";
  return dir / "reference.toml";
}

// `mlcg plan` on a shipped case (its path from the source root) into a fresh folder: the folder, the planned
// case and what the planner printed; `ok` false when it did not write the case.
struct Planned {
  fs::path dir, out;
  std::string said;
  bool ok = false;
};
Planned plan_shipped(const std::string& rel, const std::string& tag) {
  Planned p{fresh_temp_path(tag), {}, {}};
  fs::create_directories(p.dir);
  p.out = p.dir / "planned.toml";
  p.ok = run(kBin + "/mlcg plan " + kSrc + "/" + rel + " --out " + p.out.string() + " > " + p.dir.string() +
             "/plan.out 2>&1") == 0;
  p.said = slurp(p.dir / "plan.out");
  return p;
}

// The one region of a planned single-outlet case and its outlet.
struct OneRegion {
  mlcg::config::RegionBox box;
  double cell = 0.0, d0 = 0.0, outlet_z = 0.0;
};
OneRegion one_region(const Planned& p) {
  const auto v = mlcg::config::load_case(p.out.string());
  const auto outlets = mlcg::find_outlets(v).outlets;
  EXPECT_EQ(outlets.size(), 1u);
  EXPECT_EQ(v.coupling->regions.size(), 1u);
  const auto& r = v.coupling->regions.at(0);
  return {mlcg::config::region_box(r), r.cell_size, outlets.at(0).size(), outlets.at(0).center.z};
}

TEST(Plan, TwoOutletsFarApartGetOneFineRegionEachThatPassesTheRules) {
  const fs::path dir = fresh_temp_path("plan_two");
  const fs::path ref = two_outlet_case(dir), out = dir / "mlcg.toml";
  const std::string cmd = kBin + "/mlcg plan " + ref.string() + " --out " + out.string();
  ASSERT_EQ(run(cmd + " > " + dir.string() + "/plan.out 2>&1"), 0) << slurp(dir / "plan.out");
  const std::string said = slurp(dir / "plan.out");
  EXPECT_NE(said.find("expected cost:"), std::string::npos) << said;
  const auto v = mlcg::config::load_case(out.string());
  EXPECT_EQ(v.bases.size(), 1u);
  ASSERT_EQ(v.levels.size(), 3u);  // one coarse level for the scene, a fine level per region
  EXPECT_EQ(v.levels[0].alpha, 2.0);
  EXPECT_EQ(v.levels[1].alpha, 1.0);
  EXPECT_EQ(v.levels[2].alpha, 1.0);
  EXPECT_DOUBLE_EQ(v.levels[0].dt, 2e-5);  // dt scales with alpha
  ASSERT_TRUE(v.coupling);
  ASSERT_EQ(v.coupling->regions.size(), 2u) << slurp(out);
  const auto outlets = mlcg::find_outlets(v).outlets;
  ASSERT_EQ(outlets.size(), 2u);
  for (size_t r = 0; r < 2; ++r) {  // each region holds its own outlet and not the other
    const auto box = mlcg::config::region_box(v.coupling->regions[r]);
    EXPECT_TRUE(box.contains(outlets[r].center)) << "region " << r;
    EXPECT_FALSE(box.contains(outlets[1 - r].center)) << "region " << r;
    // across it: the fewest whole cells that span its half-length + 1 D0 on each side, centred on it
    const double half = 0.5 * outlets[r].length + outlets[r].size(), cell = v.coupling->regions[r].cell_size;
    // above it: regions side by side are 2 D0 deep rounded up to whole cells (shallower ones read high:
    // three_outlets' 2.5 cm outlet +3.4 % at 1.6 D0, its 3 cm outlet +5.4 % at 1.33 D0)
    const double top = box.hi.z - outlets[r].center.z;
    EXPECT_GE(top, 2.0 * outlets[r].size() - 1e-9) << "region " << r;
    EXPECT_LT(top, 2.0 * outlets[r].size() + cell - 1e-9) << "region " << r;
    for (int k : {0, 1}) {
      const double lo = box.lo[k], hi = box.hi[k], c = outlets[r].center[k];
      EXPECT_GE(hi - lo, 2.0 * half - 1e-9) << "region " << r << " axis " << k;
      EXPECT_LT(hi - lo, 2.0 * half + cell - 1e-9) << "region " << r << " axis " << k;
      EXPECT_NEAR(lo + hi, 2.0 * c, 1e-9) << "region " << r << " axis " << k;
    }
  }
  const auto rules = mlcg::config::check_region_rules(v, mlcg::find_outlets(v));
  EXPECT_TRUE(rules.errors.empty()) << rules.errors.front();
  for (const auto& w : rules.warnings) EXPECT_EQ(w.find("fine regions"), std::string::npos) << w;
  EXPECT_EQ(v.levels[mlcg::config::resolving_level(v, v.probes[0].point)].name, "fine0");
  EXPECT_EQ(v.levels[mlcg::config::resolving_level(v, v.probes[1].point)].name, "fine1");
  // never over a file
  const std::string before = slurp(out);
  EXPECT_EQ(run(cmd + " > " + dir.string() + "/again.out 2>&1"), 2);
  EXPECT_NE(slurp(dir / "again.out").find("exists; give another --out (nothing is overwritten)"), std::string::npos);
  EXPECT_EQ(slurp(out), before);
  fs::remove_all(dir);
}

// A hole in a side wall is fed from above: its region reaches 1.5 D0 above the hole's upper edge, not only
// its half-length + 1 D0 (cut to 1.17 D0 by rounding, side_outlet's discharge went from +3.2 % to +8.6 %).
TEST(Plan, ASideWallOutletsRegionReachesAboveItsUpperEdge) {
  const Planned p = plan_shipped("cases/outlets/side_outlet/reference.toml", "plan_side");
  ASSERT_TRUE(p.ok) << p.said;
  const auto v = mlcg::config::load_case(p.out.string());
  const auto outlets = mlcg::find_outlets(v).outlets;
  ASSERT_EQ(outlets.size(), 1u);
  const auto& o = outlets[0];
  ASSERT_NEAR(o.normal.x, 1.0, 1e-9);  // the hole leaves along +x, 3 cm square, centre 2 cm above the floor
  const auto box = mlcg::config::region_box(v.coupling->regions.at(0));
  EXPECT_GE(box.hi.z, o.center.z + 0.5 * o.length + 1.5 * o.size() - 1e-9);
  EXPECT_GE(o.center.x - box.lo.x, 1.5 * o.size() - 1e-9);  // 1.5 D0 into the bin along the normal
  EXPECT_NE(p.said.find("1.5 D0 above its upper edge (it is fed from above)"), std::string::npos);
  fs::remove_all(p.dir);
}

// Rounding 1.5 D0 up to whole 2 cm cells put the flat bin's region top 2 D0 above its 3 cm orifice, most of a fill
// 2.3 D0 deep: the planned run cost as much as the reference. To the nearest cell it is 1.33 D0, the height of
// the hand-written region measured within 3 % (cases/hoppers/flat_bin/mlcg.toml).
TEST(Plan, ADownwardOutletsDepthGoesToTheNearestCellNotUp) {
  const Planned p = plan_shipped("cases/hoppers/flat_bin/reference.toml", "plan_flat");
  ASSERT_TRUE(p.ok) << p.said;
  const OneRegion r = one_region(p);
  ASSERT_NEAR(r.d0, 0.03, 1e-9);
  ASSERT_NEAR(r.cell, 0.02, 1e-9);
  EXPECT_NEAR(r.box.hi.z - r.outlet_z, 0.04, 1e-9);  // 2 cells: 1.33 D0, not 3 (2 D0)
  EXPECT_NEAR(r.box.lo.z - r.outlet_z, -0.02, 1e-9);  // one cell below
  const auto shipped = mlcg::config::load_case(kSrc + "/cases/hoppers/flat_bin/mlcg.toml");
  EXPECT_NEAR(r.box.hi.z, shipped.coupling->regions.at(0).max[2], 1e-12);
  EXPECT_NE(p.said.find("to the nearest cell, at least 1.1 D0 and 2 cells"), std::string::npos);
  fs::remove_all(p.dir);
}

// The hourglass's neck (D0 4 mm, cells of 5 mm): 1.5 D0 is nearest one cell, but a region whose top cell sits
// straight over the outlet has no correction cell (it measured -17.9 %): two cells, 2.5 D0.
TEST(Plan, ANeckGetsTwoCellsAboveIt) {
  const Planned p = plan_shipped("cases/hourglass/reference.toml", "plan_neck");
  ASSERT_TRUE(p.ok) << p.said;
  const OneRegion r = one_region(p);
  ASSERT_NEAR(r.cell, 0.005, 1e-12);
  EXPECT_NEAR(r.box.hi.z - r.outlet_z, 2 * r.cell, 1e-9);
  fs::remove_all(p.dir);
}

TEST(Plan, OnSiloSmallItPlansTheShippedRegion) {
  const Planned plan = plan_shipped("cases/silo_small/reference.toml", "plan_silo");
  ASSERT_TRUE(plan.ok) << plan.said;
  const auto planned = mlcg::config::load_case(plan.out.string());
  const auto shipped = mlcg::config::load_case(kSrc + "/cases/silo_small/mlcg.toml");
  ASSERT_TRUE(planned.coupling && shipped.coupling);
  const auto& p = planned.coupling->regions.at(0);
  const auto& s = shipped.coupling->regions.at(0);
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(p.min[k], s.min[k], 1e-12) << k;
    EXPECT_NEAR(p.max[k], s.max[k], 1e-12) << k;
  }
  EXPECT_DOUBLE_EQ(p.cell_size, s.cell_size);
  EXPECT_DOUBLE_EQ(p.velocity_only_below, s.velocity_only_below);
  EXPECT_EQ(planned.levels.size(), shipped.levels.size());
  // the condition that opens the lid needs a time in a hierarchy: without a reference run, its latest
  EXPECT_NE(plan.said.find("event 'open' at its latest, t = 1.2 s"), std::string::npos);
  fs::remove_all(plan.dir);
}

}  // namespace
