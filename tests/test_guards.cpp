// The stability guard: a dt that does not resolve the contacts is refused
// before step 1 with the file, line, key and the fix; an explicit override
// with a reason is accepted; during the run a NaN or an excessive overlap
// stops the level within one step, naming the particle, with a final checkpoint.
// A damaged [initial] file is refused before step 1, naming the particle.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <vector>

#include <nlohmann/json.hpp>

#include "io/h5.hpp"
#include "files.hpp"
#include "scene_support.hpp"

using namespace mlcg;
using namespace mlcg::test;
namespace fs = std::filesystem;

namespace {
std::string refusal(const config::CaseSpec& cs) {
  try {
    Level level(cs, quiet());
  } catch (const StabilityError& e) {
    return e.what();
  }
  return "";
}
}  // namespace

TEST(StabilityGuard, DtAboveTwentyPercentOfRayleighIsRefusedWithLocationAndFix) {
  auto cs = load("silo_small/reference.toml");
  cs.levels[0].dt = 1.2e-5;  // t_R = 4.79e-5 s: 25 %
  const std::string msg = refusal(cs);
  ASSERT_FALSE(msg.empty());
  EXPECT_NE(msg.find("reference.toml:" + std::to_string(cs.levels[0].loc.line) + ":"), std::string::npos) << msg;
  EXPECT_NE(msg.find("dt"), std::string::npos) << msg;
  EXPECT_NE(msg.find("Rayleigh time"), std::string::npos) << msg;
  EXPECT_NE(msg.find("use dt <= 9.58"), std::string::npos) << msg;
  EXPECT_NE(msg.find("dt_override_reason"), std::string::npos) << msg;
}

TEST(StabilityGuard, DtJustBelowTheGuardIsAccepted) {
  auto cs = load("silo_small/reference.toml");
  cs.levels[0].dt = 9.5e-6;
  EXPECT_EQ(refusal(cs), "");
}

TEST(StabilityGuard, OverrideWithAReasonIsAcceptedAndReported) {
  auto cs = load("silo_small/reference.toml");
  cs.levels[0].dt = 1.2e-5;
  cs.stability.dt_override_reason = "testing the override";
  Level level(cs, quiet());
  EXPECT_TRUE(level.stability().overridden);
}

TEST(StabilityGuard, TooFewStepsPerHertzContactIsRefused) {
  auto cs = load("collision/head_on.toml");
  cs.stability.max_impact_speed = 10.0;
  cs.stability.max_overlap_fraction = 0.5;
  cs.levels[0].dt = 9e-6;  // below 20 % of Rayleigh, but t_c(10 m/s) = 8.7e-5 s -> ~10 steps
  cs.stability.min_steps_per_contact = 20;
  const std::string msg = refusal(cs);
  EXPECT_NE(msg.find("Hertz contact"), std::string::npos) << msg;
  EXPECT_NE(msg.find("need 20"), std::string::npos) << msg;
}

TEST(StabilityGuard, ImpactsThatWouldOverlapTooMuchAreRefused) {
  auto cs = load("collision/head_on.toml");
  cs.stability.max_impact_speed = 50.0;  // Hertz overlap ~75 % of the radius for this soft material
  const std::string msg = refusal(cs);
  EXPECT_NE(msg.find("max_overlap_fraction"), std::string::npos) << msg;
  EXPECT_NE(msg.find("50 m/s"), std::string::npos) << msg;
}

TEST(RunGuard, NonFiniteVelocityStopsWithinOneStepNamingTheParticle) {
  auto cs = load("collision/head_on.toml");
  Level level(cs, quiet());
  level.step_once();
  level.particles_mut().v[1].y = std::nan("");
  try {
    level.step_once();
    FAIL() << "no stop";
  } catch (const GuardStop& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("non-finite"), std::string::npos) << msg;
    EXPECT_NE(msg.find("particle id 1"), std::string::npos) << msg;
    EXPECT_NE(msg.find("step 1"), std::string::npos) << msg;
  }
}

TEST(RunGuard, ExcessiveOverlapStopsTheRunWithACheckpointAndAFailedSummary) {
  auto cs = load("collision/head_on.toml");
  const fs::path dir = fresh_temp_path("guard");
  LevelOptions o = quiet();
  o.out_dir = dir;
  Level level(cs, o);
  // Pushed together after the start (placed like this, the level refuses them before step 1).
  level.particles_mut().x[0] = {-0.0007, 0.0, 0.0};  // 100 % overlap of 1.4 mm radii
  level.particles_mut().x[1] = {0.0007, 0.0, 0.0};
  EXPECT_EQ(level.run(), RunStatus::Failed);
  EXPECT_EQ(level.step(), 0u);  // stopped inside the first step
  EXPECT_TRUE(fs::exists(dir / "checkpoint_failed.h5"));
  const auto j = read_json(dir / "summary.json");
  EXPECT_EQ(j["status"], "failed");
  const std::string reason = j["reason"];
  EXPECT_NE(reason.find("overlap of 100.0 %"), std::string::npos) << reason;
  EXPECT_NE(reason.find("max_overlap_fraction"), std::string::npos) << reason;
  fs::remove_all(dir);
}

