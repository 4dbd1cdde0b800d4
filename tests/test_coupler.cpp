// The coupler's logic without sockets: controllers, insertion planner and one
// interval of Coupler::advance, driven by scripted level statistics; hostile
// statistics and damaged checkpoints refused. Also the grid a case's region gives (from_case.hpp).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "config/case_parser.hpp"
#include "coupler.hpp"
#include "from_case.hpp"

using namespace mlcg;
using namespace mlcg::coupling;

namespace {

// A 3 x 3 x 2 box of 2 cm cells at the origin; every cell active.
bus::CouplingGrid small_grid(uint32_t coarse = 0, uint32_t fine = 1) {
  bus::CouplingGrid g;
  g.set_coarse_level(coarse);
  g.set_fine_level(fine);
  g.set_cell_size(0.02);
  g.set_nx(3);
  g.set_ny(3);
  g.set_nz(2);
  for (uint32_t c = 0; c < 18; ++c) g.add_cells(c);
  g.set_insert_depth(0.011);
  g.set_fade_depth(0.0042);
  g.add_radius_bins(2.8e-3);
  g.add_radius_bins(2.8e-3);
  return g;
}

PlannerParams planner_params() {
  PlannerParams p;
  p.ratio = 2.0;
  p.density = 1000.0;
  p.insert_depth = 0.011;
  p.radius_bins = {2.8e-3, 2.8e-3};
  p.seed = 7;
  return p;
}

// A coarse and a fine level over the small grid.
CouplerConfig two_levels() {
  CouplerConfig cfg;
  cfg.levels = {{"coarse", 2.0, 1e-5, 1}, {"fine", 1.0, 5e-6, 1}};
  cfg.interval = 8e-5;
  RegionConfig rc;
  rc.grid = small_grid();
  rc.planner = planner_params();
  cfg.regions.push_back(rc);
  return cfg;
}

bool inside_box(const Vec3&, const Vec3& x, double r) {
  return x.x - r > 0.0 && x.x + r < 0.06 && x.y - r > 0.0 && x.y + r < 0.06;
}

// Coarse statistics: every face crossed by `mass` kg downward at velocity v.
void face_flux(bus::GridStats& g, const bus::CouplingGeometry& geo, double mass, const Vec3& v) {
  for (size_t f = 0; f < geo.faces(); ++f) {
    const Vec3 c = geo.cell_centre(geo.cell_of_face(f));
    g.add_face_mass(mass);
    for (double q : {mass * v.x, mass * v.y, mass * v.z}) g.add_face_momentum(q);
    for (double q : {mass * c.x, mass * c.y, mass * geo.top()}) g.add_face_moment(q);
    g.add_face_histogram(static_cast<int64_t>(std::lround(mass / (1000.0 * 4.0 / 3.0 * M_PI * std::pow(2.8e-3, 3)))));
  }
}

void cells(bus::GridStats& g, const bus::CouplingGeometry& geo, double szz, double phi, const Vec3& v, double vmax) {
  for (size_t c = 0; c < geo.cells(); ++c) {
    for (double s : {0.5 * szz, 0.5 * szz, szz, 0.0, 0.0, 0.0}) g.add_cell_stress(s);
    g.add_cell_volume_fraction(phi);
    for (double q : {v.x, v.y, v.z}) g.add_cell_velocity(q);
    g.add_cell_max_speed(vmax);
  }
}

}  // namespace

// Plant for the PI tests: the fine cell's stress follows its own part plus the
// traction with a lag of a few intervals (the bed's dynamic response).
struct LagPlant {
  double own = 40.0, stress = 40.0, lag = 0.2;
  double respond(double traction) { return stress += lag * (own + traction - stress); }
};

TEST(PiController, StepOfTenTimesSettlesWithoutGrowingOscillationAndWithinItsLimit) {
  PiController pi;
  pi.limit = 5000.0;
  LagPlant plant;
  const double dt = 8e-5;
  double setpoint = 100.0;
  std::vector<double> err;
  double peak_stress = 0.0;
  for (int k = 0; k < 6000; ++k) {
    if (k == 2000) setpoint = 1000.0;  // a 10x step
    const double u = pi.update(setpoint, plant.stress, dt);
    ASSERT_GE(u, 0.0);
    ASSERT_LE(u, pi.limit);
    plant.respond(u);
    if (k >= 2000) {
      err.push_back(std::fabs(setpoint - plant.stress));
      peak_stress = std::max(peak_stress, plant.stress);
    }
  }
  // The error envelope (largest error per 100 intervals) never grows after the step.
  double prev = 1e300;
  for (size_t w = 0; w + 100 <= err.size(); w += 100) {
    const double env = *std::max_element(err.begin() + static_cast<long>(w), err.begin() + static_cast<long>(w + 100));
    EXPECT_LE(env, prev * (1.0 + 1e-9)) << "envelope grew in window " << w / 100;
    prev = env;
  }
  EXPECT_LT(err.back(), 1e-3 * setpoint);
  EXPECT_LE(peak_stress, 1.05 * setpoint) << "overshoot above 5 %";
}

