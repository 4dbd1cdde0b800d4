// The case-file parser: a complete case parses into the expected values, and
// every class of bad input is refused with "FILE:LINE: KEY: what; allowed".
// Bad inputs are made by editing one spot of a valid fixture; the expected line
// is found by searching the edited text, never hard-coded.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>

#include "case_parser_support.hpp"
#include "config/case_parser.hpp"

namespace {

using namespace case_parser_test;

// ---- valid input ----------------------------------------------------------------

// Only the required keys.
const std::string kMinimalCase = one_material("1", "0") + R"(
[[levels]]
dt = 2e-6

[domain]
min = [0, 0, 0]
max = [1, 1, 1]

[time]
end = 1.5
)";

TEST(CaseParser, CompleteCaseParses) {
  const CaseSpec c = load_case(kFixture);
  EXPECT_EQ(c.path, kFixture);
  EXPECT_EQ(std::filesystem::path(c.dir), std::filesystem::absolute(kFixtureDir).lexically_normal());
  EXPECT_EQ(c.title, "small silo");
  EXPECT_EQ(c.seed, 42u);
  expect_near(c.gravity, {0, 0, -9.81});

  ASSERT_EQ(c.materials.size(), 2u);
  EXPECT_EQ(c.materials[1].name, "steel");
  EXPECT_DOUBLE_EQ(c.materials[1].density, 7800.0);  // an integer where a float is expected
  EXPECT_DOUBLE_EQ(c.materials[0].poisson_ratio, 0.45);
  EXPECT_EQ(c.materials[0].loc.file, kFixture);
  EXPECT_EQ(c.materials[0].loc.line, fixture_line("[[materials]]"));

  ASSERT_EQ(c.interactions.size(), 2u);
  EXPECT_EQ(c.interactions[1].a, "glass");
  EXPECT_EQ(c.interactions[1].b, "steel");
  EXPECT_DOUBLE_EQ(c.interactions[1].restitution, 0.6);
  EXPECT_DOUBLE_EQ(c.interactions[1].rolling_friction, 0.0);  // default

  EXPECT_EQ(c.contact.normal, "hertz");
  EXPECT_EQ(c.contact.tangential, "history");
  EXPECT_EQ(c.contact.rolling, "none");
  EXPECT_FALSE(c.contact.clamp_normal);

  ASSERT_EQ(c.levels.size(), 1u);
  EXPECT_EQ(c.levels[0].name, "fine");
  EXPECT_DOUBLE_EQ(c.levels[0].alpha, 1.0);
  EXPECT_DOUBLE_EQ(c.levels[0].dt, 1e-6);
  EXPECT_EQ(c.levels[0].ranks, 2);
  EXPECT_DOUBLE_EQ(c.levels[0].skin, 0.0);
  EXPECT_EQ(c.levels[0].loc.line, fixture_line("[[levels]]"));

  expect_near(c.domain.min, {-0.1, -0.1, -0.2});
  expect_near(c.domain.max, {0.1, 0.1, 0.6});

  ASSERT_EQ(c.walls.size(), 5u);
  const WallSpec& silo = c.walls[0];
  EXPECT_EQ(silo.type, WallType::Cylinder);
  EXPECT_EQ(silo.material, "steel");
  expect_near(silo.axis, {0, 0, 1});  // normalised
  EXPECT_DOUBLE_EQ(silo.radius, 0.05);
  EXPECT_DOUBLE_EQ(silo.top, 0.5);
  EXPECT_TRUE(silo.rim_bottom);
  EXPECT_FALSE(silo.rim_top);
  EXPECT_EQ(silo.loc.line, fixture_line("[[walls]]"));
  const WallSpec& hopper = c.walls[1];
  EXPECT_EQ(hopper.type, WallType::Cone);
  expect_near(hopper.center, {0, 0, 0});  // default
  expect_near(hopper.axis, {0, 0, 1});    // default
  EXPECT_DOUBLE_EQ(hopper.radius_bottom, 0.01);
  EXPECT_DOUBLE_EQ(hopper.bottom, -0.05);
  EXPECT_FALSE(hopper.rim_bottom);
  EXPECT_EQ(c.walls[2].type, WallType::Disk);
  EXPECT_EQ(c.walls[3].type, WallType::Plane);
  expect_near(c.walls[3].point, {0, 0, -0.15});
  const WallSpec& funnel = c.walls[4];
  EXPECT_EQ(funnel.type, WallType::Mesh);
  EXPECT_EQ(std::filesystem::path(funnel.file),
            (std::filesystem::absolute(kFixtureDir) / "funnel.stl").lexically_normal());
  EXPECT_DOUBLE_EQ(funnel.scale, 0.001);
  expect_near(funnel.offset, {0, 0, 0.1});

  ASSERT_EQ(c.insertions.size(), 1u);
  const InsertionSpec& pour = c.insertions[0];
  EXPECT_EQ(pour.name, "pour");
  EXPECT_EQ(pour.region.type, RegionType::Cylinder);
  EXPECT_DOUBLE_EQ(pour.region.radius, 0.04);
  expect_near(pour.region.min, {-0.04, -0.04, 0.3});  // bounding box of the cylinder
  expect_near(pour.region.max, {0.04, 0.04, 0.5});
  EXPECT_EQ(pour.radius.kind, RadiusKind::Discrete);
  EXPECT_EQ(pour.radius.values, (std::vector<double>{1e-3, 1.4e-3}));
  EXPECT_EQ(pour.radius.fractions, (std::vector<double>{0.25, 0.75}));
  EXPECT_EQ(pour.count, -1);
  EXPECT_DOUBLE_EQ(pour.mass, 0.5);
  EXPECT_DOUBLE_EQ(pour.rate, -1.0);
  EXPECT_DOUBLE_EQ(pour.mass_rate, 2.0);
  EXPECT_DOUBLE_EQ(pour.start, 0.0);
  EXPECT_DOUBLE_EQ(pour.interval, 0.0);
  EXPECT_DOUBLE_EQ(pour.follow_gap, 0.02);
  EXPECT_EQ(pour.max_attempts, 200);
  expect_near(pour.velocity, {0, 0, -1});

  ASSERT_EQ(c.events.size(), 2u);
  EXPECT_TRUE(c.events[0].after_insertion);
  EXPECT_DOUBLE_EQ(c.events[0].mean_speed_below, 0.01);
  EXPECT_DOUBLE_EQ(c.events[0].check_interval, 0.01);  // default
  EXPECT_DOUBLE_EQ(c.events[0].latest, 3.0);
  EXPECT_DOUBLE_EQ(c.events[0].at, -1.0);
  EXPECT_DOUBLE_EQ(c.events[1].at, 2.0);
  EXPECT_TRUE(std::isinf(c.events[1].latest));
  EXPECT_EQ(c.events[1].remove_walls, std::vector<std::string>{"lid"});

  ASSERT_EQ(c.probes.size(), 1u);
  expect_near(c.probes[0].normal, {0, 0, -1});  // default
  EXPECT_DOUBLE_EQ(c.probes[0].sample_rate, 100.0);
  EXPECT_DOUBLE_EQ(c.probes[0].window_start, 0.5);
  EXPECT_TRUE(std::isinf(c.probes[0].window_end));
  EXPECT_EQ(c.probes[0].window_event, "open");

  ASSERT_EQ(c.grids.size(), 1u);
  EXPECT_DOUBLE_EQ(c.grids[0].cell_size, 0.02);
  EXPECT_DOUBLE_EQ(c.grids[0].sample_interval, 0.0);

  EXPECT_DOUBLE_EQ(c.output.snapshot_interval, 0.05);
  EXPECT_DOUBLE_EQ(c.output.stats_interval, 0.01);  // default
  EXPECT_DOUBLE_EQ(c.output.energy_interval, 0.0);  // default: no energy account
  EXPECT_DOUBLE_EQ(c.stability.rayleigh_fraction, 0.25);
  EXPECT_DOUBLE_EQ(c.stability.min_steps_per_contact, 10.0);
  EXPECT_TRUE(c.stability.dt_override_reason.empty());

  EXPECT_DOUBLE_EQ(c.time.end, -1.0);
  EXPECT_EQ(c.time.end_event, "open");
  EXPECT_DOUBLE_EQ(c.time.end_plus, 0.6);
  EXPECT_DOUBLE_EQ(c.time.progress_interval, 2.0);
}

