// `mlcg check CASE` (issue 16): on every shipped case it prints an estimate or refuses with a reason, and
// creates nothing; every scene with probes lists its outlets (none by [orifice]), Beverloo beside each; a case `mlcg run` refuses it refuses with the same message; its wall-time estimate of
// a short quickstart run is within a factor of 2 of the run's own wall time.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <cstdio>
#include <regex>
#include <string>

#include <nlohmann/json.hpp>

#include "launch_support.hpp"

using launch_support::edited_case;
using launch_support::fingerprint;
using launch_support::kBin;
using launch_support::kSrc;
using launch_support::run;
using mlcg::test::fresh_temp_path;
using mlcg::test::read_json;
using mlcg::test::slurp;
using mlcg::test::temp_path;

namespace fs = std::filesystem;

namespace {

struct Estimate {
  double particle_steps = 0.0, wall_seconds = 0.0;
  bool found = false;
};

// "estimate: 2.3e+10 particle-steps, about 4.1 h on this machine (...)".
Estimate parse_estimate(const std::string& out) {
  static const std::regex line(R"(estimate: ([0-9.e+-]+) particle-steps, about ([0-9.e+-]+) (s|min|h|days) on this machine)");
  std::smatch m;
  Estimate e;
  if (!std::regex_search(out, m, line)) return e;
  const std::string unit = m[3];
  const double scale = unit == "s" ? 1.0 : unit == "min" ? 60.0 : unit == "h" ? 3600.0 : 86400.0;
  e.particle_steps = std::stod(m[1]);
  e.wall_seconds = std::stod(m[2]) * scale;
  e.found = true;
  return e;
}

// `mlcg check ARGS` run from `cwd` with its own throughput cache; exit code, stdout+stderr in `out`.
int check(const std::string& args, const fs::path& cwd, const fs::path& cache, std::string& out) {
  const fs::path log = cwd.string() + ".log";
  const int rc = run("cd " + cwd.string() + " && XDG_CACHE_HOME=" + cache.string() + " " + kBin + "/mlcg check " +
                     args + " > " + log.string() + " 2>&1");
  out = slurp(log);
  fs::remove(log);
  return rc;
}

// The shipped scenes that are refused as shipped, and why (empty: none today; every stability scene of
// cases/stability runs as shipped and is refused only in the tests' edited copies).
const std::map<std::string, std::string> kRefused = {};

}  // namespace

// Every shipped case: exit 0 with a positive, finite estimate (or a refusal listed in kRefused); nothing is
// written into the case folders or the working folder.
TEST(Check, EveryShippedCasePrintsAnEstimateAndCreatesNothing) {
  const fs::path cwd = fresh_temp_path("check_cwd"), cache = fresh_temp_path("check_cache");
  fs::create_directories(cwd);
  const auto cases_before = fingerprint(kSrc + "/cases");
  std::vector<std::string> files;
  for (const auto& e : fs::recursive_directory_iterator(kSrc + "/cases"))
    if (e.path().extension() == ".toml" && e.path().filename() != "study.toml") files.push_back(e.path().string());
  std::sort(files.begin(), files.end());
  ASSERT_GE(files.size(), 50u);
  std::map<std::string, std::string> outputs;
  for (const auto& f : files) {
    std::string out;
    const int rc = check(f, cwd, cache, out);
    const std::string rel = fs::relative(f, kSrc).string();
    if (const auto it = kRefused.find(rel); it != kRefused.end()) {
      EXPECT_EQ(rc, 2) << rel << ":\n" << out;
      EXPECT_NE(out.find(it->second), std::string::npos) << rel << ":\n" << out;
      continue;
    }
    EXPECT_EQ(rc, 0) << rel << ":\n" << out;
    const Estimate e = parse_estimate(out);
    EXPECT_TRUE(e.found) << rel << ":\n" << out;
    EXPECT_TRUE(std::isfinite(e.particle_steps) && e.particle_steps > 0.0) << rel << ":\n" << out;
    EXPECT_TRUE(std::isfinite(e.wall_seconds) && e.wall_seconds > 0.0) << rel << ":\n" << out;
    std::printf("[check] %s: %.3g particle-steps, %.3g s\n", rel.c_str(), e.particle_steps, e.wall_seconds);
    // every scene that measures a discharge names its outlets, none of them by [orifice] but the belt feeder's:
    // its slot opens into a chute (skirts and a back plate down to the belt), no hole the walls can show
    if (slurp(f).find("[[probes]]") != std::string::npos && rel.find("collision") == std::string::npos) {
      EXPECT_EQ(out.find("outlets: 0"), std::string::npos) << rel << ":\n" << out;
      if (rel != "cases/feeder/reference.toml")
        EXPECT_EQ(("\n" + slurp(f)).find("\n[orifice]"), std::string::npos) << rel;
    }
    outputs[rel] = out;
  }
  // Beverloo beside each floor outlet: silo_small's 4 cm cone bottom as scripts/beverloo.py (python, the
  // figure in cases/hoppers/README.md) computed it; none for an outlet in a side wall
  EXPECT_NE(outputs["cases/silo_small/reference.toml"].find("Beverloo: 0.2643 kg/s (circle law, D0 = 40 mm"),
            std::string::npos);
  EXPECT_NE(outputs["cases/hoppers/wedge_slot/reference.toml"].find("Beverloo: 0.3273 kg/s (slot law, W0 = 30 mm"),
            std::string::npos);
  EXPECT_NE(outputs["cases/outlets/side_outlet/reference.toml"].find("Beverloo: no estimate"), std::string::npos);
  EXPECT_EQ(fingerprint(kSrc + "/cases"), cases_before) << "mlcg check wrote into the case folders";
  EXPECT_TRUE(fs::is_empty(cwd)) << "mlcg check wrote into the working folder";
  EXPECT_TRUE(fs::exists(cache / "mlcg" / "throughput.json")) << "the calibration was not cached";
  fs::remove_all(cwd);
  fs::remove_all(cache);
}