TEST(PiController, NoWindupWhileSaturated) {
  PiController pi;
  pi.limit = 100.0;
  const double dt = 8e-5;
  LagPlant plant;
  plant.own = 0.0;
  // Unreachable setpoint for 10,000 intervals: output pinned at the limit.
  for (int k = 0; k < 10000; ++k) plant.respond(pi.update(1e6, plant.stress, dt));
  EXPECT_DOUBLE_EQ(pi.output, 100.0);
  EXPECT_LE(pi.ki * pi.integral, pi.limit) << "the integral wound up";
  // A reachable setpoint below the current stress: the output drops below the
  // limit at once instead of unwinding a huge integral, and settles.
  EXPECT_LT(pi.update(50.0, plant.stress, dt), 100.0);
  for (int k = 0; k < 4000; ++k) plant.respond(pi.update(50.0, plant.stress, dt));
  EXPECT_NEAR(plant.stress, 50.0, 0.05);
}

TEST(VelocityController, PushesTowardTheTargetAndScalesByVolumeFraction) {
  VelocityController vc;
  vc.gain = 10.0;
  vc.ki = 0.0;
  vc.limit = 5.0;
  Vec3 integral{};
  const Vec3 a = vc.update({0, 0, -0.2}, {0, 0, -0.1}, integral, 1e-4);
  EXPECT_NEAR(a.z, -1.0, 1e-12);
  const Vec3 big = vc.update({0, 0, -10.0}, {0, 0, 0}, integral, 1e-4);
  EXPECT_NEAR(norm(big), 5.0, 1e-12);
  // Mass flow: phi_f = 0.6, phi_c = 0.5 -> the coarse level must move 1.2x faster.
  const Vec3 t = correction_target({0, 0, -0.1}, 0.6, 0.5, true);
  EXPECT_NEAR(t.z, -0.12, 1e-15);
  EXPECT_NEAR(correction_target({0, 0, -0.1}, 0.6, 0.5, false).z, -0.1, 1e-15);
}

// A coarse cell whose particles resist the correction with a constant deceleration d (a jam at an
// orifice): dv/dt = a - d, advanced over coupling intervals. A proportional controller settles at the
// lag d / gain; the integral removes it; with ki <= gain^2 / 4 (real poles) only the PI's zero makes
// the response overshoot, by a few per cent of the step.
TEST(VelocityController, IntegralRemovesTheLagOfAResistingCell) {
  const double dt = 8e-5, d = 2.0, target = -0.2;
  auto settle = [&](double ki, double& peak) {
    VelocityController vc;
    vc.ki = ki;
    Vec3 integral{}, v{};
    peak = 0.0;
    for (int k = 0; k < 5000; ++k) {  // 0.4 s
      const Vec3 a = vc.update({0, 0, target}, v, integral, dt);
      v.z += (a.z + d) * dt;          // the resistance opposes the downward motion
      peak = std::min(peak, v.z);
    }
    return v.z;
  };
  double peak_p = 0.0, peak_pi = 0.0;
  const double v_p = settle(0.0, peak_p), v_pi = settle(25000.0, peak_pi);
  EXPECT_NEAR(v_p - target, d / 500.0, 1e-6) << "proportional alone lags by d / gain";
  EXPECT_NEAR(v_pi, target, 1e-6) << "the integral removes the lag";
  EXPECT_GT(peak_pi, 1.05 * target) << "real poles: the overshoot stays below 5 % of the step";
  // Saturated output (an unreachable target): the integral does not wind up.
  VelocityController vc;
  Vec3 integral{};
  for (int k = 0; k < 1000; ++k) vc.update({0, 0, -100.0}, {}, integral, dt);
  EXPECT_EQ(integral.z, 0.0);
}