TEST(CaseParser, MinimalCaseTakesDefaults) {
  const std::string text = kMinimalCase;
  const CaseSpec c = parse_case(text, "some/dir/min.toml");
  EXPECT_EQ(c.seed, 1u);
  expect_near(c.gravity, {0, 0, -9.81});
  EXPECT_EQ(c.levels[0].name, "level0");
  EXPECT_EQ(c.levels[0].ranks, 1);
  EXPECT_DOUBLE_EQ(c.levels[0].alpha, 1.0);
  EXPECT_DOUBLE_EQ(c.interactions[0].restitution, 1.0);
  EXPECT_TRUE(c.walls.empty() && c.insertions.empty() && c.events.empty() && c.probes.empty() && c.grids.empty());
  EXPECT_DOUBLE_EQ(c.time.end, 1.5);
  EXPECT_TRUE(c.time.end_event.empty());
  EXPECT_DOUBLE_EQ(c.stability.max_overlap_fraction, 0.3);
  EXPECT_DOUBLE_EQ(c.output.checkpoint_interval, 0.0);
  EXPECT_EQ(std::filesystem::path(c.dir), std::filesystem::absolute("some/dir").lexically_normal());
}

// A CaseSpec built in code starts from the defaults written in case_spec.hpp; a parsed one from the
// declarations. A case that sets only what is required must come out as the former, table by table.
TEST(CaseParser, TheSpecsDefaultsAreTheDeclaredDefaults) {
  const CaseSpec c = parse_case(kMinimalCase, "defaults.toml");
  const CaseSpec d;
  EXPECT_EQ(c.title, d.title);
  EXPECT_EQ(c.seed, d.seed);
  EXPECT_EQ(c.gravity.x, d.gravity.x);
  EXPECT_EQ(c.gravity.z, d.gravity.z);
  EXPECT_TRUE(c.contact == d.contact);
  EXPECT_TRUE(c.output == d.output);
  EXPECT_TRUE(c.stability == d.stability);
  EXPECT_EQ(c.limits.max_steps, d.limits.max_steps);
  EXPECT_EQ(c.limits.max_output_files, d.limits.max_output_files);
  EXPECT_EQ(c.limits.max_memory_gb, d.limits.max_memory_gb);
  EXPECT_EQ(c.time.progress_interval, d.time.progress_interval);
  const LevelSpec l;
  ASSERT_EQ(c.levels.size(), 1u);
  EXPECT_EQ(c.levels[0].name, l.name);
  EXPECT_EQ(c.levels[0].alpha, l.alpha);
  EXPECT_EQ(c.levels[0].ranks, l.ranks);
  EXPECT_EQ(c.levels[0].skin, l.skin);
  EXPECT_EQ(c.levels[0].balance, l.balance);
  EXPECT_EQ(c.interactions[0].rolling_friction, InteractionSpec{}.rolling_friction);
}

