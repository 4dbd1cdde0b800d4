// The case-file parser on multi-level cases: [coupling] and [[coupling.regions]]
// parse with their defaults and automatic interval, and every class of bad
// input is refused with "FILE:LINE: KEY: what; allowed".
#include <gtest/gtest.h>

#include <string>

#include "case_parser_support.hpp"

using namespace case_parser_test;

// ---- [coupling]: multi-level cases --------------------------------------------------

namespace {

// The fixture as a two-level case: a coarse level (alpha 2, dt 2e-6) above its
// level "fine" (alpha 1, dt 1e-6), coupled in one region with default settings.
const std::string& two_levels() {
  static const std::string text = [] {
    std::string t = base();
    t.replace(t.find("[domain]"), 8, "[[levels]]\nname = \"coarse\"\nalpha = 2\ndt = 2e-6\n\n[domain]");
    // Levels share event times: the fixture's settling condition becomes a fixed time.
    const std::string cond = "after_insertion = true\nmean_speed_below = 0.01\nlatest = 3.0\n";
    t.replace(t.find(cond), cond.size(), "at = 1.5\n");
    t += "\n[coupling]\nheartbeat = 0.5\n\n[[coupling.regions]]\ncoarse = \"coarse\"\nfine = \"fine\"\n"
         "min = [-0.05, -0.05, -0.1]\nmax = [0.05, 0.05, 0.1]\n";
    return t;
  }();
  return text;
}

// A minimal case with the given [[levels]] entries and [coupling] section.
std::string minimal_with(const std::string& levels, const std::string& coupling) {
  return one_material("0.5", "0.5") + "\n" + levels + R"(
[domain]
min = [0, 0, 0]
max = [1, 1, 1]

[time]
end = 1

)" + coupling;
}

const std::string kRegion = "[[coupling.regions]]\ncoarse = \"cg\"\nfine = \"ref\"\nmin = [0.2, 0.2, 0.2]\n"
                            "max = [0.8, 0.8, 0.6]\n";

}  // namespace

TEST(CaseParser, TwoLevelCaseTakesCouplingDefaults) {
  const std::string& text = two_levels();
  const CaseSpec c = parse_case(text, kFixture);
  ASSERT_EQ(c.levels.size(), 2u);
  ASSERT_TRUE(c.coupling.has_value());
  const CouplingSpec& cp = *c.coupling;
  EXPECT_DOUBLE_EQ(cp.interval, 1.6e-5);  // automatic: 8 x 2e-6 >= 15 x 1e-6
  EXPECT_EQ(cp.endpoint, "");
  EXPECT_DOUBLE_EQ(cp.heartbeat, 0.5);
  EXPECT_DOUBLE_EQ(cp.timeout, 60.0);
  EXPECT_EQ(cp.loc.file, kFixture);
  EXPECT_EQ(cp.loc.line, line_at(text, text.find("[coupling]")));
  ASSERT_EQ(cp.regions.size(), 1u);
  const CouplingRegionSpec& r = cp.regions[0];
  EXPECT_EQ(r.coarse, "coarse");
  EXPECT_EQ(r.fine, "fine");
  expect_near(r.min, {-0.05, -0.05, -0.1});
  expect_near(r.max, {0.05, 0.05, 0.1});
  EXPECT_DOUBLE_EQ(r.cell_size, 0.02);
  EXPECT_FALSE(r.inside.has_value());
  EXPECT_DOUBLE_EQ(r.insert_depth, 0.0);
  EXPECT_DOUBLE_EQ(r.fade, 1.5);
  EXPECT_DOUBLE_EQ(r.kp, 0.5);
  EXPECT_DOUBLE_EQ(r.ki, 200.0);
  EXPECT_DOUBLE_EQ(r.traction_limit, 0.0);
  EXPECT_EQ(r.correct, "mass_flow");
  EXPECT_DOUBLE_EQ(r.velocity_gain, 500.0);
  EXPECT_DOUBLE_EQ(r.velocity_ki, 25000.0);
  EXPECT_DOUBLE_EQ(r.acceleration_limit, 0.0);
  EXPECT_TRUE(std::isinf(r.velocity_only_below) && r.velocity_only_below < 0.0);
  EXPECT_EQ(r.radius_bins, 8);
  EXPECT_EQ(r.loc.line, line_at(text, text.find("[[coupling.regions]]")));
}