TEST(InsertionPlanner, MassIsConservedExactlyPerFaceAndNothingOverlaps) {
  const bus::CouplingGeometry geo(small_grid());
  InsertionPlanner planner(geo, planner_params(), inside_box);
  const double m_coarse = 1000.0 * 4.0 / 3.0 * M_PI * std::pow(2.8e-3, 3);
  std::vector<Sphere> occupants;
  std::mt19937_64 rng(3);
  // Fine particles already in the slab (some), which new ones must avoid.
  std::uniform_real_distribution<double> u(0.0, 0.06), uz(0.029, 0.039);
  for (int i = 0; i < 60; ++i) occupants.push_back({{u(rng), u(rng), uz(rng)}, 1.4e-3});
  std::vector<Sphere> all = occupants;
  size_t total = 0;
  double sent = 0.0;                                     // per face: what this test's coarse level sent
  std::vector<double> planned(geo.faces(), 0.0);         // per face: the mass of the particles planned there
  const double m_fine = 1000.0 * 4.0 / 3.0 * M_PI * std::pow(1.4e-3, 3);
  for (uint64_t k = 0; k < 40; ++k) {
    bus::GridStats g;
    sent += (k % 3 == 0 ? 1.0 : 0.3) * m_coarse;
    face_flux(g, geo, (k % 3 == 0 ? 1.0 : 0.3) * m_coarse, {0.0, 0.0, -0.5});
    planner.add_crossings({g.face_mass().begin(), g.face_mass().end()},
                          {g.face_momentum().begin(), g.face_momentum().end()},
                          {g.face_moment().begin(), g.face_moment().end()},
                          {g.face_histogram().begin(), g.face_histogram().end()});
    const auto ins = planner.plan(k + 1, all);
    for (const auto& p : ins) {
      EXPECT_NEAR(p.r, 1.4e-3, 1e-15);
      EXPECT_LE(p.x.z, geo.top() - p.r + 1e-15);
      EXPECT_GE(p.x.z, geo.top() - 0.011 + p.r - 1e-15);
      EXPECT_NEAR(p.v.z, -0.5, 1e-12);
      for (const auto& q : all) EXPECT_GE(norm(p.x - q.x), p.r + q.r) << "overlap at interval " << k;
      all.push_back({p.x, p.r});
      ASSERT_EQ(geo.face_column(p.x), p.face) << "a particle planned outside its face's column";
      planned[static_cast<size_t>(p.face)] += 1000.0 * 4.0 / 3.0 * M_PI * p.r * p.r * p.r;
    }
    total += ins.size();
    // Particles drift down out of the slab between intervals.
    for (auto& s : all) s.x.z -= 0.004;
  }
  EXPECT_GT(total, 100u);
  // Each face against what was sent and what was planned, counted here: the ledger must match both, and
  // less than one fine particle's mass may stay unplaced (the slab never fills in this scene).
  for (size_t f = 0; f < geo.faces(); ++f) {
    const FaceState& s = planner.faces()[f];
    EXPECT_NEAR(s.crossed, sent, 1e-12 * sent) << "face " << f;
    EXPECT_NEAR(s.inserted, planned[f], 1e-12 * sent) << "face " << f;
    EXPECT_GE(sent - planned[f], -1e-12 * sent) << "face " << f << " placed more than was sent";
    EXPECT_LT(sent - planned[f], m_fine * (1.0 + 1e-12)) << "face " << f << " kept more than one particle's mass";
  }
}

// A wall across the grid at x = 4.5 cm (the vessel on its low side): the top faces over x 4-6 cm are half
// outside it. Coarse mass crosses them twice: first one-way (its mean inside, at x = 4.2 cm), then both ways,
// whose net mean falls outside (x = 5.5 cm), as on wide_cone_junction's side faces. That mean must not become
// the faces' anchor: from an anchor outside the walls, a sphere outside them is reachable, and was placed there.
TEST(InsertionPlanner, AnAnchorOutsideTheWallsIsNotTakenSoNothingIsPlacedOutside) {
  bus::CouplingGrid grid = small_grid();
  for (double v : {0.01, 0.01, 0.03}) grid.add_inside_point(v);
  const bus::CouplingGeometry geo(grid);
  const double wall = 0.045;
  const auto fits = [wall](const Vec3& anchor, const Vec3& x, double r) {
    return std::abs(x.x - wall) >= r && (anchor.x < wall) == (x.x < wall);
  };
  InsertionPlanner planner(geo, planner_params(), fits);
  const double m_coarse = 1000.0 * 4.0 / 3.0 * M_PI * std::pow(2.8e-3, 3);
  size_t past_wall_faces = 0, placed_there = 0;
  for (uint64_t k = 0; k < 2; ++k) {
    bus::GridStats g;
    face_flux(g, geo, 20.0 * m_coarse, {0.0, 0.0, -0.5});
    for (size_t f = 0; f < geo.faces(); ++f) {
      if (geo.cell_centre(geo.cell_of_face(f)).x < 0.04 || !geo.is_top(f)) continue;
      past_wall_faces += k == 0;
      g.set_face_moment(3 * f, 20.0 * m_coarse * (k == 0 ? 0.042 : 0.055));
    }
    planner.add_crossings({g.face_mass().begin(), g.face_mass().end()},
                          {g.face_momentum().begin(), g.face_momentum().end()},
                          {g.face_moment().begin(), g.face_moment().end()},
                          {g.face_histogram().begin(), g.face_histogram().end()});
    for (const auto& p : planner.plan(k + 1, {})) {
      EXPECT_LE(p.x.x + p.r, wall + 1e-15) << "a fine particle placed outside the wall, interval " << k;
      placed_there += p.x.x > 0.04;
    }
  }
  ASSERT_EQ(past_wall_faces, 3u);
  EXPECT_GT(placed_there, 0u) << "the faces the wall cuts place their particles on its inside";
  for (size_t f = 0; f < geo.faces(); ++f) {
    if (geo.is_top(f) && geo.cell_centre(geo.cell_of_face(f)).x > 0.04) {
      EXPECT_NEAR(planner.faces()[f].anchor.x, 0.042, 1e-12) << "face " << f;
    }
  }
}