TEST(CaseParser, OtherForms) {  // constant and uniform radius, box region, count and rate, rims = "both"
  std::string text = base();
  auto replace = [&](const std::string& from, const std::string& to) {
    const size_t at = text.find(from);
    ASSERT_NE(at, std::string::npos) << from;
    text.replace(at, from.size(), to);
  };
  replace("radius = { values = [1e-3, 1.4e-3], fractions = [0.25, 0.75] }", "radius = 1.4e-3");
  replace("mass = 0.5\nmass_rate = 2.0", "count = 1000\nrate = 5e3\n");
  replace(R"(region = { type = "cylinder", center = [0, 0], radius = 0.04, zmin = 0.3, zmax = 0.5 })", "");
  replace("follow_gap = 0.02\n", "follow_gap = 0.02\n[insertion.region]\nmin = [-0.03, -0.03, 0.3]\n"
          "max = [0.03, 0.03, 0.5]\n");  // the sub-table form of region
  replace("rims = \"bottom\"", "rims = \"both\"");
  replace("[[events]]\nname = \"settled\"", "[[insertion]]\nname = \"more\"\nmaterial = \"glass\"\n"
          "region = { min = [0, 0, 0.1], max = [0.01, 0.01, 0.2] }\nradius = { uniform = [1e-3, 2e-3] }\n"
          "count = 5\n\n[[events]]\nname = \"settled\"");
  const CaseSpec c = parse_case(text, kFixture);
  ASSERT_EQ(c.insertions.size(), 2u);
  const InsertionSpec& pour = c.insertions[0];
  EXPECT_EQ(pour.radius.kind, RadiusKind::Constant);
  EXPECT_DOUBLE_EQ(pour.radius.value, 1.4e-3);
  EXPECT_EQ(pour.count, 1000);
  EXPECT_DOUBLE_EQ(pour.mass, -1.0);
  EXPECT_DOUBLE_EQ(pour.rate, 5e3);
  EXPECT_EQ(pour.region.type, RegionType::Box);
  expect_near(pour.region.max, {0.03, 0.03, 0.5});
  EXPECT_EQ(c.insertions[1].radius.kind, RadiusKind::Uniform);
  EXPECT_DOUBLE_EQ(c.insertions[1].radius.max, 2e-3);
  EXPECT_TRUE(c.walls[0].rim_bottom && c.walls[0].rim_top);
}

