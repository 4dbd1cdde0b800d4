// Walls whose surface moves while the geometry stays in place: a conveyor belt (a plane sliding along
// itself) and a drum (a cylinder turning about its axis). A sphere at rest on either is dragged by kinetic
// friction mu m g and spun up by its torque until its contact point moves with the surface: the slip
// U - (v + omega r) falls at (1 + 5/2) mu g, so it ends at t = 2 U / (7 mu g) with v = 2/7 U and
// omega r = 5/7 U (the sliding test's result seen from the belt's frame). A mesh moving as a whole
// (move_velocity, move_angular_velocity) is checked the same way (a turntable), against the static mesh in its
// own frame (Galilean invariance), across a restart, and refused where it cannot be honoured.
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

// Runs 2 n steps straight and n + n with a restart from the checkpoint in between; returns the sphere's
// (x, v, omega) of each, to be compared bit for bit.
struct SphereState {
  Vec3 x, v, omega;
  bool operator==(const SphereState&) const = default;
};
std::pair<SphereState, SphereState> straight_and_resumed(const config::CaseSpec& cs, uint64_t n, const std::string& tag) {
  const auto straight = fresh_temp_path(tag + "_straight"), split = fresh_temp_path(tag + "_split");
  const auto run = [&](const std::filesystem::path& dir, uint64_t steps, bool restart) {
    LevelOptions o = quiet();
    o.out_dir = dir;
    o.max_steps = steps;
    if (restart) o.restart = dir / "checkpoint.h5";
    Level level(cs, o);
    EXPECT_EQ(level.run(), RunStatus::StepLimit);
    const auto& p = level.particles();
    return SphereState{p.x[0], p.v[0], p.omega[0]};
  };
  const auto a = run(straight, 2 * n, false);
  run(split, n, false);
  const auto b = run(split, n, true);
  for (const auto& d : {straight, split}) std::filesystem::remove_all(d);
  return {a, b};
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
  const auto [a, b] = straight_and_resumed(load("collision/belt.toml"), 10000, "belt");  // 0.02 s of the 0.073 s slip
  EXPECT_TRUE(a == b);
  EXPECT_GT(a.v.x, 0.0) << "the belt moved it";
}

// ---- meshes that move as a whole (move_velocity, move_angular_velocity) ------------------------------

namespace {

// collision/belt.toml with its belt replaced by a turntable: a 2 cm square mesh plate under the sphere turning
// as a whole at 1 rad/s about the vertical axis 5 cm away, so that its surface under the sphere moves at
// 0.05 m/s along x, as a belt of that speed would (it turns 0.4 degrees over the slip, and the sphere moves a
// 250th of its distance from the axis).
constexpr double kTableOmega = 1.0, kTableArm = 0.05;
config::CaseSpec turntable() {
  auto cs = load("collision/belt.toml");
  auto& w = cs.walls[0];
  w.type = config::WallType::Mesh;
  w.file = "meshes/plate.stl";
  w.scale = 2e-3;
  w.surface_velocity = {};
  w.move_angular_velocity = {0.0, 0.0, kTableOmega};
  w.move_center = {0.0, kTableArm, 0.0};
  return cs;
}

}  // namespace

TEST(MovingWalls, AMeshMovingAtConstantVelocityGivesTheStaticMeshsContactsInItsFrame) {
  // Galilean invariance: a sphere striking a plate obliquely (normal, sliding and sticking friction, the
  // tangential spring carried through the impact) and the same sphere, given the plate's velocity U on top,
  // striking the plate moving at U: seen from the moving plate the two runs are one.
  auto still = load("collision/wall_face.toml");
  // Already touching at t = 0: where a contact begins, the damping (as delta^(1/4)) turns a rounding-level
  // difference of the onset step into 1e-7 of the velocity, and the sliding friction amplifies that.
  still.particles[0].position.z = still.particles[0].radius - 1e-6;
  still.particles[0].velocity = {0.3, 0.1, -1.0};
  const Vec3 U{0.2, -0.1, 0.4};
  auto moving = still;
  moving.walls[0].move_velocity = U;
  moving.particles[0].velocity = still.particles[0].velocity + U;
  Level a(still, quiet()), b(moving, quiet());
  double worst_x = 0.0, worst_v = 0.0, worst_w = 0.0, largest_w = 0.0;
  while (a.time() < 4e-4) {
    a.step_once();
    b.step_once();
    ASSERT_EQ(a.time(), b.time());
    const auto &pa = a.particles(), &pb = b.particles();
    worst_x = std::max(worst_x, norm(pb.x[0] - U * b.time() - pa.x[0]));
    worst_v = std::max(worst_v, norm(pb.v[0] - U - pa.v[0]));
    worst_w = std::max(worst_w, norm(pb.omega[0] - pa.omega[0]));
    largest_w = std::max(largest_w, norm(pa.omega[0]));
  }
  EXPECT_GT(largest_w, 10.0) << "the impact spun the sphere: friction acted";
  EXPECT_GT(a.particles().v[0].z, 0.0) << "it bounced off the plate";
  EXPECT_LT(worst_x, 1e-12);  // m: rounding in x - U t, against a 1.4 mm sphere
  EXPECT_LT(worst_v, 1e-9);   // m/s, against about 1 m/s
  EXPECT_LT(worst_w, 1e-6 * largest_w);
}