TEST(InsertionPlanner, FullSlabCarriesTheRemainderToLaterIntervals) {
  const bus::CouplingGeometry geo(small_grid());
  InsertionPlanner planner(geo, planner_params(), inside_box);
  const double m_coarse = 1000.0 * 4.0 / 3.0 * M_PI * std::pow(2.8e-3, 3);
  bus::GridStats g;
  face_flux(g, geo, 200.0 * m_coarse, {0, 0, -1});  // far more than the slab holds
  planner.add_crossings({g.face_mass().begin(), g.face_mass().end()},
                        {g.face_momentum().begin(), g.face_momentum().end()},
                        {g.face_moment().begin(), g.face_moment().end()},
                        {g.face_histogram().begin(), g.face_histogram().end()});
  const auto first = planner.plan(1, {});
  std::vector<Sphere> occ;
  std::vector<double> planned(geo.faces(), 0.0);  // per face: the mass of the particles planned there, counted here
  for (const auto& p : first) {
    occ.push_back({p.x, p.r});
    planned[static_cast<size_t>(p.face)] += 1000.0 * 4.0 / 3.0 * M_PI * p.r * p.r * p.r;
  }
  for (size_t k = 0; k < geo.faces(); ++k) {
    const FaceState& f = planner.faces()[k];
    // The ledger against what was sent and what was planned: a full slab keeps the rest, it loses nothing.
    EXPECT_NEAR(f.crossed, 200.0 * m_coarse, 1e-12 * f.crossed) << "face " << k;
    EXPECT_NEAR(f.inserted, planned[k], 1e-12 * f.crossed) << "face " << k;
    EXPECT_GT(200.0 * m_coarse - planned[k], 100.0 * m_coarse) << "the slab cannot hold 1600 fine particles";
    EXPECT_NEAR(f.remainder, 200.0 * m_coarse - planned[k], 1e-12 * f.crossed) << "face " << k;
    EXPECT_EQ(f.short_intervals, 1u);
  }
  // The slab is full: the next interval places (almost) nothing and keeps the mass.
  const auto second = planner.plan(2, occ);
  EXPECT_LT(second.size(), first.size() / 4);
}

// retry_full_every = 4: a face whose slab was full tries (and has its slab reported) only before plans of
// intervals that are multiples of 4; a face that placed last time is reported every interval; a face whose slab
// was not reported does not place, whatever its remainder, and loses nothing.
TEST(InsertionPlanner, AFullSlabIsRetriedEveryNthIntervalAndOnlyReportedFacesPlace) {
  const bus::CouplingGeometry geo(small_grid());
  auto prm = planner_params();
  prm.retry_full_every = 4;
  InsertionPlanner planner(geo, prm, inside_box);
  const double m_coarse = 1000.0 * 4.0 / 3.0 * M_PI * std::pow(2.8e-3, 3);
  const auto cross = [&](double m) {
    bus::GridStats g;
    face_flux(g, geo, m, {0, 0, -1});
    planner.add_crossings({g.face_mass().begin(), g.face_mass().end()},
                          {g.face_momentum().begin(), g.face_momentum().end()},
                          {g.face_moment().begin(), g.face_moment().end()},
                          {g.face_histogram().begin(), g.face_histogram().end()});
  };
  cross(200.0 * m_coarse);  // far more than a slab holds: every face ends its first plan full
  std::vector<Sphere> occ;
  for (const auto& p : planner.plan(1, {})) occ.push_back({p.x, p.r});
  for (const auto& f : planner.faces()) ASSERT_GT(f.short_streak, 0u);
  // Full faces: reported before the plans of intervals 4 and 8 only (asked at the end of 3 and 7).
  for (uint64_t k = 1; k <= 8; ++k) {
    const auto faces = planner.occupant_faces(k);
    EXPECT_EQ(faces.size(), (k + 1) % 4 == 0 ? geo.faces() : 0u) << "interval " << k;
    EXPECT_EQ(planner.wants_occupants(k), !faces.empty()) << "interval " << k;
  }
  // Face 0 alone reported, its slab emptied: it places, no other face does (their remainders stay).
  std::vector<double> before;
  for (const auto& f : planner.faces()) before.push_back(f.remainder);
  const auto placed = planner.plan(4, {}, {0});
  ASSERT_FALSE(placed.empty());
  for (const auto& p : placed) EXPECT_EQ(p.face, 0);
  for (size_t f = 1; f < geo.faces(); ++f) EXPECT_EQ(planner.faces()[f].remainder, before[f]) << "face " << f;
  EXPECT_LT(planner.faces()[0].remainder, before[0]);
  EXPECT_GT(planner.faces()[0].short_streak, 0u) << "its remainder overfills its slab again";
  EXPECT_TRUE(planner.occupant_faces(5).empty());
  EXPECT_EQ(planner.occupant_faces(7).size(), geo.faces());
  // Faces that placed all they had (slabs not full) are reported at every interval while mass crosses.
  InsertionPlanner fresh(geo, prm, inside_box);
  bus::GridStats g;
  face_flux(g, geo, 4.0 * m_coarse, {0, 0, -1});
  fresh.add_crossings({g.face_mass().begin(), g.face_mass().end()},
                      {g.face_momentum().begin(), g.face_momentum().end()},
                      {g.face_moment().begin(), g.face_moment().end()},
                      {g.face_histogram().begin(), g.face_histogram().end()});
  ASSERT_FALSE(fresh.plan(1, {}).empty());
  for (const auto& f : fresh.faces()) ASSERT_EQ(f.short_streak, 0u);
  for (uint64_t k = 1; k <= 4; ++k) EXPECT_EQ(fresh.occupant_faces(k).size(), geo.faces()) << "interval " << k;
  // retry_full_every = 1: every face's slab, as before (an empty list).
  InsertionPlanner every(geo, planner_params(), inside_box);
  EXPECT_TRUE(every.occupant_faces(3).empty());
}