TEST(CaseParser, ReadmeExampleParses) {  // the user documentation's complete example stays valid
  const std::string readme = slurp(std::string(MLCG_SOURCE_DIR) + "/cases/README.md");
  const size_t begin = readme.find("```toml\n", readme.find("## Complete example"));
  ASSERT_NE(begin, std::string::npos);
  const size_t end = readme.find("```", begin + 8);
  ASSERT_NE(end, std::string::npos);
  const CaseSpec c = parse_case(readme.substr(begin + 8, end - begin - 8), kFixtureDir + "/readme_example.toml");
  EXPECT_EQ(c.walls.size(), 5u);
  EXPECT_EQ(c.time.end_event, "open");
}

TEST(CaseParser, EveryShippedCaseParses) {  // the cases users start from, long runs included
  int n = 0, hoppers = 0;
  for (const auto& e : std::filesystem::recursive_directory_iterator(std::string(MLCG_SOURCE_DIR) + "/cases")) {
    if (e.path().extension() != ".toml" || e.path().filename() == "study.toml") continue;  // study files: mlcg study
    EXPECT_NO_THROW(load_case(e.path().string())) << e.path();
    ++n;
    hoppers += e.path().parent_path().parent_path().filename() == "hoppers";
  }
  EXPECT_GE(n, 38);
  EXPECT_GE(hoppers, 18);  // cases/hoppers: six scenes x reference, cg2, mlcg
}

// ---- syntax, unknown keys, types --------------------------------------------------

TEST(CaseParserErrors, TomlSyntaxError) {
  expect_error("restitution = 0.6\n", "restitution = = 0.6\n", "TOML syntax error", "Error while parsing");
}

TEST(CaseParserErrors, UnknownTopLevelKeySuggests) {
  expect_error("gravity = [0.0, 0.0, -9.81]", "gravty = [0.0, 0.0, -9.81]", "gravty",
               "unknown key (did you mean 'gravity'?)");
}

TEST(CaseParserErrors, UnknownKeyInTableSuggests) {
  expect_error("dt = 1e-6", "dtt = 1e-6", "levels[0].dtt", "unknown key (did you mean 'dt'?)");
}

TEST(CaseParserErrors, UnknownKeyInNestedTable) {
  expect_error("zmax = 0.5 }", "zmax = 0.5, hieght = 1 }", "insertion[0].region.hieght", "unknown key");
}

TEST(CaseParserErrors, UnknownKeyListsAllowedKeys) {
  expect_error("snapshot_interval = 0.05", "snapshot_intervall = 0.05", "output.snapshot_intervall",
               "(did you mean 'snapshot_interval'?); allowed keys");
}

TEST(CaseParserErrors, KeyOfAnotherWallType) {
  expect_error(Edit{"normal = [0, 0, 1]", "normal = [0, 0, 1]\nradius = 0.1", "radius = 0.1"}, "walls[3].radius",
               "allowed keys for a plane wall");
}

TEST(CaseParserErrors, WallMotionThatCannotBe) {
  // A plane slides along itself (a belt), a surface of revolution turns about its axis (a drum); nothing else.
  const auto with = [](const std::string& after, const std::string& key_line) {
    return Edit{after, after + "\n" + key_line, key_line};
  };
  expect_error(with("normal = [0, 0, 1]", "angular_velocity = 1.0"), "walls[3].angular_velocity",
               "a plane has no axis of its own to turn about; give surface_velocity");
  expect_error(with("normal = [0, 0, 1]", "surface_velocity = [0.3, 0, 0.1]"), "walls[3].surface_velocity",
               "0.1 m/s along the plane's normal; a belt moves in its own plane");
  expect_error(with("top = 0.5", "surface_velocity = [0.1, 0, 0]"), "walls[0].surface_velocity",
               "a cylinder moves by turning about its axis: give angular_velocity");
  expect_error(with("offset = [0, 0, 0.1]", "angular_velocity = 2.0"), "walls[4].angular_velocity",
               "turn the whole mesh with move_angular_velocity");
}

TEST(CaseParserErrors, WrongTypeStringForNumber) {
  expect_error("radius = 0.05", "radius = \"0.05\"", "walls[0].radius", "expected a number, found string");
}

TEST(CaseParserErrors, FloatWhereIntegerExpected) {
  expect_error("ranks = 2", "ranks = 2.0", "levels[0].ranks", "expected an integer, found float");
}

