// A sphere launched sliding (v0, no spin) on a plane: kinetic friction mu m g
// slows it and spins it up until the contact point stops slipping, which for a
// solid sphere happens at v = 5/7 v0 and t = 2 v0 / (7 mu g).
#include <gtest/gtest.h>

#include "scene_support.hpp"

using namespace mlcg;
using namespace mlcg::test;

TEST(Sliding, ReachesPureRollingAtFiveSeventhsOfV0AtTheoryTime) {
  auto cs = load("collision/sliding.toml");
  const double v0 = cs.particles[0].velocity.x;
  const double mu = cs.interactions[1].friction;
  const double g = 9.81;
  Level level(cs, quiet());
  const double t_roll = 2.0 * v0 / (7.0 * mu * g);

  // slip = velocity of the contact point; it falls linearly and reaches zero at t_roll
  auto slip = [&] {
    const auto& p = level.particles();
    return p.v[0].x - p.radius[0] * p.omega[0].y;
  };
  double s_prev = slip(), t_prev = 0.0, t_cross = -1.0, v_cross = 0.0;
  while (level.time() < 1.5 * t_roll) {
    level.step_once();
    const double s = slip();
    if (s_prev > 0.0 && s <= 0.0) {
      t_cross = t_prev + (level.time() - t_prev) * s_prev / (s_prev - s);
      v_cross = level.particles().v[0].x;
      break;
    }
    s_prev = s;
    t_prev = level.time();
  }
  ASSERT_GT(t_cross, 0.0) << "never reached rolling";
  std::printf("rolling at t = %.6f s (theory %.6f s), v = %.6f m/s (theory %.6f m/s)\n", t_cross, t_roll, v_cross,
              5.0 / 7.0 * v0);
  EXPECT_NEAR(t_cross / t_roll, 1.0, 0.01) << "rolling at t = " << t_cross << " s, theory " << t_roll << " s";
  EXPECT_NEAR(v_cross / (5.0 / 7.0 * v0), 1.0, 0.01) << "v = " << v_cross;

  // Afterwards it keeps rolling: the slip stays tiny and the speed stays at 5/7 v0.
  for (int k = 0; k < 5000; ++k) level.step_once();
  EXPECT_NEAR(level.particles().v[0].x / (5.0 / 7.0 * v0), 1.0, 0.01);
  EXPECT_LT(std::fabs(slip()), 0.01 * v0);
}