// Crossings that nearly cancel: down 1.00 kg-units at 2 m/s, up 0.98 at 1.5 m/s. The net mean velocity is
// (-2 - 0.98 x 1.5) / 0.02 = -173.5 m/s; the particles are inserted no faster than the crossings' mean speed,
// (2 + 0.98 x 1.5) / 1.98 m/s, along the net direction. One-way crossings keep their mean velocity exactly.
TEST(InsertionPlanner, ANearlyCancellingCrossingInsertsNoFasterThanTheCrossingsMeanSpeed) {
  const bus::CouplingGeometry geo(small_grid());
  const double m = 1000.0 * 4.0 / 3.0 * M_PI * std::pow(2.8e-3, 3), n = 30.0 * m;  // 30 coarse particles' mass
  const size_t nf = geo.faces(), nb = planner_params().radius_bins.size() - 1;
  const auto run = [&](double up, std::vector<double> gross, std::vector<double> speed) {
    InsertionPlanner planner(geo, planner_params(), inside_box);
    std::vector<double> mass(nf), momentum(3 * nf), moment(3 * nf);
    for (size_t f = 0; f < nf; ++f) {
      const Vec3 c = geo.cell_centre(geo.cell_of_face(f));
      mass[f] = n - up * n;
      momentum[3 * f + 2] = -2.0 * n - up * n * 1.5;
      moment[3 * f] = mass[f] * c.x;
      moment[3 * f + 1] = mass[f] * c.y;
      moment[3 * f + 2] = mass[f] * geo.top();
    }
    planner.add_crossings(mass, momentum, moment, std::vector<int64_t>(nb * nf, 1), gross, speed);
    return planner;
  };
  const double bound = (2.0 + 0.98 * 1.5) / 1.98;
  const auto mixed = run(0.98, std::vector<double>(nf, 1.98 * n), std::vector<double>(nf, (2.0 + 0.98 * 1.5) * n));
  const auto unbounded = run(0.98, {}, {});
  for (size_t f = 0; f < nf; ++f) {
    EXPECT_NEAR(mixed.faces()[f].velocity.z, -bound, 1e-12) << "face " << f;
    EXPECT_NEAR(unbounded.faces()[f].velocity.z, -173.5, 1e-9) << "without the two-way sums: the net mean";
    EXPECT_EQ(mixed.faces()[f].bounded, 1u);
    EXPECT_EQ(unbounded.faces()[f].bounded, 0u);
  }
  const auto one_way = run(0.0, std::vector<double>(nf, n), std::vector<double>(nf, 2.0 * n));
  for (size_t f = 0; f < nf; ++f) {
    EXPECT_EQ(one_way.faces()[f].velocity.z, (-2.0 * n) / n) << "face " << f;
    EXPECT_EQ(one_way.faces()[f].bounded, 0u);
  }
  InsertionPlanner planner(geo, planner_params(), inside_box);
  const std::vector<double> zeros(nf), short_one(nf - 1), zeros3(3 * nf);
  EXPECT_THROW(planner.add_crossings(zeros, zeros3, zeros3, std::vector<int64_t>(nb * nf), short_one, zeros),
               std::invalid_argument);
}