TEST(CaseParser, SingleLevelCaseHasNoCoupling) {
  EXPECT_FALSE(load_case(kFixture).coupling.has_value());
}

TEST(CaseParser, CouplingIntervalAutomatic) {
  // 15 x 5e-6 = 7.5e-5; the multiples of 1e-5 are 7e-5 (too short) and 8e-5.
  const CaseSpec c = parse_case(
      minimal_with("[[levels]]\nname = \"cg\"\nalpha = 2\ndt = 1e-5\n\n[[levels]]\nname = \"ref\"\ndt = 5e-6\n",
                   "[coupling]\n" + kRegion),
      "auto.toml");
  ASSERT_TRUE(c.coupling.has_value());
  EXPECT_DOUBLE_EQ(c.coupling->interval, 8e-5);
  // The same with the coarse step given as dt_alpha1 x alpha = 5e-6 x 2.
  const CaseSpec d = parse_case(
      minimal_with("[[levels]]\nname = \"cg\"\nalpha = 2\ndt_alpha1 = 5e-6\n\n[[levels]]\nname = \"ref\"\ndt = 5e-6\n",
                   "[coupling]\ninterval = 0\n" + kRegion),
      "auto.toml");
  EXPECT_DOUBLE_EQ(d.coupling->interval, 8e-5);
  // Steps that are not multiples of each other: 3e-6 and 2e-6 -> 6e-6 x 5 = 3e-5 >= 15 x 2e-6.
  const CaseSpec e = parse_case(
      minimal_with("[[levels]]\nname = \"cg\"\nalpha = 1.5\ndt = 3e-6\n\n[[levels]]\nname = \"ref\"\ndt = 2e-6\n",
                   "[coupling]\n" + kRegion),
      "auto.toml");
  EXPECT_DOUBLE_EQ(e.coupling->interval, 3e-5);
}

TEST(CaseParser, CouplingEveryKeyRead) {
  const CaseSpec c = parse_case(
      minimal_with("[[levels]]\nname = \"cg\"\nalpha = 2\ndt = 1e-5\n\n[[levels]]\nname = \"ref\"\ndt = 5e-6\n",
                   "[coupling]\ninterval = 1e-4\nendpoint = \"tcp://127.0.0.1:5555\"\nheartbeat = 2\ntimeout = 30\n" +
                       kRegion +
                       "cell_size = 0.05\ninside = [0.5, 0.5, 0.3]\ninsert_depth = 0.01\nfade = 2\nkp = 0\nki = 10\n"
                       "traction_limit = 500\ncorrect = \"velocity\"\nvelocity_gain = 20\nacceleration_limit = 40\n"
                       "velocity_only_below = 0.25\nradius_bins = 4\n"),
      "all.toml");
  const CouplingSpec& cp = *c.coupling;
  EXPECT_DOUBLE_EQ(cp.interval, 1e-4);
  EXPECT_EQ(cp.endpoint, "tcp://127.0.0.1:5555");
  EXPECT_DOUBLE_EQ(cp.heartbeat, 2.0);
  EXPECT_DOUBLE_EQ(cp.timeout, 30.0);
  const CouplingRegionSpec& r = cp.regions.at(0);
  EXPECT_DOUBLE_EQ(r.cell_size, 0.05);
  ASSERT_TRUE(r.inside.has_value());
  expect_near(*r.inside, {0.5, 0.5, 0.3});
  EXPECT_DOUBLE_EQ(r.insert_depth, 0.01);
  EXPECT_DOUBLE_EQ(r.fade, 2.0);
  EXPECT_DOUBLE_EQ(r.kp, 0.0);
  EXPECT_DOUBLE_EQ(r.ki, 10.0);
  EXPECT_DOUBLE_EQ(r.traction_limit, 500.0);
  EXPECT_EQ(r.correct, "velocity");
  EXPECT_DOUBLE_EQ(r.velocity_gain, 20.0);
  EXPECT_DOUBLE_EQ(r.velocity_ki, 40.0);  // follows the gain: gain^2 / 10
  EXPECT_DOUBLE_EQ(r.acceleration_limit, 40.0);
  EXPECT_DOUBLE_EQ(r.velocity_only_below, 0.25);
  EXPECT_EQ(r.radius_bins, 4);
}