TEST(MovingWalls, AMeshTurningAsAWholePicksASphereUpAsABeltOfItsSurfaceSpeedWould) {
  const auto cs = turntable();
  const double u = kTableOmega * kTableArm, mu = cs.interactions[1].friction;
  Level level(cs, quiet());
  expect_theory(pick_up(level, u, 0.05), u, mu, 0.01);
}

TEST(MovingWalls, AResumedRunWithATurningMeshEqualsTheUninterruptedOneBitForBit) {
  // The mesh's pose is a function of time: a restarted level places it where the uninterrupted one has it, and
  // both rebuild their candidates at the step after the checkpoint. Mid-slip, as the belt's test.
  const auto [a, b] = straight_and_resumed(turntable(), 1000, "turntable");  // 2 ms of the 7.3 ms slip
  EXPECT_TRUE(a == b);
  EXPECT_GT(std::fabs(a.omega.y), 1.0) << "the table spun the sphere up";
}

TEST(MovingWalls, AWholeWallMotionIsRefusedWhereItCannotBeHonoured) {
  const std::string belt = slurp(std::string(MLCG_SOURCE_DIR) + "/cases/collision/belt.toml");
  // The case text is refused with an error on `key` that says `what`.
  const auto refused = [&](const std::string& text, const std::string& file, const std::string& key,
                           const std::string& what) {
    try {
      config::parse_case(text, std::string(MLCG_SOURCE_DIR) + "/cases/collision/" + file);
      ADD_FAILURE() << "accepted: " << what;
    } catch (const std::exception& e) {
      const std::string msg = e.what();
      EXPECT_NE(msg.find(key), std::string::npos) << msg;
      EXPECT_NE(msg.find(what), std::string::npos) << msg;
    }
  };
  const std::string sv = "surface_velocity = [0.5, 0.0, 0.0]";
  ASSERT_NE(belt.find(sv), std::string::npos);
  // A plane moves its surface only.
  std::string plane = belt;
  plane.replace(plane.find(sv), sv.size(), "move_velocity = [0.0, 0.0, 0.1]");
  refused(plane, "belt.toml", "walls[0].move_velocity", "only a mesh moves as a whole");
  // A mesh moves either its surface or itself.
  auto face = slurp(std::string(MLCG_SOURCE_DIR) + "/cases/collision/wall_face.toml");
  const std::string off = "offset = [0.0005, -0.0003, 0.0]";
  ASSERT_NE(face.find(off), std::string::npos);
  const auto face_with = [&](const std::string& lines) {
    std::string t = face;
    t.replace(t.find(off), off.size(), off + "\n" + lines);
    return t;
  };
  refused(face_with("surface_velocity = [0.1, 0.0, 0.0]\nmove_velocity = [0.0, 0.0, 0.1]"), "wall_face.toml",
          "walls[0].move_velocity", "give either the surface's motion");
  EXPECT_NO_THROW(config::parse_case(face_with("move_velocity = [0.0, 0.0, 0.1]"),
                                     std::string(MLCG_SOURCE_DIR) + "/cases/collision/wall_face.toml"));
  // A hierarchy may move a mesh too: whether it leaves the coupling regions as they were is the coupler's check
  // (tests/test_case_coupling.cpp).
  const std::string level = "[[levels]]\nname = \"fine\"\nalpha = 1.0\ndt = 1e-7\n";
  ASSERT_NE(face.find(level), std::string::npos);
  std::string two = face_with("move_velocity = [0.0, 0.0, 0.1]");
  two.replace(two.find(level), level.size(),
              "[[levels]]\nname = \"coarse\"\nalpha = 2.0\ndt = 2e-7\n\n" + level);
  two += "\n[coupling]\n\n[[coupling.regions]]\ncoarse = \"coarse\"\nfine = \"fine\"\nmin = [-0.01, -0.01, -0.01]\n"
         "max = [0.01, 0.01, 0.0]\ncell_size = 0.005\n";
  EXPECT_NO_THROW(config::parse_case(two, std::string(MLCG_SOURCE_DIR) + "/cases/collision/wall_face.toml"));
}