TEST(CaseParserErrors, VectorNeedsThreeNumbers) {
  expect_error("gravity = [0.0, 0.0, -9.81]", "gravity = [0.0, -9.81]", "gravity",
               "expected an array of 3 numbers, found 2");
}

TEST(CaseParserErrors, VectorElementNotANumber) {
  expect_error("velocity = [0, 0, -1]", "velocity = [0, \"0\", -1]", "insertion[0].velocity[1]",
               "expected a number, found string");
}

TEST(CaseParserErrors, CylinderRegionCenterHasTwoNumbers) {
  expect_error("center = [0, 0], radius = 0.04", "center = [0, 0, 0], radius = 0.04", "insertion[0].region.center",
               "expected an array of 2 numbers, found 3");
}

TEST(CaseParserErrors, NanRefused) {
  expect_error("density = 2500", "density = nan", "materials[0].density", "nan is not allowed");
}

TEST(CaseParserErrors, ArrayOfTablesWrittenAsTable) {
  expect_error(Edit{"[[levels]]", "[levels]", "[levels]"}, "levels", "expected an array of tables ([[levels]])");
}

TEST(CaseParserErrors, MissingRequiredTable) {
  expect_error(Edit{"[time]\nend = { event = \"open\", plus = 0.6 }\n", "", "# A complete", true}, "time",
               "missing required table");
}

TEST(CaseParserErrors, MissingRequiredKey) {
  expect_error(Edit{"dt = 1e-6\n", "", "[[levels]]", true}, "levels[0].dt", "missing required key");
}

// ---- impossible values ------------------------------------------------------------

TEST(CaseParserErrors, PoissonRatioOutOfRange) {
  expect_error("poisson_ratio = 0.45", "poisson_ratio = 0.7", "materials[0].poisson_ratio",
               "0.7 is outside [0, 0.5)");
}

TEST(CaseParserErrors, YoungsModulusNotPositive) {
  expect_error("youngs_modulus = 2e8", "youngs_modulus = 0", "materials[1].youngs_modulus", "0 is outside (0, 1e+14] Pa");
}

TEST(CaseParserErrors, DensityNotPositive) {
  expect_error("density = 7800", "density = -7800", "materials[1].density", "-7800 is not > 0");
}

TEST(CaseParserErrors, RestitutionOutOfRange) {
  expect_error("restitution = 0.6", "restitution = 1.2", "interactions[1].restitution", "1.2 is outside (0, 1]");
  expect_error("restitution = 0.5", "restitution = 0", "interactions[0].restitution", "0 is outside (0, 1]");
}

TEST(CaseParserErrors, FrictionNegative) {
  expect_error("friction = 0.3", "friction = -0.1", "interactions[1].friction", "-0.1 is negative");
}

TEST(CaseParserErrors, TimeStepNotPositive) {
  expect_error("dt = 1e-6", "dt = 0", "levels[0].dt", "0 is not > 0");
}

TEST(CaseParserErrors, AlphaBelowOne) {
  expect_error("alpha = 1", "alpha = 0.5", "levels[0].alpha", "0.5 is below 1");
}

TEST(CaseParserErrors, RanksBelowOne) {
  expect_error("ranks = 2", "ranks = 0", "levels[0].ranks", "0 is outside [1, 1000000]; the number of MPI processes");
}

TEST(CaseParserErrors, DomainMinNotBelowMax) {
  expect_error("max = [0.1, 0.1, 0.6]", "max = [0.1, -0.1, 0.6]", "domain.max", "max.y = -0.1 is not above min.y");
}

TEST(CaseParserErrors, WallRadiusNotPositive) {
  expect_error("radius = 0.05", "radius = -0.05", "walls[0].radius", "-0.05 is not > 0");
}

TEST(CaseParserErrors, ZeroLengthAxis) {
  expect_error("axis = [0, 0, 2]", "axis = [0, 0, 0]", "walls[0].axis", "has zero length");
}

TEST(CaseParserErrors, ZeroLengthNormal) {
  expect_error("normal = [0, 0, 1]", "normal = [0.0, 0, 0]", "walls[3].normal", "has zero length");
}

TEST(CaseParserErrors, CylinderBottomNotBelowTop) {
  expect_error("top = 0.5\n", "top = -0.5\n", "walls[0].top", "is not below top");
}

TEST(CaseParserErrors, ConeNegativeRadius) {
  expect_error("radius_bottom = 0.01", "radius_bottom = -0.01", "walls[1].radius_bottom", "-0.01 is negative");
}

