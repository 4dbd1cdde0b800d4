// Walls whose surface moves while the geometry stays in place: a conveyor belt (a plane sliding along
// itself) and a drum (a cylinder turning about its axis). A sphere at rest on either is dragged by kinetic
// friction mu m g and spun up by its torque until its contact point moves with the surface: the slip
// U - (v + omega r) falls at (1 + 5/2) mu g, so it ends at t = 2 U / (7 mu g) with v = 2/7 U and
// omega r = 5/7 U (the sliding test's result seen from the belt's frame).
#include <gtest/gtest.h>

#include <cmath>

#include "config/case_parser.hpp"
#include "files.hpp"
#include "scene_support.hpp"

using namespace mlcg;
using namespace mlcg::test;

namespace {

struct PickUp {
  double t = -1.0, v = 0.0, spin = 0.0;  // when the slip ended, the speed and the contact point's spin speed
};

// Steps until the slip (along the surface's velocity u) changes sign; u is the surface speed under the sphere.
PickUp pick_up(Level& level, double u, double t_end) {
  const auto slip = [&] {
    const auto& p = level.particles();
    return u - (p.v[0].x - p.radius[0] * p.omega[0].y);
  };
  double s_prev = slip(), t_prev = level.time();
  while (level.time() < t_end) {
    level.step_once();
    const double s = slip();
    if ((s_prev > 0.0) != (s > 0.0)) {
      PickUp r;
      r.t = t_prev + (level.time() - t_prev) * s_prev / (s_prev - s);
      r.v = level.particles().v[0].x;
      r.spin = -level.particles().radius[0] * level.particles().omega[0].y;
      return r;
    }
    s_prev = s;
    t_prev = level.time();
  }
  return {};
}

// The pick-up against theory: at t = 2 |u| / (7 mu g), v = 2/7 u and the contact point's spin speed 5/7 u.
void expect_theory(const PickUp& r, double u, double mu, double tol) {
  const double t_theory = 2.0 * std::abs(u) / (7.0 * mu * 9.81);
  ASSERT_GT(r.t, 0.0) << "the slip never ended";
  std::printf("picked up at t = %.6f s (theory %.6f), v = %.5f m/s (theory %.5f)\n", r.t, t_theory, r.v, 2.0 / 7.0 * u);
  EXPECT_NEAR(r.t / t_theory, 1.0, tol);
  EXPECT_NEAR(r.v / (2.0 / 7.0 * u), 1.0, tol);
  EXPECT_NEAR(r.spin / (5.0 / 7.0 * u), 1.0, tol);
}

}  // namespace

TEST(MovingWalls, ABeltPicksASphereUpAtTheTheoryTimeAndItRollsAtTwoSeventhsOfTheBeltSpeed) {
  const auto cs = load("collision/belt.toml");
  const double u = cs.walls[0].surface_velocity.x, mu = cs.interactions[1].friction;
  ASSERT_GT(u, 0.0);
  Level level(cs, quiet());
  expect_theory(pick_up(level, u, 0.2), u, mu, 0.01);
  // It then rolls with the belt: the speed stays at 2/7 U.
  for (int k = 0; k < 5000; ++k) level.step_once();
  EXPECT_NEAR(level.particles().v[0].x / (2.0 / 7.0 * u), 1.0, 0.01);
  // The belt's work is the energy account's input: 2/7 m U^2 by the end of the slip (m U^2 / 7 of it kinetic and
  // rotational, the rest lost in sliding), so the account shows no gain.
  level.run();
  ASSERT_NE(level.energy_account(), nullptr);
  const auto& e = level.energy_account()->totals();
  const double m = level.particles().mass[0];
  EXPECT_NEAR(e.wall_work / (2.0 / 7.0 * m * u * u), 1.0, 0.02) << e.wall_work;
  EXPECT_LT(e.max_gain, 1e-3 * e.wall_work);
}

TEST(MovingWalls, ATurningDrumPicksASphereUpAsABeltOfItsSurfaceSpeedWould) {
  const auto cs = load("collision/drum.toml");
  const auto& w = cs.walls[0];
  // The drum's surface under the sphere (its lowest line): omega x (bottom - centre), with the axis along +y.
  const double u = -w.angular_velocity * w.radius, mu = cs.interactions[1].friction;
  Level level(cs, quiet());
  expect_theory(pick_up(level, u, 0.02), u, mu, 0.02);
}

TEST(MovingWalls, AMeshBeltThatIsNotFlatIsRefusedNamingTheTriangle) {
  // A mesh slides along itself only where its velocity lies in every triangle: the hourglass's cones do not.
  auto cs = load("hourglass/reference.toml");
  size_t m = 0;
  while (m < cs.walls.size() && cs.walls[m].type != config::WallType::Mesh) ++m;
  ASSERT_LT(m, cs.walls.size());
  cs.walls[m].surface_velocity = {0.1, 0.0, 0.0};
  try {
    Level level(cs, quiet());
    ADD_FAILURE() << "a curved mesh was accepted as a belt";
  } catch (const std::exception& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("walls[" + std::to_string(m) + "].surface_velocity: has "), std::string::npos) << msg;
    EXPECT_NE(msg.find("along the normal of triangle"), std::string::npos) << msg;
    EXPECT_NE(msg.find(cs.walls[m].loc.str()), std::string::npos) << msg;
  }
}

TEST(MovingWalls, AResumedBeltRunEqualsTheUninterruptedOneBitForBit) {
  // Mid-slip, the sphere's tangential spring against the belt is saturated and moving: the checkpoint must carry
  // it, and the restarted level must move the belt as the uninterrupted one does.
  const auto cs = load("collision/belt.toml");
  const uint64_t n = 10000;  // 0.02 s of the 0.073 s slip
  const auto straight = fresh_temp_path("belt_straight"), split = fresh_temp_path("belt_split");
  const auto run = [&](const std::filesystem::path& dir, uint64_t steps, bool restart) {
    LevelOptions o = quiet();
    o.out_dir = dir;
    o.max_steps = steps;
    if (restart) o.restart = dir / "checkpoint.h5";
    Level level(cs, o);
    EXPECT_EQ(level.run(), RunStatus::StepLimit);
    return std::pair{level.particles().v[0], level.particles().omega[0]};
  };
  const auto a = run(straight, 2 * n, false);
  run(split, n, false);
  const auto b = run(split, n, true);
  EXPECT_EQ(a.first, b.first);
  EXPECT_EQ(a.second, b.second);
  EXPECT_GT(a.first.x, 0.0) << "the belt moved it";
  for (const auto& d : {straight, split}) std::filesystem::remove_all(d);
}