// 100,000 [[particles]] (issue 13: 690,000 hung before step 1): the guard considers one kind per
// material, not one per particle (which made its pair loop O(N^2), 1e10 pairs here).
TEST(StabilityGuard, ManyPlacedParticlesAreCheckedInLinearTime) {
  auto cs = load("collision/head_on.toml");
  cs.domain.min = {-0.1, -0.1, -0.1};
  cs.domain.max = {0.1, 0.1, 0.1};
  const config::ParticleSpec proto = cs.particles[0];
  cs.particles.clear();
  for (int i = 0; i < 47 && cs.particles.size() < 100000; ++i)
    for (int j = 0; j < 47 && cs.particles.size() < 100000; ++j)
      for (int k = 0; k < 47 && cs.particles.size() < 100000; ++k) {
        config::ParticleSpec p = proto;
        p.radius = 1e-3;
        p.velocity = {};
        p.position = {-0.09 + 0.0035 * i, -0.09 + 0.0035 * j, -0.09 + 0.0035 * k};
        cs.particles.push_back(p);
      }
  const auto t0 = std::chrono::steady_clock::now();
  Level level(cs, quiet());
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_EQ(level.particles().n_local(), 100000u);
  EXPECT_LT(seconds, 30.0) << "setting up 100,000 placed particles took " << seconds << " s";
  EXPECT_GT(level.stability().rayleigh_time, 0.0);
}

// ---- a damaged [initial] file (issue 13; found by fuzzing, tests/fuzz/fuzz_initial) ----------

namespace {

struct InitialParticle {
  Vec3 x, v, omega;
  double radius = 2e-3;
  int64_t id = 0;
};

// An [initial] snapshot of `ps` (one dataset `short_radius` entry shorter when asked).
fs::path write_initial(const std::vector<InitialParticle>& ps, bool short_radius = false) {
  const fs::path f = temp_path("initial").string() + ".h5";
  std::vector<Vec3> x, v, w;
  std::vector<double> r;
  std::vector<int64_t> id;
  for (const auto& p : ps) {
    x.push_back(p.x);
    v.push_back(p.v);
    w.push_back(p.omega);
    r.push_back(p.radius);
    id.push_back(p.id);
  }
  if (short_radius) r.pop_back();
  io::H5Writer out(f);
  out.write_vec3("position", x);
  out.write_vec3("velocity", v);
  out.write_vec3("omega", w);
  out.write("radius", r);
  out.write("id", id);
  out.commit();
  return f;
}

// The quickstart hopper started from `file`: "" when it sets up, else the refusal.
std::string start_from(const fs::path& file) {
  auto cs = load("quickstart/case.toml");
  cs.initial = config::InitialSpec{file.string(), "beads", {"case.toml", 7}};
  try {
    Level level(cs, quiet());
    level.step_once();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(InitialFile, DamagedSnapshotsAreRefusedBeforeStep1NamingTheParticle) {
  const InitialParticle a{{0.0, 0.0, 0.1}, {}, {}, 2e-3, 0}, b{{0.01, 0.0, 0.1}, {}, {}, 2e-3, 1};
  EXPECT_EQ(start_from(write_initial({a, b})), "");
  struct Bad {
    std::vector<InitialParticle> ps;
    bool short_radius;
    std::string expect;
  };
  auto far = b, nan = b, flat = b, twin = b;
  far.x.z = -7.07421e238;  // what the fuzzer found: a sign and exponent flip, UB in the overlap check's hash
  nan.v.y = std::nan("");
  flat.radius = 0.0;
  twin.id = 0;
  const Bad bad[] = {
      {{a, far}, false, "particle 1 (id 1): its centre (0.01, 0, -7.07421e+238) m lies outside the domain"},
      {{a, nan}, false, "particle 1 (id 1): a position, velocity, omega or radius that is not a finite number"},
      {{a, flat}, false, "particle 1 (id 1): radius 0 m; a radius is > 0"},
      {{a, twin}, false, "id 0 is given to two particles"},
      {{a, b}, true, "position, velocity, omega, radius and id have 2, 2, 2, 1 and 2 entries"},
  };
  for (const auto& c : bad) {
    const fs::path f = write_initial(c.ps, c.short_radius);
    const std::string msg = start_from(f);
    EXPECT_NE(msg.find("case.toml:7: initial.file: " + f.string() + ": " + c.expect), std::string::npos) << msg;
    fs::remove(f);
  }
}