TEST(CaseParserErrors, ConeBottomNotBelowTop) {
  expect_error(Edit{"bottom = -0.05\ntop = 0.0", "bottom = 0.05\ntop = 0.0", "top = 0.0"}, "walls[1].top",
               "bottom = 0.05 is not below top = 0");
}

TEST(CaseParserErrors, DiskRadiusNotPositive) {
  expect_error("radius = 0.012\n\n[[walls]]", "radius = 0\n\n[[walls]]", "walls[2].radius", "0 is not > 0");
}

TEST(CaseParserErrors, WallTypeUnknownSuggests) {
  expect_error("type = \"cone\"", "type = \"cones\"", "walls[1].type",
               "'cones' is not allowed (did you mean 'cone'?); allowed: plane, cylinder, cone, disk, mesh");
}

TEST(CaseParserErrors, MeshFileNotFoundNamesResolvedPath) {
  const std::string resolved = (std::filesystem::absolute(kFixtureDir) / "meshes/nope.stl").lexically_normal();
  expect_error("file = \"funnel.stl\"", "file = \"meshes/nope.stl\"", "walls[4].file", "file not found: " + resolved);
}

TEST(CaseParserErrors, InsertionBothCountAndMass) {
  expect_error(Edit{"mass = 0.5\n", "count = 100\nmass = 0.5\n", "mass = 0.5"}, "insertion[0].mass",
               "both count and mass given");
}

TEST(CaseParserErrors, InsertionNeitherCountNorMass) {
  expect_error(Edit{"mass = 0.5\n", "", "[[insertion]]", true}, "insertion[0]", "neither count, count_alpha1 nor mass given");
}

TEST(CaseParserErrors, InsertionCountIsAnInteger) {
  expect_error("mass = 0.5\n", "count = 1e4\n", "insertion[0].count", "expected an integer, found float");
}

TEST(CaseParserErrors, InsertionBothRateAndMassRate) {
  expect_error(Edit{"mass_rate = 2.0", "rate = 1000\nmass_rate = 2.0", "mass_rate"}, "insertion[0].mass_rate",
               "both rate and mass_rate given");
}

TEST(CaseParserErrors, InsertionRegionOutsideDomain) {
  expect_error("zmin = 0.3, zmax = 0.5 }", "zmin = 0.3, zmax = 0.7 }", "insertion[0].region",
               "reaches outside the domain in z");
}

TEST(CaseParserErrors, UniformRadiusMinNotBelowMax) {
  expect_error("radius = { values = [1e-3, 1.4e-3], fractions = [0.25, 0.75] }",
               "radius = { uniform = [2e-3, 1e-3] }", "insertion[0].radius.uniform",
               "min = 0.002 >= max = 0.001");
}

TEST(CaseParserErrors, FractionsDoNotSumToOne) {
  expect_error("fractions = [0.25, 0.75]", "fractions = [0.25, 0.7]", "insertion[0].radius.fractions",
               "fractions sum to 0.95, not 1");
}

TEST(CaseParserErrors, FractionsLengthMismatch) {
  expect_error("fractions = [0.25, 0.75]", "fractions = [1.0]", "insertion[0].radius.fractions",
               "expected an array of 2 numbers, found 1");
}

TEST(CaseParserErrors, ProbePointOutsideDomain) {
  expect_error("point = [0, 0, -0.06]", "point = [0, 0.5, -0.06]", "probes[0].point", "outside the domain");
}

TEST(CaseParserErrors, ProbeRadiusNotPositive) {
  expect_error("radius = 0.012\nwindow", "radius = 0\nwindow", "probes[0].radius", "0 is not > 0");
}

TEST(CaseParserErrors, ProbeSampleRateNotPositive) {
  expect_error("window = [0.5, inf]", "sample_rate = 0\nwindow = [0.5, inf]", "probes[0].sample_rate",
               "0 is not > 0");
}

TEST(CaseParserErrors, ProbeWindowReversed) {
  expect_error("window = [0.5, inf]", "window = [0.5, 0.2]", "probes[0].window", "is not before end");
}

TEST(CaseParserErrors, GridOutsideDomain) {
  expect_error("max = [0.05, 0.05, 0.5]", "max = [0.05, 0.05, 0.9]", "grids[0].max", "reaches outside the domain in z");
  expect_error("min = [-0.05, -0.05, -0.05]", "min = [-0.5, -0.05, -0.05]", "grids[0].min",
               "reaches outside the domain in x");
}

TEST(CaseParserErrors, GridCellSizeNotPositive) {
  expect_error("cell_size = 0.02", "cell_size = 0", "grids[0].cell_size", "0 is not > 0");
}