namespace {

// `mlcg check` and `mlcg run` of `bad`: both exit 2 with the same message on stderr; the run starts nothing.
void expect_same_refusal(const fs::path& bad, const std::string& expected) {
  const fs::path runs = fresh_temp_path("check_refusal_run");
  const std::string check_err = bad.string() + ".check.err", run_err = bad.string() + ".run.err";
  EXPECT_EQ(run("MLCG_NO_CALIBRATE=1 " + kBin + "/mlcg check " + bad.string() + " > /dev/null 2> " + check_err), 2);
  EXPECT_EQ(run(kBin + "/mlcg run " + bad.string() + " --out " + runs.string() + " > /dev/null 2> " + run_err), 2);
  const std::string c = slurp(check_err), r = slurp(run_err);
  EXPECT_EQ(c, r) << "check:\n" << c << "run:\n" << r;
  EXPECT_NE(c.find(expected), std::string::npos) << c;
  EXPECT_FALSE(fs::exists(runs)) << "a refused case must not start a run";
  mlcg::test::remove_case_copy(bad);  // its folder: the case, its bases and the two .err files
}

}  // namespace

TEST(Check, RefusesWhatTheParserRefusesAsRunDoes) {
  expect_same_refusal(
      edited_case("cases/collision/head_on.toml", {{"poisson_ratio = 0.25", "poisson_ratio = 0.75"}}, "check_parser"),
                      "materials[0].poisson_ratio: 0.75");
}

TEST(Check, RefusesWhatTheRegionRulesRefuseAsRunDoes) {
  expect_same_refusal(edited_case("cases/quickstart/mlcg.toml",
                                  {{"max = [0.04, 0.04, 0.04]", "max = [0.04, 0.04, 0.02]"}}, "check_region"),
                      "coupling.regions[0].max: ");
}

// The level's guard refuses before step 1: `mlcg check` gives the message the level gives under `mlcg run`.
TEST(Check, RefusesWhatTheTimeStepGuardRefusesWithTheLevelsMessage) {
  const fs::path bad = edited_case("cases/stability/dt_guard.toml", {{"dt = 1e-6", "dt = 1e-4"}}, "check_dt");
  const fs::path runs = fresh_temp_path("check_dt_run");
  EXPECT_EQ(run("MLCG_NO_CALIBRATE=1 " + kBin + "/mlcg check " + bad.string() + " > " + bad.string() + ".out 2> " +
                bad.string() + ".err"),
            2);
  const std::string err = slurp(bad.string() + ".err");
  EXPECT_NE(err.find("levels[level0].dt: time step refused"), std::string::npos) << err;
  EXPECT_NE(run(kBin + "/mlcg run " + bad.string() + " --out " + runs.string() + " > " + bad.string() + ".run 2>&1"), 0);
  EXPECT_NE(slurp(bad.string() + ".run").find(err), std::string::npos) << "run:\n" << slurp(bad.string() + ".run")
                                                                       << "check:\n" << err;
  mlcg::test::remove_case_copy(bad);  // its folder: the case, its bases and the outputs beside it
  fs::remove_all(runs);
}

