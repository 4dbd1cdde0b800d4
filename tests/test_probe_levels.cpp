// Each probe of a hierarchy is read from the finest level whose region holds it (config/regions.hpp):
// a fine level removes its particles where they leave its region, so it cannot see a probe outside.
// The quickstart hierarchy with a second probe above the fine region: the summary, the closing lines
// and the warning before step 1 name the level, and the values are that level's own measurement. A
// completed run is final: `mlcg resume` refuses it.
#include <gtest/gtest.h>

#include <fstream>

#include "launch_support.hpp"

namespace {

using namespace launch_support;

TEST(ProbeLevels, AProbeOutsideEveryFineRegionIsReadFromTheCoarseLevelAndNamedBeforeStepOne) {
  const fs::path dir = fresh_temp_path("probe_levels");
  const fs::path variant = dir.string() + ".toml";
  {
    std::ofstream f(variant);
    f << "base = \"" << kSrc << "/cases/quickstart/mlcg.toml\"\n"
      << R"(
[[probes]]
name = "outlet"
point = [0.0, 0.0, -0.01]
normal = [0.0, 0.0, -1.0]
radius = 0.03
window = [0.1, 0.5]
window_relative_to = "open"

[[probes]]
name = "funnel"          # across the funnel 1 cm above the fine region's top (z = 0.04 m)
point = [0.0, 0.0, 0.05]
normal = [0.0, 0.0, -1.0]
radius = 0.04
window = [0.1, 0.5]
window_relative_to = "open"
)";
  }
  const fs::path dir_run = run_hierarchy_case(variant.string(), "probe_levels_run");
  const std::string out = slurp(dir_run.string() + ".out");
  EXPECT_NE(out.find("probes[1].point: probe 'funnel' at [0, 0, 0.05] lies in no fine region, so its mass flow is "
                     "read from level 'coarse' (alpha 2)"),
            std::string::npos)
      << out;
  EXPECT_LT(out.find("lies in no fine region"), out.find("level 'coarse' (alpha 2, dt")) << "named before any level starts";
  EXPECT_NE(out.find("probe funnel (level coarse, coarse: no fine region holds it): mass flow"), std::string::npos) << out;
  EXPECT_NE(out.find("probe outlet (level fine): mass flow"), std::string::npos) << out;

  const auto s = read_json(dir_run / "summary.json");
  ASSERT_EQ(s["probes"].size(), 2u);
  const auto coarse = read_json(dir_run / "levels" / "coarse" / "summary.json")["probes"];
  const auto fine = read_json(dir_run / "levels" / "fine" / "summary.json")["probes"];
  // each entry is the measurement of the level that holds the probe, taken by that level
  EXPECT_EQ(s["probes"][0]["level"], "fine");
  EXPECT_EQ(s["probes"][0]["resolved"], true);
  EXPECT_EQ(s["probes"][0]["total_mass_kg"], fine[0]["total_mass_kg"]);
  EXPECT_EQ(s["probes"][1]["level"], "coarse");
  EXPECT_EQ(s["probes"][1]["resolved"], false);
  EXPECT_EQ(s["probes"][1]["mean_kg_per_s"], coarse[1]["mean_kg_per_s"]);
  EXPECT_EQ(s["probes"][1]["total_mass_kg"], coarse[1]["total_mass_kg"]);
  // what reading the finest level would have reported: no fine particle ever reaches the funnel probe,
  // while the coarse level's bed flows through it for the whole window
  EXPECT_EQ(fine[1]["total_mass_kg"].get<double>(), 0.0);
  EXPECT_GT(coarse[1]["mean_kg_per_s"].get<double>(), 0.5 * fine[0]["mean_kg_per_s"].get<double>());
  // a completed run is final: `mlcg resume` refuses it and leaves its summary as it was
  const std::string before = slurp(dir_run / "summary.json");
  std::string said;
  EXPECT_EQ(run(kBin + "/mlcg resume " + dir_run.string() + " --quiet", said), 2) << said;
  EXPECT_NE(said.find("completed (its summary.json says so): there is nothing to resume"), std::string::npos) << said;
  EXPECT_EQ(slurp(dir_run / "summary.json"), before);
  remove_run(dir_run);
  fs::remove(variant);
}

}  // namespace