TEST(CaseParserErrors, GridCellLargerThanBox) {
  expect_error("cell_size = 0.02", "cell_size = 0.2", "grids[0].cell_size", "larger than the box");
}

TEST(CaseParserErrors, EventRemovesUnknownWall) {
  expect_error("remove_walls = [\"lid\"]", "remove_walls = [\"lidd\"]", "events[1].remove_walls",
               "unknown wall 'lidd' (did you mean 'lid'?)");
}

TEST(CaseParserErrors, EventWithoutTimeOrCondition) {
  expect_error(Edit{"at = 2.0\n", "", "[[events]]\nname = \"open\"", true}, "events[1]",
               "neither at nor a condition");
}

TEST(CaseParserErrors, WindowRelativeToUnknownEvent) {
  expect_error("window_relative_to = \"open\"", "window_relative_to = \"opne\"", "probes[0].window_relative_to",
               "unknown event 'opne' (did you mean 'open'?)");
}

TEST(CaseParserErrors, TimeEndMissing) {
  expect_error(Edit{"end = { event = \"open\", plus = 0.6 }", "progress_interval = 1", "[time]", true}, "time.end",
               "missing required key");
}

TEST(CaseParserErrors, TimeEndUnknownEvent) {
  expect_error("end = { event = \"open\", plus = 0.6 }", "end = { event = \"close\", plus = 0.6 }", "time.end.event",
               "unknown event 'close'");
}

TEST(CaseParserErrors, TimeEndWrongType) {
  expect_error("end = { event = \"open\", plus = 0.6 }", "end = \"1.5\"", "time.end",
               "expected a number or a table, found string");
}

TEST(CaseParserErrors, WallNamesUnknownMaterial) {
  expect_error("material = \"steel\"\ncenter = [0, 0, 0]", "material = \"stel\"\ncenter = [0, 0, 0]",
               "walls[0].material", "unknown material 'stel' (did you mean 'steel'?)");
}

TEST(CaseParserErrors, InteractionNamesUnknownMaterial) {
  expect_error("between = [\"glass\", \"steel\"]", "between = [\"glass\", \"iron\"]", "interactions[1].between",
               "unknown material 'iron'");
}

TEST(CaseParserErrors, DuplicateMaterialName) {
  expect_error("name = \"steel\"", "name = \"glass\"", "materials[1].name", "duplicate name 'glass'");
}

TEST(CaseParserErrors, DuplicateWallName) {
  expect_error("name = \"hopper\"", "name = \"silo\"", "walls[1].name", "duplicate name 'silo'");
}

TEST(CaseParserErrors, DuplicateEventName) {
  expect_error(Edit{"name = \"settled\"", "name = \"open\"", "name = \"open\"\nat"}, "events[1].name",
               "duplicate name 'open' (also events[0], line");
}

TEST(CaseParserErrors, DuplicateProbeAndGridNames) {
  expect_error(Edit{"[[grids]]", "[[probes]]\nname = \"orifice\"\npoint = [0, 0, 0]\nradius = 0.01\n\n[[grids]]",
                    "name = \"orifice\""},
               "probes[1].name", "duplicate name 'orifice'");
  expect_error(Edit{"[output]", "[[grids]]\nname = \"bed\"\nmin = [0, 0, 0]\nmax = [0.05, 0.05, 0.05]\ncell_size = 0.01\n"
                    "output_interval = 0.1\n\n[output]", "name = \"bed\""},
               "grids[1].name", "duplicate name 'bed'");
}

TEST(CaseParserErrors, DuplicateLevelName) {
  expect_error(Edit{"[domain]", "[[levels]]\nname = \"fine\"\ndt = 1e-6\n\n[domain]", "name = \"fine\""},
               "levels[1].name",
               "duplicate name 'fine'");
}

TEST(CaseParserErrors, MultiLevelNeedsCoupling) {
  expect_error(Edit{"[domain]", "[[levels]]\nname = \"coarse\"\nalpha = 2\ndt = 2e-6\n\n[domain]", "[[levels]]"},
               "levels", "no [coupling] section; a multi-level case needs one: add [coupling] with one "
                         "[[coupling.regions]] entry");
}

TEST(CaseParserErrors, MissingInteractionBetweenParticleAndWall) {
  expect_error(Edit{"[[interactions]]\nbetween = [\"glass\", \"steel\"]\nrestitution = 0.6\nfriction = 0.3\n", "",
                    "material = \"steel\"", true},
               "walls[0].material", "no [[interactions]] entry between 'steel' and 'glass'");
}

