// Binary collisions against theory (issue: single-level solver, "Done when").
// Damping law of the paper: the restitution equals the case's e at every
// speed (Antypov & Elliott 2011); without damping and friction the kinetic
// energy is conserved and the contact lasts 2.868 (m*^2/(R* E*^2 v))^(1/5).
#include <gtest/gtest.h>

#include <functional>

#include "scene_support.hpp"

using namespace mlcg;
using namespace mlcg::test;

namespace {

// dt = t_c / 400 (the issue asks for dt <= t_c / 100). The restitution error
// is first order in dt (the damping force sees the half-step velocity, as in
// LIGGGHTS): measured 0.3 % at t_c/100, 0.17 % at t_c/200, 0.05 % at t_c/400.
constexpr double kStepsPerContact = 400.0;
constexpr double kRadius = 1.4e-3;
constexpr double kE = 2.5e7, kNu = 0.25, kRho = 1000.0;
const double kEStarPair = 1.0 / (2.0 * (1.0 - kNu * kNu) / kE);
const double kEStarWall = kEStarPair;  // the wall material has the same E and nu

// Two particles approaching head on at relative speed v; dt = t_c/200. `edit` changes the case last.
Impact pair_impact(double v, double alpha, double e, double mu, double steps_per_contact,
                   const std::function<void(config::CaseSpec&)>& edit = {}) {
  auto cs = load("collision/head_on.toml");
  cs.interactions[0].restitution = e;
  cs.interactions[0].friction = mu;
  if (edit) edit(cs);
  const double r = kRadius * alpha;
  const double m = sphere_mass(kRho, r);
  cs.levels[0].alpha = alpha;
  cs.levels[0].dt = hertz_time(0.5 * m, 0.5 * r, kEStarPair, v) / steps_per_contact;
  cs.stability.max_impact_speed = v;
  cs.particles[0].position = {-(r + 0.2 * r), 0.0, 0.0};
  cs.particles[1].position = {r + 0.2 * r, 0.0, 0.0};
  cs.particles[0].velocity = {0.5 * v, 0.0, 0.0};
  cs.particles[1].velocity = {-0.5 * v, 0.0, 0.0};
  Level level(cs, quiet());
  auto gap = [](const Level& l) {
    const auto& p = l.particles();
    return norm(p.x[1] - p.x[0]) - p.radius[0] - p.radius[1];
  };
  auto vn = [](const Level& l) {
    const auto& p = l.particles();
    // approach speed along the line of centres (id 0 is on the left)
    const size_t a = p.id[0] == 0 ? 0 : 1, b = 1 - a;
    return p.v[a].x - p.v[b].x;
  };
  return measure_impact(level, gap, vn);
}

// One particle falling onto the wall of the case at speed v.
Impact wall_impact(const std::string& scene, double v, double alpha, double e, double mu,
                   double steps_per_contact) {
  auto cs = load("collision/wall_" + scene + ".toml");
  for (auto& in : cs.interactions) {
    in.restitution = e;
    in.friction = mu;
  }
  const double r = kRadius * alpha;
  const double m = sphere_mass(kRho, r);
  cs.levels[0].alpha = alpha;
  cs.levels[0].dt = hertz_time(m, r, kEStarWall, v) / steps_per_contact;
  cs.stability.max_impact_speed = v;
  cs.particles[0].position = {0.0, 0.0, 1.2 * r};
  cs.particles[0].velocity = {0.0, 0.0, -v};
  Level level(cs, quiet());
  // every scene's wall has its top point at the origin, under the particle
  auto gap = [](const Level& l) { return l.particles().x[0].z - l.particles().radius[0]; };
  auto vn = [](const Level& l) { return -l.particles().v[0].z; };
  return measure_impact(level, gap, vn);
}

}  // namespace

// The law takes each pair's coefficients from its two materials: with a second material (same E, nu and
// density) whose own pairs have e = 0.9, a glass-other collision must rebound with the glass-other e = 0.5,
// and two particles of the other material with 0.9 (the kernel's one-material path must pick that pair's
// coefficients, not the first material's).
void add_second_material(config::CaseSpec& cs, double e_other, double e_mixed) {
  config::MaterialSpec other = cs.materials[0];
  other.name = "other";
  cs.materials.push_back(other);
  config::InteractionSpec same = cs.interactions[0], mixed = cs.interactions[0];
  same.a = same.b = "other";
  same.restitution = e_other;
  mixed.b = "other";
  mixed.restitution = e_mixed;
  cs.interactions.push_back(same);
  cs.interactions.push_back(mixed);
}

