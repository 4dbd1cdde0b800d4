// Issue 17: stiff and extreme hierarchies (cases/stability/coupled/). Each scene runs through `mlcg run`
// with the energy account on every level ([output] energy_interval, level/energy_account.hpp) and must
// finish with no NaN, no guard stop, no inserted particle placed deeper than the stated limit into
// another or into a wall, none outside the walls, and an account that does not rise beyond the scene's
// bound for that level; or it is refused before step 1 with the limit and the fix.
//
// The bound is on the largest rise of the account, gain(t) - min over earlier samples, as a share of the
// largest energy in motion (kinetic + rotational + elastic) of that level: a rise is what damping cannot
// hide. Each level's bound is about 10x the rise measured on that level (README, "Coupled hierarchies"), and
// not below 1e-9, the rounding of sums over thousands of particles: a regression of
// one order of magnitude fails.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iostream>
#include <map>

#include <fmt/format.h>

#include "config/case_parser.hpp"
#include "launch_support.hpp"
#include "run_checks.hpp"

using namespace mlcg;
namespace fs = std::filesystem;
using launch_support::kBin;
using launch_support::kSrc;
using launch_support::remove_run;
using launch_support::run;
using launch_support::run_hierarchy_case;
using mlcg::test::slurp;
using mlcg::test::temp_path;

namespace {

constexpr double kInsertOverlap = 0.05;  // of the inserted particle's diameter, with particles and with walls

constexpr double kFloor = 1e-9;  // the rounding of sums over thousands of particles

struct Scene {
  const char* name;
  std::map<std::string, double> bound;  // per level: largest rise / energy in motion
};

void PrintTo(const Scene& s, std::ostream* os) { *os << s.name; }

// Each level's bound about 10x its own rise measured 2026-12-06 at e366408 (in the comment, same order; the runs
// depend on the seed only, the same digits on every run), or kFloor. dense_stream's coarse level, 6.0e-6 when its
// bound was set, now rises by rounding only: held to kFloor (a drift of 1e-10 per step, 7.6e-8, passed 6e-5).
const Scene kScenes[] = {
    {"youngs_1e6", {{"coarse", kFloor}, {"fine", kFloor}}},       // 2.3e-14, 0
    {"youngs_1e10", {{"coarse", kFloor}, {"fine", kFloor}}},      // 2.2e-12, 4.9e-15
    {"alpha8", {{"coarse8", 4e-4}, {"fine", kFloor}}},            // 4.2e-5, 4.5e-16
    {"dt_guard_3lvl", {{"coarsest", kFloor}, {"coarse", kFloor}, {"fine", kFloor}}},  // 7.7e-15, 0, 8.5e-14
    {"dense_stream", {{"coarse", kFloor}, {"fine", kFloor}}},     // 1.3e-13, 1.3e-14
    {"gains_99", {{"coarse", kFloor}, {"fine", kFloor}}},         // 0, 0
    {"junction", {{"coarse", kFloor}, {"fine", kFloor}}},         // 0, 0
    {"rank_border", {{"coarse", kFloor}, {"fine", kFloor}}},      // 0, 0
    {"undamped", {{"coarse", 4e-3}, {"fine", 2e-3}}},             // 6.5e-4, 4.9e-4 (6x, 4x: not loosened)
};

struct LevelResult {
  std::string name;
  nlohmann::json level, summary;
};

std::vector<LevelResult> levels_of(const fs::path& dir) {
  std::vector<LevelResult> out;
  for (const auto& e : fs::directory_iterator(dir / "levels")) {
    const auto s = run_checks::read_json(e.path() / "summary.json");
    out.push_back({e.path().filename().string(), s["levels"][0], s});
  }
  std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) { return a.name < b.name; });
  return out;
}

}  // namespace

class CoupledScene : public ::testing::TestWithParam<Scene> {};