// A moving wall strikes particles at its surface's speed: the impact the contact checks size for includes it,
// and a belt too fast for the material is refused before step 1 naming the wall.
TEST(Check, AFastBeltIsRefusedBeforeStep1NamingTheWall) {
  const fs::path bad = edited_case("cases/collision/belt.toml",
                                   {{"max_impact_speed = 1.0\n", ""},
                                    {"surface_velocity = [0.5, 0.0, 0.0]", "surface_velocity = [20.0, 0.0, 0.0]"}},
                                   "check_belt");
  EXPECT_EQ(run("MLCG_NO_CALIBRATE=1 " + kBin + "/mlcg check " + bad.string() + " > " + bad.string() + ".out 2> " +
                bad.string() + ".err"),
            2);
  const std::string err = slurp(bad.string() + ".err");
  EXPECT_NE(err.find("levels[fine].dt: impacts at 21.1 m/s (estimated from insertion speed, free fall and the surface "
                     "of wall 'belt')"),
            std::string::npos)
      << err;
  const std::string out = slurp(bad.string() + ".out");  // the scene's moving walls, before the refusal
  EXPECT_NE(out.find("wall 'belt' moves its surface at [20, 0, 0] m/s (20 m/s), the geometry in place"),
            std::string::npos)
      << out;
  mlcg::test::remove_case_copy(bad);  // its folder: the case, its bases and the outputs beside it
}

// Every level of a hierarchy whose guard refuses is named, with the message that level gives under `mlcg run`
// (where the first level to refuse ends the run, so which others get to speak is a race).
TEST(Check, NamesEveryLevelOfAHierarchyWhoseGuardRefuses) {
  const fs::path bad = edited_case("cases/stability/coupled/dense_stream.toml",
                                   {{"velocity = [0.0, 0.0, -5.0]", "velocity = [0.0, 0.0, -30.0]"}}, "check_fast");
  EXPECT_EQ(run("MLCG_NO_CALIBRATE=1 " + kBin + "/mlcg check " + bad.string() + " > /dev/null 2> " + bad.string() +
                ".err"),
            2);
  const std::string err = slurp(bad.string() + ".err");
  size_t errors = 0;
  for (size_t at = err.find("error: "); at != std::string::npos; at = err.find("error: ", at + 1)) ++errors;
  EXPECT_EQ(errors, 2u) << err;
  for (const char* part : {"levels[coarse].dt: time step refused", "levels[fine].dt: time step refused", "30.1 m/s",
                           "use dt <= 2.008e-05 s", "use dt <= 1.004e-05 s"})
    EXPECT_NE(err.find(part), std::string::npos) << part << " missing in:\n" << err;
  mlcg::test::remove_case_copy(bad);  // its folder: the case, its bases and the .err beside it
}

// The estimate against a real run: the quickstart cut to 0.2 s (the lid stays closed: filling and settling,
// ~3e7 particle-steps). The calibration runs just before the run, so when other work slows the machine
// both are slowed alike; a load that changes between the two moves the ratio (the bound is a factor 2).
TEST(Check, EstimatesAShortQuickstartRunWithinAFactorOfTwo) {
  const fs::path c =
      edited_case("cases/quickstart/case.toml", {{"end = { event = \"open\", plus = 0.5 }", "end = 0.2"}}, "check_short");
  const fs::path cwd = fresh_temp_path("check_short_cwd"), cache = fresh_temp_path("check_short_cache"),
                 dir = fresh_temp_path("check_short_run");
  fs::create_directories(cwd);
  std::string out;
  ASSERT_EQ(check(c.string() + " --calibrate", cwd, cache, out), 0) << out;
  const Estimate e = parse_estimate(out);
  ASSERT_TRUE(e.found) << out;
  ASSERT_EQ(run(kBin + "/mlcg run " + c.string() + " --out " + dir.string() + " --quiet > /dev/null 2>&1"), 0);
  const auto s = read_json(dir / "summary.json");
  const double wall = s["wall_seconds"].get<double>(), steps = s["levels"][0]["particle_steps"].get<double>();
  const double ratio = e.wall_seconds / wall;
  std::printf("[check] estimate %.3g particle-steps, %.3g s; run %.3g particle-steps, %.3g s wall; ratio %.2f\n",
              e.particle_steps, e.wall_seconds, steps, wall, ratio);
  EXPECT_GE(ratio, 0.5) << out;
  EXPECT_LE(ratio, 2.0) << out;
  EXPECT_GE(e.particle_steps / steps, 0.5);
  EXPECT_LE(e.particle_steps / steps, 2.0);
  fs::remove_all(cwd);
  fs::remove_all(cache);
  fs::remove_all(dir);
  mlcg::test::remove_case_copy(c);
}