TEST(CaseParser, CheckpointEveryAndLauncherRead) {
  const CaseSpec c = parse_case(
      minimal_with("[[levels]]\nname = \"cg\"\nalpha = 2\ndt = 1e-5\n\n[[levels]]\nname = \"ref\"\ndt = 5e-6\n",
                   "[launcher]\nrestart_on_failure = 3\n\n[coupling]\ncheckpoint_every = 0.05\n" + kRegion),
      "ckpt.toml");
  EXPECT_DOUBLE_EQ(c.coupling->checkpoint_every, 0.05);
  EXPECT_EQ(c.launcher.restart_on_failure, 3);
  const CaseSpec d = parse_case(two_levels(), kFixture);
  EXPECT_EQ(d.launcher.restart_on_failure, 0);
  EXPECT_DOUBLE_EQ(d.coupling->checkpoint_every, 0.0);
}

TEST(CaseParser, ThreeLevelHierarchy) {
  const CaseSpec c = parse_case(
      minimal_with("[[levels]]\nname = \"cg4\"\nalpha = 4\ndt = 2e-5\n\n[[levels]]\nname = \"cg\"\nalpha = 2\n"
                   "dt = 1e-5\n\n[[levels]]\nname = \"ref\"\ndt = 5e-6\n",
                   "[coupling]\n" + kRegion +
                       "\n[[coupling.regions]]\ncoarse = \"cg4\"\nfine = \"cg\"\nmin = [0.1, 0.1, 0.1]\n"
                       "max = [0.9, 0.9, 0.7]\n"),
      "three.toml");
  ASSERT_EQ(c.coupling->regions.size(), 2u);
  EXPECT_EQ(c.coupling->regions[1].coarse, "cg4");
  EXPECT_DOUBLE_EQ(c.coupling->interval, 8e-5);
}

TEST(CaseParserErrors, CouplingWithOneLevel) {
  expect_error(Edit{"[time]", "[coupling]\n" + kRegion + "\n[time]", "[coupling]"}, "coupling",
               "a [coupling] section needs more than one [[levels]] entry, found 1");
}

TEST(CaseParserErrors, CouplingUnknownKeyInRegion) {
  expect_error_in(two_levels(), Edit{"max = [0.05, 0.05, 0.1]\n", "max = [0.05, 0.05, 0.1]\nkpp = 1\n", "kpp"},
                  "coupling.regions[0].kpp", "unknown key (did you mean 'kp'?); allowed keys: coarse, fine, min");
}

TEST(CaseParserErrors, CouplingRefusesConditionalEvents) {
  expect_error_in(two_levels(), Edit{"at = 1.5\n", "mean_speed_below = 0.02\n", "mean_speed_below"},
                  "events[0].mean_speed_below", "different time on each level of a multi-level case; give at");
}

TEST(CaseParser, SwapEntriesRead) {
  const CaseSpec c = parse_case(two_levels() + "\n[[swap]]\nlevel = \"fine\"\nat = 0.5\nbinary = \"/opt/dem_level2\"\n",
                                kFixture);
  ASSERT_EQ(c.swaps.size(), 1u);
  EXPECT_EQ(c.swaps[0].level, "fine");
  EXPECT_DOUBLE_EQ(c.swaps[0].at, 0.5);
  EXPECT_EQ(c.swaps[0].binary, "/opt/dem_level2");
}

TEST(CaseParserErrors, SwapOfAnUnknownLevel) {
  expect_error_in(two_levels() + "\n[[swap]]\nlevel = \"fine\"\nat = 0.5\nbinary = \"/opt/x\"\n",
                  Edit{"level = \"fine\"\nat", "level = \"medium\"\nat", "level = \"medium\""}, "swap[0].level",
                  "'medium' is not a [[levels]] entry");
}

TEST(CaseParserErrors, CheckpointEveryNegativeAndRestartsOutOfRange) {
  expect_error_in(two_levels(), Edit{"heartbeat = 0.5", "heartbeat = 0.5\ncheckpoint_every = -1", "checkpoint_every"},
                  "coupling.checkpoint_every", "-1");
  expect_error_in(two_levels(), Edit{"[coupling]", "[launcher]\nrestart_on_failure = -2\n\n[coupling]", "restart_on_failure"},
                  "launcher.restart_on_failure", "-2 is outside [0, 100]");
  expect_error(Edit{"[time]", "[launcher]\nrestart_on_failure = 1\n\n[time]", "[launcher]"}, "launcher",
               "a single-level case has nothing to restart");
}