TEST(InsertionPlanner, SameSeedSamePlanOtherSeedAnotherPlan) {
  const bus::CouplingGeometry geo(small_grid());
  auto run = [&](uint64_t seed) {
    auto prm = planner_params();
    prm.seed = seed;
    InsertionPlanner planner(geo, prm, inside_box);
    bus::GridStats g;
    face_flux(g, geo, 3e-4, {0.1, 0, -1});
    planner.add_crossings({g.face_mass().begin(), g.face_mass().end()},
                          {g.face_momentum().begin(), g.face_momentum().end()},
                          {g.face_moment().begin(), g.face_moment().end()},
                          {g.face_histogram().begin(), g.face_histogram().end()});
    return planner.plan(5, {});
  };
  const auto a = run(11), b = run(11), c = run(12);
  ASSERT_EQ(a.size(), b.size());
  ASSERT_FALSE(a.empty());
  for (size_t i = 0; i < a.size(); ++i) EXPECT_TRUE(a[i].x == b[i].x);
  EXPECT_FALSE(a[0].x == c[0].x);
}

TEST(Coupler, OneIntervalGivesInsertionTractionAndCorrection) {
  CouplerConfig cfg = two_levels();
  cfg.regions[0].velocity.gain = 10.0;
  const RegionConfig& rc = cfg.regions[0];
  Coupler coupler(cfg, inside_box);
  const auto& geo = coupler.geometry(0);
  ASSERT_EQ(geo.faces(), 9u);
  ASSERT_EQ(geo.cells(), 18u);

  std::vector<bus::IntervalStats> st(2);
  for (auto& s : st) s.set_interval(0);
  auto* cg = st[0].add_grids();
  face_flux(*cg, geo, 2e-4, {0, 0, -0.3});
  cells(*cg, geo, 300.0, 0.5, {0, 0, -0.10}, 0.4);
  auto* fg = st[1].add_grids();
  cells(*fg, geo, 200.0, 0.6, {0, 0, -0.12}, 0.3);
  fg->set_occupants_sent(true);  // an empty slab
  const auto cmds = coupler.advance(0, st);
  ASSERT_EQ(cmds.size(), 2u);
  EXPECT_EQ(cmds[0].interval(), 1u);
  const auto& fine = cmds[1].grids(0);
  EXPECT_EQ(fine.traction_size(), 9);
  EXPECT_EQ(fine.speed_limit_size(), 9);
  EXPECT_GT(fine.insert_size(), 0);
  EXPECT_EQ(fine.insert_size() % 7, 0);
  EXPECT_TRUE(fine.want_occupants()) << "mass keeps crossing: the next plan needs the slab's particles";
  // The fine stress is below the coarse setpoint: positive traction (push down), 0.4 m/s limit.
  const PiController gains;  // the case leaves kp and ki at their defaults
  for (int f = 0; f < 9; ++f) {
    EXPECT_NEAR(fine.traction(f), gains.kp * 100.0 + gains.ki * 100.0 * 8e-5, 1e-9);
    EXPECT_DOUBLE_EQ(fine.speed_limit(f), 0.4);
  }
  // Coarse correction cells (the lower layer only): mass flow target 1.2 x -0.12 = -0.144 m/s.
  const auto& coarse = cmds[0].grids(0);
  ASSERT_EQ(coarse.acceleration_size(), 3 * 18);
  for (size_t c = 0; c < 18; ++c) {
    const double az = coarse.acceleration(static_cast<int>(3 * c + 2));
    if (geo.is_transition(c)) EXPECT_EQ(az, 0.0);
    else EXPECT_NEAR(az, (10.0 + rc.velocity.ki * 8e-5) * (-0.144 + 0.10), 1e-12);  // P + first integral step
  }
  // An interval without crossing and without the slab report: nothing is placed, and with the
  // remainders below a fine particle's mass no report is asked for.
  {
    auto quiet = st;
    for (auto& s : quiet) s.set_interval(1);
    auto* g = quiet[0].mutable_grids(0);
    for (int f = 0; f < g->face_mass_size(); ++f) g->set_face_mass(f, 0.0);
    for (auto& q : *g->mutable_face_momentum()) q = 0.0;
    for (auto& q : *g->mutable_face_moment()) q = 0.0;
    for (auto& q : *g->mutable_face_histogram()) q = 0;
    quiet[1].mutable_grids(0)->set_occupants_sent(false);
    Coupler again(cfg, inside_box);
    auto first = st;
    again.advance(0, first);
    const auto cmds2 = again.advance(1, quiet);
    EXPECT_EQ(cmds2[1].grids(0).insert_size(), 0);
    EXPECT_FALSE(cmds2[1].grids(0).want_occupants());
  }
  // A malformed statistic names the level and the field.
  st[1].mutable_grids(0)->add_cell_volume_fraction(0.1);
  try {
    coupler.advance(1, st);
    FAIL() << "expected an error";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("interval"), std::string::npos) << e.what();
  }
  for (auto& s : st) s.set_interval(1);
  try {
    coupler.advance(1, st);
    FAIL() << "expected an error";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("'fine'"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("cell_volume_fraction"), std::string::npos) << e.what();
  }
}

