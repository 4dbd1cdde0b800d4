// The coupling-region rules checked before step 1 (config/region_rules.hpp): the orifice
// found from the scene or [orifice], each refusal with its message, the warnings, and
// every shipped hierarchy passing. Also the walls that make an orifice: a disk with a hole.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <string>

#include "config/case_parser.hpp"
#include "config/region_rules.hpp"
#include "core/material.hpp"
#include "files.hpp"
#include "messages.hpp"
#include "scene/outlets.hpp"
#include "scene/vessel.hpp"
#include "scene/walls_from_case.hpp"

namespace {

using namespace mlcg::config;
using mlcg::test::slurp;
namespace fs = std::filesystem;

const std::string kSrc = MLCG_SOURCE_DIR;
const std::string kQuickstart = kSrc + "/cases/quickstart/mlcg.toml";

// `text` with its only occurrence of `from` replaced by `to`.
std::string edited(std::string text, const std::string& from, const std::string& to) {
  const size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << "missing: " << from;
  EXPECT_EQ(text.find(from, at + 1), std::string::npos) << "more than one: " << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

int line_of(const std::string& text, const std::string& marker) {
  const size_t at = text.find(marker);
  return 1 + static_cast<int>(std::count(text.begin(), text.begin() + static_cast<long>(at), '\n'));
}

// The quickstart hierarchy with one edit: a funnel of D0 = 24 mm at z = 0, 8 mm coarse beads,
// a region of 2 cm cells from z = -0.02 to 0.04.
std::string quickstart(const std::string& from = "", const std::string& to = "") {
  const std::string text = slurp(kQuickstart);
  return from.empty() ? text : edited(text, from, to);
}

RegionRuleReport rules(const CaseSpec& cs) {
  return check_region_rules(cs, mlcg::find_outlets(cs), mlcg::vessel_crossing(cs));
}
RegionRuleReport rules_of(const std::string& text) { return rules(parse_case(text, kQuickstart)); }
std::vector<Outlet> outlets_of(const CaseSpec& cs) { return mlcg::find_outlets(cs).outlets; }

using mlcg::test::all;
using mlcg::test::has;

// ---- the orifice --------------------------------------------------------------------

TEST(RegionRules, OrificeIsTheConeUnderTheLid) {  // silo_small: a 6 cm lid over the cone's 4 cm opening
  const auto all = outlets_of(load_case(kSrc + "/cases/silo_small/mlcg.toml"));
  ASSERT_EQ(all.size(), 1u);  // the cylinder's bottom on the cone's top is a junction, their tops open upward
  const Outlet& o = all[0];
  EXPECT_DOUBLE_EQ(o.size(), 0.04);
  EXPECT_DOUBLE_EQ(o.center.z, 0.0);
  EXPECT_DOUBLE_EQ(o.normal.z, -1.0);
  EXPECT_EQ(o.from, "lid 'lid' over the bottom of cone 'cone'");
  EXPECT_EQ(o.opened_by, "event 'open' (removes wall 'lid')");
}

TEST(RegionRules, OrificeIsTheHoleOfAFlatFloor) {  // an annulus with an off-centre hole, the lid 1 mm below
  const auto all = outlets_of(load_case(kSrc + "/cases/hoppers/offcentre_bin/mlcg.toml"));
  ASSERT_EQ(all.size(), 1u);  // the barrel's bottom is narrowed to the floor's hole
  EXPECT_DOUBLE_EQ(all[0].size(), 0.03);
  EXPECT_DOUBLE_EQ(all[0].center.x, 0.02);
  EXPECT_DOUBLE_EQ(all[0].normal.z, -1.0);  // a hole in a flat floor: away from the fill above it
  EXPECT_EQ(all[0].from, "lid 'lid' over the hole of disk 'floor'");
}

TEST(RegionRules, OrificeKeyWinsOverTheLid) {  // the slot under a round lid, given by hand
  const std::string ref = kSrc + "/cases/hoppers/wedge_slot/reference.toml";
  const auto scan = mlcg::find_outlets(
      parse_case(slurp(ref) + "\n[orifice]\ncenter = [0.0, 0.0, 0.0]\nwidth = 0.03\nlength = 0.045\n", ref));
  ASSERT_EQ(scan.outlets.size(), 1u);
  EXPECT_TRUE(scan.given);
  EXPECT_DOUBLE_EQ(scan.outlets[0].size(), 0.03);  // the slot's width, not the lid's 6 cm
  EXPECT_NE(scan.outlets[0].from.find("[orifice]"), std::string::npos) << scan.outlets[0].from;
  // the walls say the same: the mesh's slot under the lid
  EXPECT_TRUE(has(scan.notes, "found in the walls, replaced by the case's [orifice] / [[orifices]]: outlet0: "
                              "slot 0.03 x 0.045 m (D0 = its width) at [0, 0, 0], flow leaves along [0, 0, -1], from lid "
                              "'lid' over a slot hole (4 edges) in mesh 'hopper'"))
      << all(scan.notes);
}

TEST(RegionRules, AnOpeningALidNeverLeavesIsClosedAndAnOpenOneIsAnOutlet) {
  CaseSpec cs = parse_case(quickstart(), kQuickstart);
  cs.events.clear();  // the lid stays: the funnel's bottom is closed
  const auto closed = mlcg::find_outlets(cs);
  EXPECT_TRUE(closed.outlets.empty());
  EXPECT_TRUE(has(closed.notes, "the bottom of cone 'funnel' is closed by wall 'lid', which no event removes"))
      << all(closed.notes);
  cs.walls.erase(std::find_if(cs.walls.begin(), cs.walls.end(), [](const WallSpec& w) { return w.name == "lid"; }));
  const auto open = outlets_of(cs);  // no lid at all: open from the start
  ASSERT_EQ(open.size(), 1u);
  EXPECT_DOUBLE_EQ(open[0].size(), 0.024);
  EXPECT_EQ(open[0].from, "the bottom of cone 'funnel'");
  EXPECT_EQ(open[0].opened_by, "");
}

TEST(RegionRules, NoOrificeSkipsTheOrificeRulesWithANote) {
  CaseSpec cs = parse_case(quickstart("max = [0.04, 0.04, 0.04]", "max = [0.04, 0.04, 0.0]"), kQuickstart);
  cs.events.clear();
  cs.walls.erase(cs.walls.begin(), cs.walls.begin() + 2);  // no barrel, no funnel: no opening (the lid stays)
  EXPECT_TRUE(outlets_of(cs).empty());
  const auto r = rules(cs);
  EXPECT_TRUE(r.errors.empty()) << all(r.errors);  // a top at the orifice's height is not refused without one
  EXPECT_TRUE(has(r.notes, "no outlet found")) << all(r.notes);
  EXPECT_TRUE(has(r.notes, "give [orifice]"));
}

TEST(RegionRules, ARegionInADrumWithNoOutletIsRefusedNamingTheMovingWallUnlessItReachesBelowTheWalls) {
  // The bulk of a drum circulates through a region's faces; the coupling hands over its top and sides only.
  const std::string path = kSrc + "/cases/drum/mlcg_rules_test.toml";  // never written: the base resolves beside it
  const std::string text = "base = \"reference.toml\"\n[[levels]]\nname = \"coarse\"\nalpha = 2.0\ndt = 1e-5\n"
                           "[[levels]]\nname = \"fine\"\nalpha = 1.0\ndt = 5e-6\n[coupling]\n[[coupling.regions]]\n"
                           "coarse = \"coarse\"\nfine = \"fine\"\nmin = [-0.04, -0.0125, -0.02]\n"
                           "max = [0.04, 0.0125, 0.01]\ncell_size = 0.016\n";
  CaseSpec cs = parse_case(text, path);
  auto r = rules(cs);
  ASSERT_EQ(r.errors.size(), 1u) << all(r.errors);
  EXPECT_TRUE(has(r.errors, path + ":" + std::to_string(line_of(text, "min = ")) +
                                ": coupling.regions[0].min: the scene has no outlet and wall 'drum' moves"))
      << all(r.errors);
  // A slice through the bed from below the drum: entered and left through its sides only, accepted.
  auto& slice = cs.coupling->regions[0];
  slice.min = {-0.015, -0.015, -0.045};
  slice.max = {0.015, 0.015, 0.03};
  slice.cell_size = 0.015;
  r = rules(cs);
  EXPECT_TRUE(r.errors.empty()) << all(r.errors);
  EXPECT_TRUE(has(r.warnings, "the region is a slice through the bed")) << all(r.warnings);
  EXPECT_TRUE(has(r.warnings, "no accuracy is promised")) << all(r.warnings);
  slice.min.z = -0.03;  // its bottom 1 cm above the drum's lowest point: inside the vessel again
  r = rules(cs);
  EXPECT_TRUE(has(r.errors, "this region's bottom (z = -0.03 m) lies inside the vessel")) << all(r.errors);
  slice.open_bottom = true;  // the bottom handed over like the sides: refused, with what was measured
  r = rules(cs);
  ASSERT_EQ(r.errors.size(), 1u) << all(r.errors);
  EXPECT_TRUE(has(r.errors, "coupling.regions[0].open_bottom: an open bottom is not supported yet")) << all(r.errors);
  EXPECT_TRUE(has(r.errors, "11 deg flatter")) << all(r.errors);
  slice.open_bottom = false;
  for (auto& w : cs.walls) w.angular_velocity = 0.0;  // the same closed drum at rest: a note, as before
  r = rules(cs);
  EXPECT_TRUE(r.errors.empty()) << all(r.errors);
  EXPECT_TRUE(has(r.notes, "no outlet found"));
}

// ---- across the outlet ----------------------------------------------------------------

// offcentre_bin: a 3 cm hole at x = 2 cm in the floor of a bin of radius 4.5 cm; its region reaches 0.5 D0
// past the hole's rim across y (measured -1.9 %), and the bin's wall on +x.
TEST(RegionRules, ARegionShortOfTheMarginAcrossItsOutletInsideTheVesselIsWarnedOfAndPromisedNothing) {
  const std::string file = kSrc + "/cases/hoppers/offcentre_bin/mlcg.toml";
  const auto shipped = rules(load_case(file));
  EXPECT_FALSE(has(shipped.warnings, "past the rim")) << all(shipped.warnings);
  EXPECT_TRUE(has(shipped.notes, "expect the discharge through 'outlet0' within about 3 %")) << all(shipped.notes);
  // 0.17 D0 past the rim toward -y and +y, where the bin goes on to |y| = 4 cm
  std::string text = edited(slurp(file), "min = [-0.02, -0.03, -0.02]", "min = [-0.02, -0.02, -0.02]");
  text = edited(text, "max = [0.06, 0.03, 0.04]", "max = [0.06, 0.02, 0.04]");
  const auto narrow = rules(parse_case(text, file));
  EXPECT_TRUE(narrow.errors.empty()) << all(narrow.errors);
  EXPECT_TRUE(has(narrow.warnings, "coupling.regions[0].min: the region reaches 0.17 outlet widths past the rim of "
                                   "outlet 'outlet0'")) << all(narrow.warnings);
  EXPECT_TRUE(has(narrow.warnings, "coupling.regions[0].max: the region reaches 0.17 outlet widths past the rim"));
  EXPECT_TRUE(has(narrow.warnings, "widen the region to hold [0.02, 0.03, 0.015]")) << all(narrow.warnings);
  EXPECT_FALSE(has(narrow.notes, "expect the discharge")) << all(narrow.notes);
  // wedge_slot's region stops 0.25 W0 past the slot's ends, where the end walls close the vessel: no warning.
  const auto wedge = rules(load_case(kSrc + "/cases/hoppers/wedge_slot/mlcg.toml"));
  EXPECT_FALSE(has(wedge.warnings, "past the rim")) << all(wedge.warnings);
}

// ---- refusals -----------------------------------------------------------------------

TEST(RegionRules, RefusesAnOpenBottomUnderARegionThatHoldsAnOutlet) {
  // The quickstart's region around its funnel's outlet: what leaves through the outlet sinks through the
  // region's bottom, which an open bottom would hand back to the coarse level.
  const std::string text = quickstart("cell_size = 0.02", "cell_size = 0.02\nopen_bottom = true");
  const auto r = rules_of(text);
  EXPECT_TRUE(has(r.errors, kQuickstart + ":" + std::to_string(line_of(text, "open_bottom = true")) +
                                ": coupling.regions[0].open_bottom: the region holds outlet 'outlet0'"))
      << all(r.errors);
  EXPECT_TRUE(rules_of(quickstart()).errors.empty());
}

TEST(RegionRules, RefusesATopTooCloseAboveTheOrifice) {
  const std::string text = quickstart("max = [0.04, 0.04, 0.04]", "max = [0.04, 0.04, 0.02]");
  const auto r = rules_of(text);
  ASSERT_EQ(r.errors.size(), 1u) << all(r.errors);
  const std::string& e = r.errors[0];
  const std::string where = kQuickstart + ":" + std::to_string(line_of(text, "max = [0.04, 0.04, 0.02]")) +
                            ": coupling.regions[0].max: ";
  EXPECT_EQ(e.substr(0, where.size()), where) << e;
  EXPECT_NE(e.find("z = 0.02 m, 0.83 orifice diameters above the orifice ('outlet0', D0 = 0.024 m, from lid 'lid' "
                   "over the bottom of cone 'funnel')"),
            std::string::npos)
      << e;
  EXPECT_NE(e.find("at least 1 D0"), std::string::npos) << e;
  EXPECT_NE(e.find("raise max z to at least 0.024 m"), std::string::npos) << e;
}

TEST(RegionRules, WarnsOfATopOneCellAboveTheOrifice) {  // 1.25 D0 passes the D0 rule; one 3 cm cell does not
  const std::string text = quickstart("min = [-0.04, -0.04, -0.02]\nmax = [0.04, 0.04, 0.04]\ncell_size = 0.02",
                                      "min = [-0.045, -0.045, -0.03]\nmax = [0.045, 0.045, 0.03]\ncell_size = 0.03");
  const auto r = rules_of(text);
  EXPECT_TRUE(r.errors.empty()) << all(r.errors);
  const std::string where = kQuickstart + ":" + std::to_string(line_of(text, "max = [0.045, 0.045, 0.03]")) +
                            ": coupling.regions[0].max: the region's top is z = 0.03 m, 1.00 cells of 0.03 m above "
                            "the orifice";
  EXPECT_TRUE(has(r.warnings, where)) << all(r.warnings);
  EXPECT_TRUE(has(r.warnings, "with one cell there is no correction cell")) << all(r.warnings);
  EXPECT_TRUE(has(r.warnings, "raise max z to 0.06 m or use smaller cells")) << all(r.warnings);
  EXPECT_FALSE(has(r.notes, "expect the discharge")) << all(r.notes);
}

TEST(RegionRules, WarnsOfATopFewerCellsAboveTheOrificeThanMeasured) {  // 1.5 cells: above 1, below the 1.8 measured
  const auto r = rules_of(quickstart("min = [-0.04, -0.04, -0.02]\nmax = [0.04, 0.04, 0.04]\ncell_size = 0.02",
                                     "min = [-0.04, -0.04, -0.01]\nmax = [0.04, 0.04, 0.03]\ncell_size = 0.02"));
  EXPECT_TRUE(r.errors.empty()) << all(r.errors);
  EXPECT_TRUE(has(r.warnings, "1.50 cells of 0.02 m above the orifice")) << all(r.warnings);
  EXPECT_TRUE(has(r.warnings, "below the advised 1.8 cells no accuracy is promised")) << all(r.warnings);
  EXPECT_FALSE(has(r.notes, "expect the discharge")) << all(r.notes);
}

TEST(RegionRules, TopIsTheRoundedUpCellBoundary) {  // max z 0.021 rounds up to 0.04: 1.67 D0, accepted
  const auto r = rules_of(quickstart("max = [0.04, 0.04, 0.04]", "max = [0.04, 0.04, 0.021]"));
  EXPECT_FALSE(has(r.errors, "orifice diameters above")) << all(r.errors);
}

TEST(RegionRules, RefusesCellsTooSmallForTheCoarseParticles) {
  const std::string text = quickstart("cell_size = 0.02\nvelocity_only_below", "cell_size = 0.015\nvelocity_only_below");
  const auto r = rules_of(text);
  ASSERT_EQ(r.errors.size(), 1u) << all(r.errors);
  const std::string where = kQuickstart + ":" + std::to_string(line_of(text, "cell_size = 0.015")) +
                            ": coupling.regions[0].cell_size: ";
  EXPECT_EQ(r.errors[0].substr(0, where.size()), where) << r.errors[0];
  EXPECT_NE(r.errors[0].find("1.88 coarse diameters of level 'coarse': alpha 2 x the largest insertion diameter 4 mm "
                             "= 8 mm"),
            std::string::npos)
      << r.errors[0];
  EXPECT_NE(r.errors[0].find("give cell_size >= 0.016 m"), std::string::npos) << r.errors[0];
}

TEST(RegionRules, RefusesACoarseLevelThatCannotPassAnOrificeOutsideTheRegion) {
  // The region lifted off the orifice: 8 mm coarse beads through 24 mm (D0 / d = 3) on their own.
  const std::string text = quickstart("min = [-0.04, -0.04, -0.02]", "min = [-0.04, -0.04, 0.005]");
  const auto r = rules_of(text);
  ASSERT_EQ(r.errors.size(), 1u) << all(r.errors);
  const std::string where = kQuickstart + ":" + std::to_string(line_of(text, "coarse = \"coarse\"")) +
                            ": coupling.regions[0].coarse: ";
  EXPECT_EQ(r.errors[0].substr(0, where.size()), where) << r.errors[0];
  EXPECT_NE(r.errors[0].find("the orifice ('outlet0', D0 = 0.024 m, from lid 'lid' over the bottom of cone 'funnel') is "
                             "only 3.00 coarse diameters wide"),
            std::string::npos)
      << r.errors[0];
  EXPECT_NE(r.errors[0].find("jamming ratio D0 / d = 5"), std::string::npos);
  EXPECT_NE(r.errors[0].find("no fine region over level 'coarse' contains it"), std::string::npos);
  EXPECT_NE(r.errors[0].find("extend the region over the orifice at [0, 0, 0]"), std::string::npos);
}

TEST(RegionRules, WarnsAboutCellsFarLargerThanTheCoarseParticles) {
  // 1 m cells around a 24 mm funnel outlet: 125 coarse diameters; the coupler's 8 wall samples per edge are
  // 12.5 cm apart, coarser than the whole funnel
  const auto r = rules_of(quickstart("cell_size = 0.02\nvelocity_only_below", "cell_size = 1.0\nvelocity_only_below"));
  EXPECT_TRUE(has(r.warnings, "coupling.regions[0].cell_size: cell_size = 1 m is 125.00 coarse diameters")) << all(r.warnings);
  EXPECT_TRUE(has(r.warnings, "above the advised 3-10")) << all(r.warnings);
  EXPECT_TRUE(has(r.warnings, "misses walls closer than 0.125 m")) << all(r.warnings);
  EXPECT_TRUE(has(r.warnings, "cell_size <= 0.08 m would be within the advised range")) << all(r.warnings);
}

TEST(RegionRules, EveryRefusalIsReported) {
  const std::string text = quickstart("cell_size = 0.02\nvelocity_only_below", "cell_size = 0.01\nvelocity_only_below");
  const auto r = rules_of(edited(text, "max = [0.04, 0.04, 0.04]", "max = [0.04, 0.04, 0.01]"));
  EXPECT_EQ(r.errors.size(), 2u) << all(r.errors);  // cells and top, each with its own line
}

// ---- warnings -------------------------------------------------------------------------

TEST(RegionRules, WarnsWhenTheCoarseLevelReliesOnTheCorrectionCells) {
  const auto r = rules_of(quickstart());  // the shipped quickstart: 2.5 coarse diameters per cell, D0 / d = 3
  EXPECT_TRUE(r.errors.empty()) << all(r.errors);
  EXPECT_TRUE(has(r.warnings, "coupling.regions[0].coarse: the orifice ('outlet0', D0 = 0.024 m")) << all(r.warnings);
  EXPECT_TRUE(has(r.warnings, "relies on the correction cells")) << all(r.warnings);
  EXPECT_TRUE(has(r.warnings, "coupling.regions[0].cell_size: cell_size = 0.02 m is 2.50 coarse diameters"))
      << all(r.warnings);
  EXPECT_TRUE(has(r.notes, "D0 = 0.024 m, from lid 'lid' over the bottom of cone 'funnel'")) << all(r.notes);
  // its top, 1.67 D0 above the orifice: above the advised 1.1 D0, below the 2 D0 noted for about 1 %
  EXPECT_FALSE(has(r.warnings, "orifice diameters above the orifice")) << all(r.warnings);
  EXPECT_TRUE(has(r.notes, "1.67 orifice diameters above the orifice ('outlet0', D0 = 0.024 m")) << all(r.notes);
  EXPECT_TRUE(has(r.notes, "for about 1 % raise max z to 0.048 m")) << all(r.notes);
  // two diameters up: no note about the height
  const auto tall = rules_of(edited(quickstart(), "max = [0.04, 0.04, 0.04]", "max = [0.04, 0.04, 0.06]"));
  EXPECT_FALSE(has(tall.notes, "orifice diameters above the orifice")) << all(tall.notes);
  // the same top over a 38 mm orifice: 1.05 D0, allowed, below the advised height
  const auto low = rules_of(
      edited(quickstart(), "[coupling]", "[orifice]\ncenter = [0.0, 0.0, 0.0]\ndiameter = 0.038\n\n[coupling]"));
  EXPECT_TRUE(low.errors.empty()) << all(low.errors);
  EXPECT_TRUE(has(low.warnings, "1.05 orifice diameters above the orifice ('orifice', D0 = 0.038 m")) << all(low.warnings);
  EXPECT_TRUE(has(low.warnings, "below the advised 1.1")) << all(low.warnings);
}

TEST(RegionRules, SingleLevelCaseHasNoReport) {
  const auto r = rules(load_case(kSrc + "/cases/silo_small/reference.toml"));
  EXPECT_TRUE(r.errors.empty() && r.warnings.empty() && r.notes.empty());
}

// ---- shipped cases --------------------------------------------------------------------

TEST(RegionRules, ShippedHierarchiesPass) {
  for (const char* c : {"silo_small/mlcg.toml", "silo_small/mlcg_no_pi.toml", "silo_small/mlcg_tall.toml",
                        "quickstart/mlcg.toml", "quickstart/mlcg3.toml", "silo_paper/mlcg.toml",
                        "silo_paper/mlcg_small.toml", "silo_paper/mlcg3.toml"}) {
    const auto r = rules(load_case(kSrc + "/cases/" + c));
    EXPECT_TRUE(r.errors.empty()) << c << ":\n" << all(r.errors);
  }
  const auto silo = rules(load_case(kSrc + "/cases/silo_small/mlcg.toml"));
  // 3.6 coarse diameters per cell, D0/d 7.1, its top 1.5 D0 above the orifice: nothing to warn about
  EXPECT_TRUE(silo.warnings.empty()) << all(silo.warnings);
  EXPECT_TRUE(has(silo.notes, "1.50 orifice diameters above the orifice")) << all(silo.notes);
  // the same region up to 2 D0: no note about its height
  const auto tall = rules(load_case(kSrc + "/cases/silo_small/mlcg_tall.toml"));
  EXPECT_TRUE(tall.warnings.empty()) << all(tall.warnings);
  EXPECT_FALSE(has(tall.notes, "orifice diameters above the orifice")) << all(tall.notes);
}

TEST(RegionRules, EveryHopperSceneHasItsVariantsAndPasses) {
  int scenes = 0;
  for (const auto& e : fs::directory_iterator(kSrc + "/cases/hoppers")) {
    if (!e.is_directory() || e.path().filename() == "results") continue;  // results/: the studies' tables
    for (const char* f : {"reference.toml", "cg2.toml", "mlcg.toml", "planned.toml", "study.toml"})
      EXPECT_TRUE(fs::is_regular_file(e.path() / f)) << e.path() / f;
    for (const char* f : {"reference.toml", "cg2.toml"})  // single levels: nothing to check, nothing refused
      EXPECT_TRUE(rules(load_case((e.path() / f).string())).errors.empty()) << e.path() / f;
    // sized to pass clean: 3.3-3.6 coarse diameters per cell, tops 1.13-1.33 D0 and 1.8-2 cells above the orifice
    for (const char* f : {"mlcg.toml", "planned.toml"}) {
      const CaseSpec cs = load_case((e.path() / f).string());
      const auto r = rules(cs);
      EXPECT_TRUE(r.errors.empty()) << e.path() / f << ":\n" << all(r.errors);
      EXPECT_TRUE(r.warnings.empty()) << e.path() / f << ":\n" << all(r.warnings);
      EXPECT_EQ(outlets_of(cs).size(), 1u) << e.path() / f;
    }
    ++scenes;
  }
  EXPECT_GE(scenes, 6);
}

// ---- [orifice] and the disk with a hole ----------------------------------------------------

TEST(RegionRules, OrificeKeyReadAndChecked) {
  const std::string base = quickstart("[coupling]", "[orifice]\ncenter = [0.0, 0.0, 0.0]\nwidth = 0.03\nlength = 0.05\n\n[coupling]");
  const CaseSpec cs = parse_case(base, kQuickstart);
  ASSERT_EQ(cs.orifices.size(), 1u);
  EXPECT_DOUBLE_EQ(cs.orifices[0].size(), 0.03);
  EXPECT_DOUBLE_EQ(cs.orifices[0].length, 0.05);
  EXPECT_EQ(cs.orifices[0].name, "orifice");
  const auto refused = [&](const std::string& from, const std::string& to, const std::string& phrase) {
    try {
      parse_case(edited(base, from, to), kQuickstart);
      ADD_FAILURE() << "accepted: " << to;
    } catch (const CaseError& e) {
      EXPECT_NE(std::string(e.what()).find(phrase), std::string::npos) << e.what();
    }
  };
  refused("length = 0.05", "length = 0.02", "orifice.length: 0.02 is shorter than width = 0.03");
  refused("width = 0.03\nlength = 0.05", "diameter = 0.03\nwidth = 0.03", "not both");
  refused("width = 0.03\nlength = 0.05", "", "give diameter = D");
  refused("center = [0.0, 0.0, 0.0]\nwidth", "center = [0.0, 0.0, 0.5]\nwidth", "orifice.center: z = 0.5 is outside the domain");
  refused("width = 0.03\n", "width = 0.03\ndiametr = 0.03\n", "orifice.diametr: unknown key");
}

TEST(RegionRules, DiskWithAHoleIsAFloorWithAnOrifice) {
  const std::string text = slurp(kSrc + "/cases/hoppers/flat_bin/reference.toml");
  const CaseSpec cs = parse_case(text, kSrc + "/cases/hoppers/flat_bin/reference.toml");
  const mlcg::MaterialTable mt({{"particle", 2.5e7, 0.25, 1000.0}, {"steel", 2.5e7, 0.25, 7800.0}});
  mlcg::WallSet walls = mlcg::walls_from_case(cs, mt);
  for (size_t w = 0; w < walls.walls(); ++w) walls.set_active(w, walls.info(w).name != "lid");  // opened
  const double r = 1.4e-3;
  EXPECT_FALSE(walls.touches({0.0, 0.0, 0.0}, r));           // in the hole: falls through
  EXPECT_FALSE(walls.crosses({0.0, 0.0, 0.01}, {0.0, 0.0, -0.01}));
  EXPECT_TRUE(walls.touches({0.03, 0.0, 0.001}, r));         // on the floor
  EXPECT_TRUE(walls.crosses({0.03, 0.0, 0.01}, {0.03, 0.0, -0.01}));
  EXPECT_TRUE(walls.touches({0.0155, 0.0, 0.0}, r));         // at the hole's edge: the rim holds it
  EXPECT_FALSE(walls.touches({0.013, 0.0, 0.0}, r));         // 2 mm inside the edge: clear
  try {
    parse_case(edited(text, "inner_radius = 0.015", "inner_radius = 0.05"), "flat_bin.toml");
    ADD_FAILURE() << "a hole as large as the disk was accepted";
  } catch (const CaseError& e) {
    EXPECT_NE(std::string(e.what()).find("walls[1].inner_radius: 0.05 is outside [0, radius = 0.05)"),
              std::string::npos)
        << e.what();
  }
}

}  // namespace