TEST(CaseParserErrors, CouplingUnknownKeyInSection) {
  expect_error_in(two_levels(), Edit{"heartbeat = 0.5", "heartbeat = 0.5\nintervall = 1e-5", "intervall"},
                  "coupling.intervall", "unknown key (did you mean 'interval'?)");
}

TEST(CaseParserErrors, CouplingFineAlphaNotBelowCoarse) {
  expect_error_in(two_levels(), Edit{"alpha = 2\ndt = 2e-6", "alpha = 1\ndt = 2e-6", "fine = \"fine\""},
                  "coupling.regions[0].fine",
                  "level 'fine' has alpha = 1, not below alpha = 1 of the coarse level 'coarse'");
  expect_error_in(two_levels(), Edit{"coarse = \"coarse\"\nfine = \"fine\"", "coarse = \"fine\"\nfine = \"coarse\"",
                                     "fine = \"coarse\""},
                  "coupling.regions[0].fine", "level 'coarse' has alpha = 2, not below alpha = 1");
}

TEST(CaseParserErrors, CouplingUnknownLevel) {
  expect_error_in(two_levels(), "coarse = \"coarse\"", "coarse = \"corse\"", "coupling.regions[0].coarse",
                  "unknown level 'corse' (did you mean 'coarse'?); known: fine, coarse");
}

TEST(CaseParserErrors, CouplingDtDoesNotDivideInterval) {
  expect_error_in(two_levels(), Edit{"heartbeat = 0.5", "interval = 1.5e-5\nheartbeat = 0.5", "interval"},
                  "coupling.interval",
                  "1.5e-05 is not a whole multiple of the time step of level 'coarse' (dt = 2e-06); interval / dt = "
                  "7.5; every level's dt must divide the coupling interval; give e.g. interval = 1.6e-05");
  // A step resolved from dt_alpha1 (2.5e-6 x alpha 2 = 5e-6) is checked, and named, as such.
  std::string scaled = two_levels();
  scaled.replace(scaled.find("dt = 2e-6"), 9, "dt_alpha1 = 2.5e-6");
  expect_error_in(scaled, Edit{"heartbeat = 0.5", "interval = 1.2e-5\nheartbeat = 0.5", "interval"},
                  "coupling.interval",
                  "level 'coarse' (dt = 5e-06 = dt_alpha1 2.5e-06 x alpha 2); interval / dt = 2.4; every level's dt "
                  "must divide the coupling interval; give e.g. interval = 1.5e-05 (the next multiple of every "
                  "level's dt), or interval = 0 (automatic: 1.5e-05)");
}

TEST(CaseParserErrors, CouplingNoAutomaticInterval) {  // 1e-5 and 3.3333e-6 have no common multiple in reach
  std::string odd = two_levels();
  odd.replace(odd.find("dt = 2e-6"), 9, "dt = 1e-5");
  odd.replace(odd.find("dt = 1e-6"), 9, "dt = 3.3333e-6");
  expect_error_in(odd, Edit{"heartbeat = 0.5", "heartbeat = 0.5", "[coupling]", true}, "coupling.interval",
                  "no automatic coupling interval: none of 10000 multiples of the largest dt (1e-05) is a whole "
                  "multiple of every level's dt ('fine' 3.3333e-06, 'coarse' 1e-05)");
}

TEST(CaseParserErrors, CouplingRegionOutsideDomain) {
  expect_error_in(two_levels(), "max = [0.05, 0.05, 0.1]", "max = [0.05, 0.05, 0.7]", "coupling.regions[0].max",
                  "reaches outside the domain in z");
}

TEST(CaseParserErrors, CouplingRegionMinNotBelowMax) {
  expect_error_in(two_levels(), "max = [0.05, 0.05, 0.1]", "max = [0.05, -0.05, 0.1]", "coupling.regions[0].max",
                  "max.y = -0.05 is not above min.y = -0.05; the fine region needs min < max");
}

TEST(CaseParserErrors, CouplingInsidePointOutsideBox) {
  expect_error_in(two_levels(), Edit{"max = [0.05, 0.05, 0.1]", "max = [0.05, 0.05, 0.1]\ninside = [0, 0, 0.2]",
                                     "inside"},
                  "coupling.regions[0].inside", "z = 0.2 is outside the region's box (z from -0.1 to 0.1)");
}