TEST(Coupler, RefusesALevelWhoseDtDoesNotDivideTheInterval) {
  CouplerConfig cfg;
  cfg.levels = {{"coarse", 2.0, 1e-5, 1}, {"fine", 1.0, 5e-6, 1}};
  cfg.interval = 7.5e-5;
  EXPECT_THROW(Coupler(cfg, inside_box), std::invalid_argument);
}

// ---- hostile statistics and damaged checkpoints (issue 13; found by fuzzing, tests/fuzz) -------

namespace {

// Interval k: mass crossing every face downward, an empty insertion slab.
std::vector<bus::IntervalStats> flowing(const bus::CouplingGeometry& geo, uint64_t k) {
  std::vector<bus::IntervalStats> st(2);
  for (auto& s : st) s.set_interval(k);
  auto* cg = st[0].add_grids();
  face_flux(*cg, geo, 2e-4, {0, 0, -0.3});
  cells(*cg, geo, 300.0, 0.5, {0, 0, -0.10}, 0.4);
  auto* fg = st[1].add_grids();
  cells(*fg, geo, 200.0, 0.6, {0, 0, -0.12}, 0.3);
  fg->set_occupants_sent(true);
  return st;
}

// The message of advancing a fresh coupler with `st` ("" when accepted).
std::string advance_refusal(const std::vector<bus::IntervalStats>& st) {
  Coupler coupler(two_levels(), inside_box);
  try {
    coupler.advance(0, st);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(Coupler, RefusesStatisticsThatAreNotFiniteOrOutOfRangeNamingLevelAndField) {
  const Coupler ref(two_levels(), inside_box);
  const auto st = flowing(ref.geometry(0), 0);
  EXPECT_EQ(advance_refusal(st), "");
  auto with_occupant = [&](std::initializer_list<double> q) {
    auto s = st;
    for (double v : q) s[1].mutable_grids(0)->add_occupants(v);
    return s;
  };
  EXPECT_EQ(advance_refusal(with_occupant({0.03, 0.03, 0.035, 1.4e-3})), "");
  // What the fuzzer found: a NaN occupant (UB in the planner's overlap hash) and a crossing count of
  // 2^63 - 1 (a signed overflow when the counts are summed).
  EXPECT_NE(advance_refusal(with_occupant({0.03, std::nan(""), 0.035, 1.4e-3}))
                .find("level 'fine' region 0: occupants[1] is nan; statistics are finite numbers"),
            std::string::npos);
  auto big = st;
  big[0].mutable_grids(0)->set_face_histogram(0, INT64_MAX);
  EXPECT_NE(advance_refusal(big).find("level 'coarse' region 0: face_histogram[0] counts 9223372036854775807 "
                                      "crossings in one interval"),
            std::string::npos);
  EXPECT_EQ(advance_refusal(with_occupant({1e300, 0.03, 0.035, 1.4e-3})), "") << "far off: of no use, no harm";
  EXPECT_NE(advance_refusal(with_occupant({0.03, 0.03, 0.035, 1e300}))
                .find("level 'fine' region 0: occupant 0 has radius 1e+300 m"),
            std::string::npos);
  auto stress = st;
  stress[0].mutable_grids(0)->set_cell_stress(2, INFINITY);
  EXPECT_NE(advance_refusal(stress).find("level 'coarse' region 0: cell_stress[2] is inf"), std::string::npos);
}

TEST(Coupler, RestoreRefusesADamagedCheckpointNamingRegionAndFace) {
  Coupler coupler(two_levels(), inside_box);
  const auto cmds = coupler.advance(0, flowing(coupler.geometry(0), 0));
  ASSERT_GT(cmds[1].grids(0).insert_size(), 0);
  bus::CouplerCheckpoint saved;
  coupler.save(saved);
  ASSERT_GT(saved.regions(0).last_insert_face_size(), 0);
  const auto refusal = [](const bus::CouplerCheckpoint& c) -> std::string {
    Coupler resumed(two_levels(), inside_box);
    try {
      resumed.restore(c);
      resumed.advance(1, flowing(resumed.geometry(0), 1));
      resumed.cancel_last_insertions();
    } catch (const std::invalid_argument& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_EQ(refusal(saved), "");
  struct Damage {
    std::function<void(bus::RegionCheckpoint&)> apply;
    std::string expect;
  };
  const Damage damages[] = {
      // what the fuzzer found: a face index out of range (a segfault when the levels finish)
      {[](auto& r) { r.set_last_insert_face(0, 4000); },
       "region 0: last_insert_face 4000 is not a face of the grid's 9"},
      {[](auto& r) { r.mutable_faces(2)->set_histogram(0, INT64_MAX); },
       "region 0 face 2: a crossing count of 9223372036854775807; at most 2^50 either way"},
      {[](auto& r) { r.mutable_faces(1)->set_next_radius(-1.0); }, "region 0 face 1: next_radius -1"},
      {[](auto& r) { r.set_pi_integral(3, std::nan("")); }, "region 0: pi_integral[3] is not a finite number"},
      {[](auto& r) { r.set_last_insert(3, 0.0); }, "region 0: last_insert particle 0 has a radius <= 0"},
  };
  for (const auto& d : damages) {
    auto c = saved;
    d.apply(*c.mutable_regions(0));
    const std::string msg = refusal(c);
    EXPECT_NE(msg.find("coupler checkpoint: " + d.expect), std::string::npos) << msg;
    EXPECT_NE(msg.find("the checkpoint is damaged"), std::string::npos) << msg;
  }
}

// The belt feeder's region spans the wedge hopper's neck and the whole belt. With its top 4 cm above the slot
// (1.33 slot widths) its box's centre, half a cell under the top, lies beside the wedge, outside the vessel.
// Counted from there, the cells "inside the walls" were the air around the hopper (69 cells, 79 boundary faces,
// 61 of them sides), and the coupler found no place for a fine particle in 1.6 s. The default point now comes
// from the cells the fill reaches from above: the grid equals the one with `inside` given in the hopper by
// hand, and its point lies inside the wedge.
TEST(CaseCoupling, ARegionWhoseBoxCentreLiesBesideTheHopperIsCountedFromInsideIt) {
  const std::string path = std::string(MLCG_SOURCE_DIR) + "/cases/feeder/mlcg.toml";
  const auto grid_of = [](const config::CaseSpec& cs) { return coupling_from_case(cs).cfg.regions.at(0).grid; };
  config::CaseSpec cs = config::load_case(path);
  ASSERT_FALSE(cs.coupling->regions.at(0).inside.has_value());
  cs.coupling->regions[0].max.z = 0.04;
  const bus::CouplingGrid by_default = grid_of(cs);

  cs.coupling->regions[0].inside = Vec3{0.0, 0.0, 0.03};  // above the slot, by hand
  const bus::CouplingGrid by_hand = grid_of(cs);
  cs.coupling->regions[0].inside = Vec3{0.04, 0.0, 0.03};  // the box's centre: beside the wedge
  const bus::CouplingGrid from_the_centre = grid_of(cs);

  ASSERT_EQ(by_default.inside_point_size(), 3);
  const double x = by_default.inside_point(0), z = by_default.inside_point(2);
  const double half_width = 0.015 + z * std::tan(30.0 * M_PI / 180.0);  // the wedge's walls, 30 deg from vertical
  EXPECT_LT(std::fabs(x), half_width - 0.0014) << "the default point is not inside the wedge";
  EXPECT_EQ(std::vector<uint32_t>(by_default.cells().begin(), by_default.cells().end()),
            std::vector<uint32_t>(by_hand.cells().begin(), by_hand.cells().end()));
  EXPECT_EQ(by_default.cells_size(), 30);
  EXPECT_EQ(from_the_centre.cells_size(), 69);  // what the old default counted
}

// A hole in a side wall under a lid that the case's event removes: beyond the hole lies the outflow, not the
// vessel. The region's sides out there were boundary faces (16 of side_outlet's 33), reachable from the inside
// point through the opened hole; fine particles of the stream leaving through them were handed back and placed
// again under the region's top (0.031 kg in a 1 s run, the run 5 % high). The open sides are now found with the
// lids in place: only the -x side, where the bin goes on, remains (the cells beyond the hole stay active).
TEST(CaseCoupling, TheSidesBeyondASideWallOutletAreNoBoundaryFaces) {
  const config::CaseSpec cs = config::load_case(std::string(MLCG_SOURCE_DIR) + "/cases/outlets/side_outlet/mlcg.toml");
  const bus::CouplingGeometry geo(coupling_from_case(cs).cfg.regions.at(0).grid);
  size_t sides = 0, beyond_the_hole = 0;
  for (size_t f = 0; f < geo.faces(); ++f) {
    if (geo.side_of_face(f) == bus::Side::Top) continue;
    ++sides;
    beyond_the_hole += geo.side_of_face(f) != bus::Side::XLo;
  }
  EXPECT_EQ(beyond_the_hole, 0u) << "of " << sides << " side faces";
  EXPECT_GT(sides, 0u) << "the bin goes on beyond the region's -x side";
  size_t active_beyond = 0;
  for (size_t c = 0; c < geo.cells(); ++c) active_beyond += geo.cell_centre(c).x > 0.06;
  EXPECT_GT(active_beyond, 0u) << "the cells the stream passes beyond the hole";
}