TEST(CaseParserErrors, MissingInteractionBetweenParticles) {
  expect_error(Edit{"between = [\"glass\", \"glass\"]", "between = [\"steel\", \"steel\"]", "material = \"glass\"", true},
               "insertion[0].material", "no [[interactions]] entry between 'glass' and 'glass'");
}

TEST(CaseParserErrors, DuplicateInteraction) {
  expect_error("between = [\"glass\", \"steel\"]", "between = [\"glass\", \"glass\"]", "interactions[1].between",
               "a second interaction between 'glass' and 'glass'");
}

TEST(CaseParserErrors, RollingFrictionWithoutRollingModel) {
  expect_error(Edit{"friction = 0.3", "friction = 0.3\nrolling_friction = 0.1", "rolling_friction"},
               "interactions[1].rolling_friction", "needs a rolling model, but [contact] rolling = \"none\"");
}

TEST(CaseParserErrors, ContactNormalModel) {
  expect_error("tangential = \"history\"", "normal = \"hooke\"", "contact.normal", "allowed: hertz");
}

TEST(CaseParserErrors, ContactTangentialModel) {
  expect_error("tangential = \"history\"", "tangential = \"histroy\"", "contact.tangential",
               "(did you mean 'history'?); allowed: history, none");
}

TEST(CaseParserErrors, ContactRollingModel) {
  expect_error("tangential = \"history\"", "rolling = \"epsd\"", "contact.rolling", "allowed: none, cdt");
}

TEST(CaseParserErrors, StabilityFractionOutOfRange) {
  expect_error("rayleigh_fraction = 0.25", "rayleigh_fraction = 1.5", "stability.rayleigh_fraction",
               "1.5 is outside (0, 1]");
}

TEST(CaseParserErrors, OutputStatsIntervalNotPositive) {
  expect_error("checkpoint_interval = 0.5", "stats_interval = 0", "output.stats_interval", "0 is not > 0");
}

TEST(CaseParserErrors, OutputEnergyIntervalNegative) {
  expect_error("checkpoint_interval = 0.5", "energy_interval = -1e-3", "output.energy_interval",
               "-0.001 is negative; give a value >= 0 in s (0 = no energy account)");
}

TEST(CaseParserErrors, LoadCaseMissingFile) {
  try {
    load_case(kFixtureDir + "/does_not_exist.toml");
    ADD_FAILURE() << "accepted a missing file";
  } catch (const CaseError& e) {
    EXPECT_NE(std::string(e.what()).find("does_not_exist.toml: cannot read the case file"), std::string::npos)
        << e.what();
  }
}

}  // namespace

// ---- process grid, time step scaling, initial state -------------------------------

TEST(CaseParser, DtAlpha1ScalesWithAlphaAndProcessorsAreRead) {
  std::string text = base();
  text.replace(text.find("dt = 1e-6"), 9, "dt_alpha1 = 1e-6\nprocessors = [2, 1, 1]\nbalance = false");
  const CaseSpec cs = parse_case(text, kFixture);
  EXPECT_DOUBLE_EQ(cs.levels[0].dt, 1e-6 * cs.levels[0].alpha);
  EXPECT_EQ(cs.levels[0].processors, (std::vector<int>{2, 1, 1}));
  EXPECT_FALSE(cs.levels[0].balance);
}

TEST(CaseParserErrors, DtAndDtAlpha1Together) {
  expect_error(Edit{"dt = 1e-6", "dt = 1e-6\ndt_alpha1 = 1e-6", "dt_alpha1"}, "levels[0].dt_alpha1",
               "both dt and dt_alpha1 given");
}

TEST(CaseParserErrors, ProcessorGridMustMatchRanks) {
  expect_error(Edit{"ranks = 2", "ranks = 2\nprocessors = [2, 2, 1]", "processors"}, "levels[0].processors",
               "makes 4 boxes but ranks = 2");
}

TEST(CaseParserErrors, ProcessorGridNeedsWholeNumbers) {
  expect_error(Edit{"ranks = 2", "ranks = 2\nprocessors = [2, 0.5, 2]", "processors"}, "levels[0].processors",
               "whole number >= 1");
}

TEST(CaseParserErrors, InitialStateFileMustExist) {
  expect_error(Edit{"[output]", "[initial]\nfile = \"no_such.h5\"\nmaterial = \"glass\"\n\n[output]",
                    "file = \"no_such.h5\""},
               "initial.file", "no_such.h5' does not exist");
}