TEST_P(CoupledScene, RunsToItsEndWithTheEnergyAccountBoundedOnEveryLevel) {
  const Scene sc = GetParam();
  const fs::path dir = run_hierarchy_case(std::string("cases/stability/coupled/") + sc.name + ".toml",
                                          std::string("cstab_") + sc.name);
  const auto lv = levels_of(dir);
  ASSERT_EQ(lv.size(), sc.bound.size()) << "a bound for every level, none for a level the scene lacks";
  double end = -1.0;
  for (const auto& l : lv) {
    SCOPED_TRACE(std::string(sc.name) + ", level " + l.name);
    EXPECT_EQ(l.summary["status"], "completed") << l.summary["reason"];
    // Every level stops after the same interval, also where the end time is no whole number of intervals
    // (alpha8, dt_guard_3lvl: 0.25 s); before the fix the coarse level stopped one interval early.
    if (end < 0.0) end = l.summary["simulated_time"].get<double>();
    EXPECT_NEAR(l.summary["simulated_time"].get<double>(), end, 1e-9);
    const auto& e = l.level["energy"];
    ASSERT_TRUE(e.is_object());
    EXPECT_GE(e["samples"].get<int>(), 50);
    const double motion = e["in_motion_J"].get<double>();
    EXPECT_GT(motion, 0.0);
    for (const char* k : {"max_rise_J", "end_gain_J", "controller_work_J", "inserted_J", "removed_J"})
      EXPECT_TRUE(std::isfinite(e[k].get<double>())) << k;
    ASSERT_TRUE(sc.bound.count(l.name)) << "no bound for level " << l.name;
    const double bound = sc.bound.at(l.name);
    EXPECT_LE(e["max_rise_J"].get<double>(), bound * motion);
    const auto& c = l.level["coupling"];
    EXPECT_LE(c["largest_insert_overlap_of_diameter"].get<double>(), kInsertOverlap);
    EXPECT_LE(c["largest_insert_wall_overlap_of_diameter"].get<double>(), kInsertOverlap);
    EXPECT_EQ(c["inserted_outside_walls"].get<int>(), 0);
    std::cout << "[coupled stability] " << sc.name << " " << l.name << ": rise / in motion "
              << e["max_rise_J"].get<double>() / motion << " (bound " << bound << "), end gain / in motion "
              << e["end_gain_J"].get<double>() / motion << ", controller work " << e["controller_work_J"] << " J, "
              << c["inserted_from_coupler"] << " inserted from the coupler, largest insert overlap "
              << c["largest_insert_overlap_of_diameter"] << " of a diameter\n";
  }
  // The fine level was fed: the coupling acted in every scene.
  const auto fine = std::find_if(lv.begin(), lv.end(), [](const auto& l) { return l.name == "fine"; });
  ASSERT_NE(fine, lv.end());
  EXPECT_GT(fine->level["coupling"]["inserted_from_coupler"].get<int>(), 100);
  remove_run(dir);
}

INSTANTIATE_TEST_SUITE_P(Scenes, CoupledScene, ::testing::ValuesIn(kScenes),
                         [](const auto& info) { return std::string(info.param.name); });

// Nothing dissipates: the account must close. The controllers' work is measured (sum F.v dt), and it is
// far larger than what is left, so an account without it, or with it wrong, would not close.
TEST(CoupledUndamped, TheAccountClosesBecauseTheControllersWorkIsMeasured) {
  const fs::path dir = run_hierarchy_case("cases/stability/coupled/undamped.toml", "cstab_undamped_close");
  for (const auto& l : levels_of(dir)) {
    SCOPED_TRACE(l.name);
    const auto& e = l.level["energy"];
    const double motion = e["in_motion_J"].get<double>(), end = e["end_gain_J"].get<double>();
    const double work = e["controller_work_J"].get<double>();
    EXPECT_LE(std::fabs(end), 1e-3 * motion);
    EXPECT_GE(std::fabs(work), 20.0 * std::fabs(end));
    // Particles crossed the level's borders both ways and carried energy measured on both sides.
    EXPECT_GT(e["removed_J"].get<double>(), 0.0);
    std::cout << "[coupled stability] undamped " << l.name << ": end gain " << end << " J of " << motion
              << " J in motion; controller work " << work << " J, carried in " << e["inserted_J"] << " J, out "
              << e["removed_J"] << " J\n";
  }
  remove_run(dir);
}