TEST(MixedMaterials, EachPairReboundsWithItsOwnRestitution) {
  const Impact mixed = pair_impact(1.0, 1.0, 0.9, 0.2, kStepsPerContact, [](config::CaseSpec& cs) {
    add_second_material(cs, 0.9, 0.5);
    cs.particles[1].material = "other";
  });
  ASSERT_TRUE(mixed.separated);
  EXPECT_NEAR(mixed.restitution, 0.5, 0.002 * 0.5);
  const Impact other = pair_impact(1.0, 1.0, 0.5, 0.2, kStepsPerContact, [](config::CaseSpec& cs) {
    add_second_material(cs, 0.9, 0.5);
    cs.particles[0].material = cs.particles[1].material = "other";
  });
  ASSERT_TRUE(other.separated);
  EXPECT_NEAR(other.restitution, 0.9, 0.002 * 0.9);
}

class PairRestitution : public ::testing::TestWithParam<std::tuple<double, double>> {};

TEST_P(PairRestitution, EqualsCaseValueWithinPointTwoPercent) {
  const auto [v, alpha] = GetParam();
  const Impact im = pair_impact(v, alpha, 0.5, 0.2, kStepsPerContact);
  ASSERT_TRUE(im.separated);
  std::printf("pair v = %5.1f m/s alpha = %g: e = %.5f (case 0.5)\n", v, alpha, im.restitution);
  EXPECT_NEAR(im.restitution, 0.5, 0.002 * 0.5) << "v = " << v << " m/s, alpha = " << alpha;
}

INSTANTIATE_TEST_SUITE_P(Speeds, PairRestitution,
                         ::testing::Combine(::testing::Values(0.1, 1.0, 3.0, 10.0), ::testing::Values(1.0, 2.0)));

class PairElastic : public ::testing::TestWithParam<std::tuple<double, double>> {};

TEST_P(PairElastic, ConservesEnergyAndLastsHertzTime) {
  const auto [v, alpha] = GetParam();
  const Impact im = pair_impact(v, alpha, 1.0, 0.0, kStepsPerContact);
  ASSERT_TRUE(im.separated);
  EXPECT_NEAR(im.ke_after / im.ke_before, 1.0, 1e-6);
  const double r = kRadius * alpha, m = sphere_mass(kRho, r);
  const double tc = hertz_time(0.5 * m, 0.5 * r, kEStarPair, v);
  std::printf("pair v = %5.1f m/s alpha = %g, e = 1: KE ratio - 1 = %.2e, contact %.4e s (Hertz %.4e s)\n", v,
              alpha, im.ke_after / im.ke_before - 1.0, im.contact_time, tc);
  EXPECT_NEAR(im.contact_time / tc, 1.0, 0.01) << "measured " << im.contact_time << " s, theory " << tc << " s";
}

INSTANTIATE_TEST_SUITE_P(Speeds, PairElastic,
                         ::testing::Combine(::testing::Values(0.1, 1.0, 3.0, 10.0), ::testing::Values(1.0, 2.0)));

class WallImpact : public ::testing::TestWithParam<std::tuple<std::string, double, double>> {};

TEST_P(WallImpact, RestitutionEnergyAndContactTime) {
  const auto [scene, v, alpha] = GetParam();
  const Impact damped = wall_impact(scene, v, alpha, 0.5, 0.175, kStepsPerContact);
  ASSERT_TRUE(damped.separated) << scene;
  EXPECT_NEAR(damped.restitution, 0.5, 0.002 * 0.5) << scene << " at " << v << " m/s";

  const Impact elastic = wall_impact(scene, v, alpha, 1.0, 0.0, kStepsPerContact);
  ASSERT_TRUE(elastic.separated) << scene;
  EXPECT_NEAR(elastic.ke_after / elastic.ke_before, 1.0, 1e-6) << scene;
  const double r = kRadius * alpha, m = sphere_mass(kRho, r);
  const double tc = hertz_time(m, r, kEStarWall, v);
  std::printf("wall %-6s v = %5.1f m/s alpha = %g: e = %.5f; e = 1: KE ratio - 1 = %.2e, contact/Hertz = %.5f\n",
              scene.c_str(), v, alpha, damped.restitution, elastic.ke_after / elastic.ke_before - 1.0,
              elastic.contact_time / tc);
  EXPECT_NEAR(elastic.contact_time / tc, 1.0, 0.01) << scene;
}

INSTANTIATE_TEST_SUITE_P(Walls, WallImpact,
                         ::testing::Combine(::testing::Values("plane", "face", "edge", "vertex"),
                                            ::testing::Values(0.1, 1.0, 3.0, 10.0), ::testing::Values(1.0, 2.0)),
                         [](const auto& info) {
                           return std::get<0>(info.param) + "_v" +
                                  std::to_string(static_cast<int>(std::get<1>(info.param) * 10)) + "_a" +
                                  std::to_string(static_cast<int>(std::get<2>(info.param)));
                         });
