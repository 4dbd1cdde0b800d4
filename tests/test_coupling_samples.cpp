// [coupling] samples: the cell samples each level takes per coupling interval for the statistics it sends.
// Each sample is a stress-accumulating force step, which the level counts (summary.json, coupling_parts
// sample_steps, also counting the steps its own [[grids]] sample). The quickstart hierarchy with the default
// (2) and with 1: every level then takes one stress step fewer per interval of the coupler's, less the few
// where a grid's sample falls on the step it dropped.
#include <gtest/gtest.h>

#include <fstream>

#include "launch_support.hpp"

namespace {

using namespace launch_support;

double sample_steps(const fs::path& run, const std::string& level) {
  const auto s = read_json(run / "levels" / level / "summary.json");
  return s["levels"][0]["performance"]["coupling_parts"]["sample_steps"].get<double>();
}

TEST(CouplingSamples, OneSamplePerIntervalTakesOneStressStepFewerPerIntervalOnEveryLevel) {
  const fs::path variant = fresh_temp_path("samples_case").string() + ".toml";
  {
    std::ofstream f(variant);
    f << "base = \"" << kSrc << "/cases/quickstart/mlcg.toml\"\n[coupling]\nsamples = 1\n";
  }
  const fs::path two = run_hierarchy_case(kSrc + "/cases/quickstart/mlcg.toml", "samples_2");
  const fs::path one = run_hierarchy_case(variant, "samples_1");
  const auto s2 = read_json(two / "summary.json"), s1 = read_json(one / "summary.json");
  ASSERT_EQ(s2["status"], "completed");
  ASSERT_EQ(s1["status"], "completed");
  const double intervals = s2["coupling"]["intervals"].get<double>();
  ASSERT_EQ(s1["coupling"]["intervals"].get<double>(), intervals);
  for (const std::string level : {"coarse", "fine"}) {
    const double fewer = sample_steps(two, level) - sample_steps(one, level);
    EXPECT_LE(fewer, intervals) << level;
    EXPECT_GE(fewer, 0.95 * intervals) << level;
  }
  EXPECT_NE(slurp(one / "levels" / "fine" / "log.txt").find("16 steps, 1 cell samples per interval"),
            std::string::npos);
  for (const auto& d : {two, one}) remove_run(d);
  fs::remove(variant);
}

}  // namespace