TEST(CaseParserErrors, CouplingFineLevelInTwoRegions) {
  const std::string second = "\n[[coupling.regions]]\ncoarse = \"coarse\"\nfine = \"fine\"\nmin = [0, 0, 0.2]\n"
                             "max = [0.05, 0.05, 0.3]\n";
  std::string text = two_levels() + second;
  const size_t at = text.rfind("fine = \"fine\"");
  try {
    parse_case(text, kFixture);
    ADD_FAILURE() << "accepted a fine level in two regions";
  } catch (const CaseError& err) {
    const std::string prefix = kFixture + ":" + std::to_string(line_at(text, at)) + ": coupling.regions[1].fine: ";
    EXPECT_EQ(std::string(err.what()).substr(0, prefix.size()), prefix) << err.what();
    EXPECT_NE(std::string(err.what()).find("level 'fine' is already the fine level of coupling.regions[0], line"),
              std::string::npos)
        << err.what();
  }
}

TEST(CaseParserErrors, CouplingValueRanges) {
  expect_error_in(two_levels(), Edit{"heartbeat = 0.5", "heartbeat = 0.5\ntimeout = 0.5", "timeout"},
                  "coupling.timeout", "0.5 is not longer than heartbeat = 0.5");
  expect_error_in(two_levels(), Edit{"heartbeat = 0.5", "heartbeat = 0", "heartbeat"}, "coupling.heartbeat",
                  "0 is below 0.01 s of wall time; give heartbeat >= 0.01");
  expect_error_in(two_levels(), Edit{"heartbeat = 0.5", "interval = -1e-5", "interval"}, "coupling.interval",
                  "-1e-05 is negative");
  expect_error_in(two_levels(), Edit{"heartbeat = 0.5", "endpoint = \"localhost:5555\"", "endpoint"},
                  "coupling.endpoint", "give tcp://HOST:PORT or ipc://PATH");
  const std::string region_end = "max = [0.05, 0.05, 0.1]";
  auto bad = [&](const std::string& line, const std::string& key, const std::string& phrase) {
    expect_error_in(two_levels(), Edit{region_end, region_end + "\n" + line, line}, "coupling.regions[0]." + key, phrase);
  };
  bad("cell_size = 0", "cell_size", "0 is not > 0");
  bad("insert_depth = -0.01", "insert_depth", "is negative");
  bad("fade = 0", "fade", "0 is not > 0");
  bad("kp = -1", "kp", "is negative");
  bad("ki = -1", "ki", "is negative");
  bad("ki = 1e5", "ki", "would ring; give at most 31250 1/s");
  bad("traction_limit = -1", "traction_limit", "is negative");
  bad("correct = \"mass-flow\"", "correct", "(did you mean 'mass_flow'?); allowed: mass_flow, velocity, none");
  bad("velocity_gain = 0", "velocity_gain", "0 is not > 0");
  bad("velocity_gain = 1e5", "velocity_gain", "would overshoot; give at most 31250 1/s");
  bad("velocity_ki = -1", "velocity_ki", "is negative");
  bad("velocity_ki = 62501", "velocity_ki", "is above velocity_gain^2 / 4 = 62500 1/s^2, where the correction oscillates");
  bad("acceleration_limit = -1", "acceleration_limit", "is negative");
  bad("radius_bins = 0", "radius_bins", "0 is outside [1, 1000000]; the number of size bins");
  bad("radius_bins = 8.0", "radius_bins", "expected an integer, found float");
}

TEST(CaseParserErrors, CouplingWithoutRegions) {
  expect_error_in(two_levels(), Edit{"[[coupling.regions]]\ncoarse = \"coarse\"\nfine = \"fine\"\n"
                                     "min = [-0.05, -0.05, -0.1]\nmax = [0.05, 0.05, 0.1]\n", "", "[coupling]", true},
                  "coupling.regions", "no regions; give at least one [[coupling.regions]] entry");
}

TEST(CaseParserErrors, LevelInNoRegion) {
  expect_error_in(two_levels(), Edit{"[domain]", "[[levels]]\nname = \"cg4\"\nalpha = 4\ndt = 4e-6\n\n[domain]",
                                     "name = \"cg4\""},
                  "levels[2].name", "level 'cg4' is in no [[coupling.regions]] entry");
}