// A stream at 30 m/s: a Hertz contact at that speed is shorter than 10 steps of either level's dt. Each
// level refuses before step 1, naming its dt, the speed and the dt to use.
TEST(CoupledRefusals, AStreamTooFastForTheLevelsDtIsRefusedNamingTheLevelTheSpeedAndTheFix) {
  std::string text = slurp(kSrc + "/cases/stability/coupled/dense_stream.toml");
  const std::string v = "velocity = [0.0, 0.0, -5.0]";
  ASSERT_NE(text.find(v), std::string::npos);
  text.replace(text.find(v), v.size(), "velocity = [0.0, 0.0, -30.0]");
  const fs::path c = temp_path("cstab_fast").string() + ".toml", dir = temp_path("cstab_fast");
  std::ofstream(c) << text;
  fs::remove_all(dir);
  EXPECT_NE(run(kBin + "/mlcg run " + c.string() + " --out " + dir.string() + " --quiet > " + dir.string() +
                ".out 2>&1"),
            0);
  const std::string out = slurp(dir.string() + ".out");
  for (const char* part : {"levels[fine].dt", "levels[coarse].dt", "time step refused", "30.1 m/s", "use dt <=",
                           "dt_override_reason"})
    EXPECT_NE(out.find(part), std::string::npos) << "'" << part << "' missing in:\n" << out;
  // Refused by the launcher before anything started (both levels named, no race between them): no run folder.
  EXPECT_FALSE(fs::exists(dir)) << out;
  remove_run(dir);
  fs::remove(c);
}

// The gains of gains_99.toml raised to 102 % of their limits: each is refused by the parser, naming the key,
// the product with the interval (or velocity_gain^2 / 4) and the largest value allowed.
TEST(CoupledRefusals, GainsJustAboveTheirLimitsAreRefusedWithTheLargestAllowed) {
  const std::string path = kSrc + "/cases/stability/coupled/gains_99.toml";
  const std::string base = slurp(path);
  ASSERT_NO_THROW(config::parse_case(base, path));
  const auto spec = config::parse_case(base, path);
  const auto& g = spec.coupling->regions[0];
  const double iv = spec.coupling->interval;
  EXPECT_NEAR(g.ki * iv, 0.99 * 0.5, 1e-6);
  EXPECT_NEAR(g.velocity_gain * iv, 0.99 * 0.5, 1e-6);
  EXPECT_NEAR(g.velocity_ki / (0.25 * g.velocity_gain * g.velocity_gain), 0.99, 1e-5);  // 6 digits in the file
  auto raised = [&](const std::string& key, double value) {
    std::string t = base;
    const auto at = t.find("\n" + key + " = ");
    EXPECT_NE(at, std::string::npos) << key;
    const auto eol = t.find('\n', at + 1);
    t.replace(at + 1, eol - at - 1, key + " = " + fmt::format("{:.9g}", value));
    return t;
  };
  const struct {
    std::string key, fragment;
    double value;
  } cases[] = {{"ki", "would ring", g.ki * 1.02 / 0.99},
               {"velocity_gain", "would overshoot", g.velocity_gain * 1.02 / 0.99},
               {"velocity_ki", "where the correction oscillates", g.velocity_ki * 1.02 / 0.99}};
  for (const auto& c : cases) {
    try {
      config::parse_case(raised(c.key, c.value), path);
      ADD_FAILURE() << c.key << " at 102 % accepted";
    } catch (const config::CaseError& e) {
      const std::string msg = e.what();
      std::cout << "[coupled stability] refused: " << msg << "\n";
      for (const std::string& part : {std::string("gains_99.toml:"), "coupling.regions[0]." + c.key, c.fragment})
        EXPECT_NE(msg.find(part), std::string::npos) << "'" << part << "' missing in: " << msg;
    }
  }
}
