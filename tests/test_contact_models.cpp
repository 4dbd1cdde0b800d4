// The contact sub-models, composed at compile time, each doing its part and
// nothing else: Coulomb truncation of the stored tangential overlap, rotation
// of that overlap into the contact plane, the optional clamp of the normal
// force, the optional rolling torque, and models without friction or rolling
// computing neither.
#include <gtest/gtest.h>

#include <cmath>

#include "contact/model.hpp"

using namespace mlcg;

namespace {

PairCoeffs paper_coeffs(double mu, double mu_roll = 0.0) {
  MaterialTable mt({Material{"glass", 2.5e7, 0.25, 1000.0}});
  mt.set_interaction(0, 0, {0.5, mu, mu_roll});
  return mt.pair(0, 0);
}

ContactInput oblique(double vt) {
  ContactInput in;
  in.n = {0, 0, 1};
  in.delta = 2e-5;
  in.r_eff = 0.7e-3;
  in.m_eff = 5.7e-6;
  in.v_rel = {vt, 0.0, -0.1};
  in.w_rel = {0.0, 3.0, 0.0};
  return in;
}

using Full = ContactModel<HertzNormal<false>, TangentialHistory, RollingCDT>;
using Frictionless = ContactModel<HertzNormal<false>, NoTangential, NoRolling>;
using Clamped = ContactModel<HertzNormal<true>, TangentialHistory, NoRolling>;

}  // namespace

TEST(ContactModels, FrictionlessModelKeepsNoHistoryAndGivesNoTangentialForce) {
  static_assert(!Frictionless::has_history && !Frictionless::has_rolling);
  Vec3 h{};
  const auto f = Frictionless::eval(paper_coeffs(0.5), 1e-6, oblique(1.0), h);
  EXPECT_EQ(f.ft, Vec3{});
  EXPECT_EQ(f.roll, Vec3{});
  EXPECT_EQ(h, Vec3{});
  EXPECT_EQ(f.force.x, 0.0);
  EXPECT_GT(f.force.z, 0.0);
}

TEST(ContactModels, CoulombTruncatesTheStoredOverlapNotJustTheForce) {
  const auto c = paper_coeffs(0.2);
  Vec3 h{};
  ContactForce f{};
  for (int k = 0; k < 2000; ++k) f = Full::eval(c, 1e-6, oblique(1.0), h);  // sliding at 1 m/s
  const double kt = 8.0 * c.g_star * std::sqrt(0.7e-3 * 2e-5);
  EXPECT_NEAR(norm(f.ft), 0.2 * std::fabs(f.fn), 1e-12 * std::fabs(f.fn));
  EXPECT_NEAR(kt * norm(h), 0.2 * std::fabs(f.fn), 1e-9 * std::fabs(f.fn)) << "stored overlap not truncated";
  EXPECT_LT(f.ft.x, 0.0) << "friction must oppose the sliding";
}

TEST(ContactModels, StoredOverlapIsRotatedIntoTheNewContactPlaneKeepingItsLength) {
  const auto c = paper_coeffs(10.0);  // sticking
  Vec3 h{1e-6, 0.0, 0.0};
  ContactInput in = oblique(0.0);
  in.v_rel = {};
  const double a = 0.1;
  in.n = {std::sin(a), 0.0, std::cos(a)};  // the contact plane tilted by 0.1 rad
  Clamped::eval(c, 1e-6, in, h);
  EXPECT_NEAR(dot(h, in.n), 0.0, 1e-18);
  EXPECT_NEAR(norm(h), 1e-6, 1e-18);
}

TEST(ContactModels, ClampedNormalForceIsNeverAttractive) {
  const auto c = paper_coeffs(0.2);
  ContactInput in = oblique(0.0);
  in.v_rel = {0.0, 0.0, 5.0};  // separating fast: the damping term exceeds the spring
  Vec3 h{};
  EXPECT_LT(Full::eval(c, 1e-6, in, h).fn, 0.0) << "the default model turns attractive here";
  h = {};
  EXPECT_EQ(Clamped::eval(c, 1e-6, in, h).fn, 0.0);
}

TEST(ContactModels, RollingTorqueOpposesRelativeSpinWithMagnitudeMuRRFn) {
  const auto c = paper_coeffs(0.2, 0.1);
  Vec3 h{};
  const auto in = oblique(0.0);
  const auto f = Full::eval(c, 1e-6, in, h);
  EXPECT_NEAR(norm(f.roll), 0.1 * in.r_eff * std::fabs(f.fn), 1e-15);
  EXPECT_LT(dot(f.roll, in.w_rel), 0.0);
  using NoRoll = ContactModel<HertzNormal<false>, TangentialHistory, NoRolling>;
  h = {};
  EXPECT_EQ(NoRoll::eval(c, 1e-6, in, h).roll, Vec3{});
}
