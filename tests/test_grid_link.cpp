// The level's side of the multi-level coupling, unit by unit: face crossings (FaceFlux), controller forces
// (ControllerForces), insertion, removal and occupants (GridLink). The bus client against a scripted coupler
// is test_coupling_client.cpp.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include "core/spheres.hpp"
#include "coupling/cell_stats.hpp"
#include "coupling/controller_forces.hpp"
#include "coupling/face_flux.hpp"
#include "coupling/grid_link.hpp"
#include "coupling_support.hpp"

using namespace mlcg;
using namespace mlcg::coupling;
using namespace mlcg::test;
using mlcg::sphere_mass;

// --- face crossings ---------------------------------------------------------

TEST(FaceFlux, RadiusBins) {
  const std::vector<double> e{1.0, 2.0, 3.0};
  EXPECT_EQ(face_radius_bin(e, 0.5), 0);
  EXPECT_EQ(face_radius_bin(e, 1.0), 0);
  EXPECT_EQ(face_radius_bin(e, 1.5), 0);
  EXPECT_EQ(face_radius_bin(e, 2.0), 1);
  EXPECT_EQ(face_radius_bin(e, 3.0), 1);  // the last edge belongs to the last bin
  EXPECT_EQ(face_radius_bin(e, 9.0), 1);
  EXPECT_EQ(face_radius_bin({2.0, 2.0}, 2.0), 0);  // equal edges: one bin
  EXPECT_EQ(face_radius_bin({2.0}, 2.0), -1);
}

TEST(FaceFlux, ScriptedParticlesFallingThroughFacesGiveExactNetSums) {
  // Two boundary faces side by side at z = 0.02: face 0 over x in [0, 0.01), face 1 over [0.01, 0.02).
  const bus::CouplingGeometry geo(make_grid({0, 0, 0}, 0.01, 2, 1, 2, {1e-3, 2e-3, 3e-3}));
  ASSERT_EQ(geo.faces(), 2u);
  Particles p;
  add(p, {0.005, 0.005, 0.0205}, 1.5e-3, {0.1, 0, -1.0});     // A: down through face 0 (bin 0)
  add(p, {0.015, 0.005, 0.0210}, 2.5e-3, {0, 0.05, -2.0});    // B: down through face 1 (bin 1)
  add(p, {0.015, 0.005, 0.0195}, 3.0e-3, {0, 0, 1.0});        // C: up through face 1 (last edge: bin 1)
  add(p, {0.025, 0.005, 0.0205}, 1.5e-3, {0, 0, -1.0});       // D: beside the box, not counted
  add(p, {0.004, 0.004, 0.0202}, 1.2e-3, {0, 0, -1.0});       // E: down and back up through face 0: net zero
  FaceFlux ff(geo);
  ff.refresh(p, 0.01);
  const double dt = 1e-3;
  for (int s = 0; s < 5; ++s) {
    if (s == 1) p.v[4] = {0, 0, 1.0};  // E turns round below the plane
    drift(p, dt);
    ff.check(p);
  }
  const double mA = p.mass[0], mB = p.mass[1], mC = p.mass[2], mE = p.mass[4];
  EXPECT_DOUBLE_EQ(ff.mass[0], mA);  // E's two crossings cancel
  EXPECT_DOUBLE_EQ(ff.mass[1], mB - mC);
  EXPECT_DOUBLE_EQ(ff.momentum[0], mA * 0.1);
  // E carried -mE down and then +mE up: the net downward flux of momentum is -2 mE.
  EXPECT_DOUBLE_EQ(ff.momentum[2], -mA - 2.0 * mE);
  EXPECT_NEAR(ff.momentum[4], mB * 0.05, 1e-18);
  EXPECT_NEAR(ff.momentum[5], mB * -2.0 - mC * 1.0, 1e-15 * mB);
  // A crossed z = 0.02 half way through its first step, at x = 0.005 + 0.5 dt 0.1.
  EXPECT_NEAR(ff.moment[0], mA * 0.00505, 1e-12 * mA);
  EXPECT_NEAR(ff.moment[1], mA * 0.005, 1e-12 * mA);
  EXPECT_NEAR(ff.moment[2], mA * 0.02, 1e-12 * mA);
  EXPECT_EQ(ff.histogram, (std::vector<int64_t>{1, 0, 0, 0}));  // face-major: f0 b0, f0 b1, f1 b0, f1 b1
  ff.reset();
  EXPECT_EQ(ff.mass, (std::vector<double>{0.0, 0.0}));
  EXPECT_EQ(ff.histogram, (std::vector<int64_t>{0, 0, 0, 0}));
}

TEST(FaceFlux, AnOpenBottomCountsTheBulkRisingIntoTheRegionAndTheFineLeavingDownward) {
  // A 2 x 1 x 2 box of 1 cm cells at z in [0, 0.02); the bottom face of cell (1, 0, 0) is open (a layer over a
  // coarse bulk), the one of cell (0, 0, 0) closed. Faces: top 0, 1; bottom 2.
  auto grid = make_grid({0, 0, 0}, 0.01, 2, 1, 2, {1e-3, 2e-3, 3e-3});
  grid.add_bottom_faces(1);
  const bus::CouplingGeometry geo(grid);
  ASSERT_EQ(geo.faces(), 3u);
  EXPECT_EQ(geo.side_of_face(2), bus::Side::Bottom);
  EXPECT_EQ(geo.face_inward(2), (Vec3{0.0, 0.0, 1.0}));
  EXPECT_EQ(geo.normal_axis(2), 2);
  EXPECT_EQ(geo.side_face(1, bus::Side::Bottom), 2);
  EXPECT_EQ(geo.side_face(0, bus::Side::Bottom), -1);
  EXPECT_DOUBLE_EQ(geo.depth_inside(bus::Side::Bottom, {0.015, 0.005, 0.003}), 0.003);
  Vec3 lo, hi;
  geo.face_slab(2, 0.004, lo, hi);
  EXPECT_EQ(lo, (Vec3{0.01, 0.0, 0.0}));
  EXPECT_EQ(hi, (Vec3{0.02, 0.01, 0.004}));
  EXPECT_EQ(geo.exit_face({0.015, 0.005, -0.002}), 2);  // under the open bottom
  EXPECT_TRUE(geo.below_a_bottom_face({0.015, 0.005, -0.002}));
  EXPECT_FALSE(geo.below_a_bottom_face({0.005, 0.005, -0.002}));  // under the closed one: as without
  Particles p;
  add(p, {0.015, 0.005, -0.0005}, 1.5e-3, {0, 0, 1.0});  // up through the open bottom: in
  add(p, {0.015, 0.005, 0.0005}, 2.5e-3, {0, 0, -1.0});  // down through it: out
  add(p, {0.005, 0.005, -0.0005}, 1.5e-3, {0, 0, 1.0});  // up through the closed bottom: not counted
  FaceFlux ff(geo);
  ff.refresh(p, 0.01);
  for (int s = 0; s < 2; ++s) {
    drift(p, 1e-3);
    ff.check(p);
  }
  EXPECT_DOUBLE_EQ(ff.mass[2], p.mass[0] - p.mass[1]);
  EXPECT_EQ(ff.mass[0] + ff.mass[1], 0.0);
  EXPECT_EQ(ff.histogram, (std::vector<int64_t>{0, 0, 0, 0, 1, -1}));
  // The fine level: a centre under the open bottom has left the region; under the closed one it has not.
  GridLink fine(0, grid, Role::Fine);
  EXPECT_TRUE(fine.leaves({0.015, 0.005, -0.001}));
  EXPECT_FALSE(fine.leaves({0.005, 0.005, -0.001}));
  EXPECT_FALSE(fine.leaves({0.015, 0.005, 0.001}));
  // The traction of the bottom face presses the particles within the fade depth above it upward, as the top
  // face's presses those under it downward: the same traction, the same depth, the same force mirrored.
  grid.set_fade_depth(0.004);
  const bus::CouplingGeometry faded(grid);
  Particles q;
  add(q, {0.015, 0.005, 0.001}, 1e-3);  // 1 mm above the open bottom
  add(q, {0.015, 0.005, 0.019}, 1e-3);  // 1 mm under the top face of the same column
  add(q, {0.015, 0.005, 0.010}, 1e-3);  // beyond both fade depths
  add(q, {0.005, 0.005, 0.001}, 1e-3);  // above the closed bottom
  ControllerForces cf(faded);
  cf.set_traction({0.0, 100.0, 100.0}, {});
  cf.normalise(q, Comm{});
  q.clear_forces();
  cf.apply(q);
  EXPECT_GT(q.f[0].z, 0.0);
  EXPECT_DOUBLE_EQ(q.f[0].z, -q.f[1].z);
  EXPECT_EQ(q.f[0].x, 0.0);
  EXPECT_EQ(q.f[2], Vec3{});
  EXPECT_EQ(q.f[3], Vec3{});
}

TEST(FaceFlux, ParticlesBornInsideTheRegionCountAsEntered) {
  // Faces at z = 0.02 over x in [0, 0.01) and [0.01, 0.02); a coarse level that pours into the region
  // itself hands that mass over as if it had crossed.
  const bus::CouplingGeometry geo(make_grid({0, 0, 0}, 0.01, 2, 1, 2, {1e-3, 2e-3, 3e-3}));
  Particles p;
  add(p, {0.015, 0.005, 0.005}, 2.5e-3, {0, 0, -3.0});  // inside, column of face 1
  add(p, {0.005, 0.005, 0.025}, 1.5e-3, {0, 0, -3.0});  // above the boundary surface: crosses later
  add(p, {0.035, 0.005, 0.005}, 1.5e-3, {0, 0, -3.0});  // beside the box
  FaceFlux ff(geo);
  for (size_t i = 0; i < 3; ++i) ff.add_born(p.x[i], p.v[i], p.mass[i], p.radius[i]);
  EXPECT_EQ(ff.mass, (std::vector<double>{0.0, p.mass[0]}));
  EXPECT_DOUBLE_EQ(ff.momentum[5], -3.0 * p.mass[0]);
  EXPECT_DOUBLE_EQ(ff.moment[3], 0.015 * p.mass[0]);
  EXPECT_EQ(ff.histogram, (std::vector<int64_t>{0, 0, 0, 1}));
}

TEST(FaceFlux, UpwardCrossingSubtracts) {
  const bus::CouplingGeometry geo(make_grid({0, 0, 0}, 0.01, 1, 1, 1, {1e-3, 2e-3}));
  Particles p;
  add(p, {0.005, 0.005, 0.0099}, 1.5e-3, {0, 0, 1.0});
  FaceFlux ff(geo);
  ff.refresh(p, 0.005);
  drift(p, 1e-3);
  ff.check(p);
  EXPECT_DOUBLE_EQ(ff.mass[0], -p.mass[0]);
  EXPECT_DOUBLE_EQ(ff.momentum[2], -p.mass[0]);
  EXPECT_EQ(ff.histogram[0], -1);
}

// A particle falling in at 2 m/s and a slightly lighter one rising out at 1.5 m/s: the net sums nearly cancel,
// the two-way sums (mass and mass times speed) add.
TEST(FaceFlux, CrossingsBothWaysAddToTheGrossMassAndSpeedSums) {
  const bus::CouplingGeometry geo(make_grid({0, 0, 0}, 0.01, 1, 1, 1, {1e-3, 2e-3}));
  Particles p;
  add(p, {0.003, 0.005, 0.0101}, 1.5e-3, {0, 0, -2.0});
  add(p, {0.007, 0.005, 0.0099}, 1.45e-3, {0.3, 0, 1.5});
  FaceFlux ff(geo);
  ff.refresh(p, 0.005);
  drift(p, 1e-3);
  ff.check(p);
  const double m0 = p.mass[0], m1 = p.mass[1];
  EXPECT_DOUBLE_EQ(ff.mass[0], m0 - m1);
  EXPECT_DOUBLE_EQ(ff.gross_mass[0], m0 + m1);
  EXPECT_NEAR(ff.speed_mass[0], m0 * 2.0 + m1 * std::hypot(0.3, 1.5), 1e-15);
  EXPECT_GT(std::fabs(ff.momentum[2] / ff.mass[0]), 20.0) << "the net mean is far faster than either particle";
  ff.reset();
  EXPECT_EQ(ff.gross_mass[0], 0.0);
  EXPECT_EQ(ff.speed_mass[0], 0.0);
}

// --- controller forces -------------------------------------------------------

TEST(ControllerForces, TractionOfACellSumsToTh2AndFadesToZero) {
  auto grid = make_grid({0, 0, 0}, 0.01, 2, 2, 2);
  grid.set_fade_depth(0.003);
  const bus::CouplingGeometry geo(grid);
  const double top = geo.top(), h = geo.cell_size();
  Particles p;
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int i = 0; i < 3000; ++i)  // over the whole box, depths 0 .. 6 mm, denser than a packed layer
    add(p, {0.02 * u(rng), 0.02 * u(rng), top - 0.006 * u(rng)}, 4e-4 + 4e-4 * u(rng));
  ControllerForces cf(geo);
  const std::vector<double> T{120.0, 0.0, 35.5, 1e4};
  cf.set_traction(T, {});
  cf.normalise(p, Comm{});
  p.clear_forces();
  cf.apply(p);
  std::vector<double> sum(4, 0.0);
  int faded = 0;
  for (size_t i = 0; i < p.n_local(); ++i) {
    const double s = top - p.x[i].z;
    if (s >= 0.003) {
      EXPECT_EQ(p.f[i], Vec3{}) << "particle " << i << " at depth " << s;
      ++faded;
      continue;
    }
    EXPECT_EQ(p.f[i].x, 0.0);
    EXPECT_EQ(p.f[i].y, 0.0);
    sum[static_cast<size_t>(geo.face_column(p.x[i]))] += p.f[i].z;
  }
  EXPECT_GT(faded, 50);
  // After a rebuild's refresh the pass visits only the particles near the faded zone: same forces.
  const std::vector<Vec3> all_visited(p.f.begin(), p.f.begin() + static_cast<long>(p.n_local()));
  cf.refresh(p, 1e-4);
  p.clear_forces();
  cf.apply(p);
  for (size_t i = 0; i < p.n_local(); ++i) EXPECT_EQ(p.f[i], all_visited[i]) << "particle " << i;
  for (size_t f = 0; f < 4; ++f) {
    EXPECT_GT(cf.weight_sums()[f], 0.0);
    if (T[f] == 0.0) EXPECT_EQ(sum[f], 0.0);
    else EXPECT_NEAR(sum[f], -T[f] * h * h, 1e-12 * T[f] * h * h) << "face " << f;
  }
}

// Weight of the sparsest layer that takes the whole traction (volume fraction 0.4, flush with the
// boundary, so its centres lie one radius r or more below it) over a cell of side h, fade depth D.
double floor_weight(double h, double D, double r) { return 0.4 * h * h * (D - r) * (D - r) / (2.0 * D); }

TEST(ControllerForces, ASparseLayerGetsNoMoreForcePerParticleThanALooseLayer) {
  auto grid = make_grid({0, 0, 0}, 0.01, 1, 1, 1);
  grid.set_fade_depth(0.003);
  const bus::CouplingGeometry geo(grid);
  Particles p;
  add(p, {0.005, 0.005, geo.top() - 0.001}, 5e-4);  // one particle at depth 1 mm
  ControllerForces cf(geo);
  cf.set_traction({200.0}, {});
  cf.normalise(p, Comm{});
  p.clear_forces();
  cf.apply(p);
  const double w = 4.0 / 3.0 * M_PI * 1.25e-10 * (1.0 - 1.0 / 3.0), packed = floor_weight(0.01, 0.003, 5e-4);
  EXPECT_NEAR(p.f[0].z, -200.0 * 1e-4 * w / packed, 1e-12);
  EXPECT_LT(std::fabs(p.f[0].z), 0.01 * 200.0 * 1e-4) << "not the whole traction on one particle";
}

TEST(ControllerForces, SpeedLimitRemovesTheAcceleratingComponent) {
  auto grid = make_grid({0, 0, 0}, 0.01, 1, 1, 1);
  grid.set_fade_depth(0.004);
  const bus::CouplingGeometry geo(grid);
  Particles p;
  add(p, {0.005, 0.005, 0.009}, 5e-4, {0, 0, -1.0});  // falling faster than the limit: F would speed it up
  add(p, {0.004, 0.005, 0.009}, 5e-4, {0, 0, 1.0});   // rising faster: F slows it, kept
  add(p, {0.006, 0.005, 0.009}, 5e-4, {1.0, 0, -1.0});  // oblique: only the part along v goes
  add(p, {0.005, 0.004, 0.009}, 5e-4, {0, 0, -0.2});  // below the limit: kept
  ControllerForces cf(geo);
  cf.set_traction({500.0}, {0.5});
  cf.normalise(p, Comm{});
  p.clear_forces();
  cf.apply(p);
  // Equal weights w, spread over at least a loose layer (see the sparse-layer test).
  const double w = 4.0 / 3.0 * M_PI * 1.25e-10 * 0.75;
  const double full = -500.0 * 1e-4 * w / std::max(4.0 * w, floor_weight(0.01, 0.004, 5e-4));
  EXPECT_EQ(p.f[0], Vec3{});
  EXPECT_NEAR(p.f[1].z, full, 1e-12 * std::fabs(full));
  EXPECT_NEAR(dot(p.f[2], p.v[2]), 0.0, 1e-15);
  EXPECT_NEAR(p.f[2].x, 0.5 * full, 1e-12 * std::fabs(full));
  EXPECT_NEAR(p.f[2].z, 0.5 * full, 1e-12 * std::fabs(full));
  EXPECT_NEAR(p.f[3].z, full, 1e-12 * std::fabs(full));
}

// The candidates a rebuild lists for the open sides are only those that may reach a side face's fade zone
// before the next rebuild (a particle moves less than the band in each axis). Particles moved up to the band
// after the refresh, many of them into another cell: the listed pass presses every particle exactly as a pass
// over all of them (the same weight sums, the same forces to the bit).
TEST(ControllerForces, TheSideCandidatesOfARefreshPressAsEveryParticleAfterMovesWithinTheBand) {
  auto grid = make_grid({0, 0, 0}, 0.01, 3, 3, 3);
  grid.set_fade_depth(0.004);
  // Side faces on some cells of the box's sides only (the rest closed): +x of cell (2,0,0), -y of (2,0,1),
  // -x of (0,1,1), +y of (1,2,2), each code 4 c + d.
  for (uint32_t code : {4 * 2 + 1, 4 * 11 + 2, 4 * 12 + 0, 4 * 25 + 3}) grid.add_side_faces(code);
  const bus::CouplingGeometry geo(grid);
  ASSERT_EQ(geo.faces(), 13u);
  std::vector<double> traction(geo.faces());
  for (size_t f = 0; f < traction.size(); ++f) traction[f] = 50.0 + 10.0 * static_cast<double>(f);
  Particles p;
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int i = 0; i < 6000; ++i) add(p, {0.03 * u(rng), 0.03 * u(rng), 0.03 * u(rng)}, 3e-4 + 3e-4 * u(rng));
  const double band = 1e-3;
  ControllerForces listed(geo), every(geo);
  listed.refresh(p, band);
  int changed_cell = 0;
  for (size_t i = 0; i < p.n_local(); ++i) {
    const int before = geo.locate(p.x[i]);
    p.x[i] += Vec3{0.99 * band * (2.0 * u(rng) - 1.0), 0.99 * band * (2.0 * u(rng) - 1.0),
                   0.99 * band * (2.0 * u(rng) - 1.0)};
    changed_cell += geo.locate(p.x[i]) != before;
  }
  EXPECT_GT(changed_cell, 500) << "the moves must carry many particles into other cells";
  for (ControllerForces* cf : {&listed, &every}) {
    cf->set_traction(traction, {});
    cf->normalise(p, Comm{});
  }
  EXPECT_EQ(listed.weight_sums(), every.weight_sums());
  p.clear_forces();
  every.apply(p);
  const std::vector<Vec3> f_every(p.f.begin(), p.f.begin() + static_cast<long>(p.n_local()));
  p.clear_forces();
  listed.apply(p);
  int pressed_sideways = 0;
  for (size_t i = 0; i < p.n_local(); ++i) {
    EXPECT_EQ(p.f[i], f_every[i]) << "particle " << i << " at " << p.x[i].x << " " << p.x[i].y << " " << p.x[i].z;
    pressed_sideways += p.f[i].x != 0.0 || p.f[i].y != 0.0;
  }
  EXPECT_GT(pressed_sideways, 100);
}

TEST(ControllerForces, CoarseCellAccelerationIsMassTimesA) {
  const bus::CouplingGeometry geo(make_grid({0, 0, 0}, 0.01, 2, 1, 1));
  Particles p;
  add(p, {0.005, 0.005, 0.005}, 1e-3);
  add(p, {0.015, 0.005, 0.005}, 2e-3);
  add(p, {0.025, 0.005, 0.005}, 1e-3);  // outside the box
  ControllerForces cf(geo);
  cf.set_acceleration({1.0, 2.0, -3.0, 0.0, 0.0, 4.5});
  EXPECT_TRUE(cf.active());
  p.clear_forces();
  cf.apply(p);
  EXPECT_EQ(p.f[0], (p.mass[0] * Vec3{1.0, 2.0, -3.0}));
  EXPECT_EQ(p.f[1], (p.mass[1] * Vec3{0.0, 0.0, 4.5}));
  EXPECT_EQ(p.f[2], Vec3{});
  EXPECT_THROW(cf.set_acceleration({1.0, 2.0}), std::invalid_argument);
}

// --- insertion, removal, occupants -------------------------------------------

TEST(GridLink, InsertionListRemovalAndOccupantsAreCounted) {
  auto grid = make_grid({0, 0, 0}, 0.01, 2, 2, 2);
  grid.set_insert_depth(0.004);
  grid.add_side_faces(4 * 3 + 1);  // the vessel goes on beyond the +x side of cell (1, 1, 0): a boundary face there
  GridLink fine(0, grid, Role::Fine);
  bus::GridCommands c;
  c.set_grid(0);
  c.set_want_occupants(true);
  for (double v : {0.005, 0.005, 0.018, 1e-3, 0.0, 0.0, -0.5, 0.015, 0.012, 0.018, 1.5e-3, 0.1, 0.0, -0.4}) c.add_insert(v);
  const auto list = GridLink::parse_inserts(c, 2, kRho, 40);
  ASSERT_EQ(list.size(), 2u);
  EXPECT_EQ(list[0].id, 40);
  EXPECT_EQ(list[1].id, 41);
  EXPECT_EQ(list[1].material, 2);
  EXPECT_EQ(list[1].radius, 1.5e-3);
  EXPECT_EQ(list[1].v, (Vec3{0.1, 0.0, -0.4}));
  bus::GridCommands bad = c;
  bad.mutable_insert()->RemoveLast();
  EXPECT_THROW(GridLink::parse_inserts(bad, 0, kRho, 0), std::invalid_argument);
  bad = c;
  bad.set_insert(3, 0.0);
  EXPECT_THROW(GridLink::parse_inserts(bad, 0, kRho, 0), std::invalid_argument);

  Particles p;
  for (const auto& pi : list) p.add(pi);
  add(p, {0.005, 0.005, 0.002}, 1e-3);  // deep in the region: not an occupant
  const double m_in = sphere_mass(kRho, 1e-3) + sphere_mass(kRho, 1.5e-3);
  fine.begin_interval(&c, p, Comm{}, list.size(), m_in);
  EXPECT_TRUE(fine.leaves({0.005, 0.005, 0.0201}));   // above the boundary surface
  EXPECT_TRUE(fine.leaves({0.021, 0.015, 0.005}));    // beside the box, through its open side
  // Beside a side that is no boundary face the box lies outside the vessel: a particle there left the vessel
  // (a stream off a belt's end), not the region into the coarse level's part of it; it is no hand-back.
  EXPECT_FALSE(fine.leaves({0.021, 0.015, 0.015}));   // beside cell (1, 1, 1): no face on its +x side
  EXPECT_FALSE(fine.leaves({-0.001, 0.005, 0.01}));
  EXPECT_FALSE(fine.leaves({0.005, 0.021, 0.01}));
  EXPECT_FALSE(fine.leaves({0.005, 0.005, -0.01}));   // below the box: still falling through the fine level
  EXPECT_FALSE(fine.leaves({0.005, 0.005, 0.0199}));
  // Left upward through the face above (0.005, 0.005) and sideways through the open side: each
  // goes back to the face it left by (the top faces of the 2 x 2 columns, then the side face).
  const int f0 = fine.geometry().face_column({0.005, 0.005, 0.0});
  ASSERT_GE(f0, 0);
  ASSERT_EQ(fine.geometry().faces(), 5u);
  fine.count_removed({0.005, 0.005, 0.0201}, 0.25);
  fine.count_removed({0.021, 0.015, 0.005}, 0.5);
  const bus::GridStats g = fine.finish(p, Comm{}, 1.5e-3);
  ASSERT_EQ(static_cast<size_t>(g.face_returned_mass_size()), fine.geometry().faces());
  for (int f = 0; f < g.face_returned_mass_size(); ++f)
    EXPECT_DOUBLE_EQ(g.face_returned_mass(f), f == f0 ? 0.25 : f == 4 ? 0.5 : 0.0) << "face " << f;
  double in_region = 0.0;  // summed here over the box [0, 0.02)^3, independently of the grid's cell lookup
  for (size_t i = 0; i < p.n_local(); ++i)
    if (p.x[i].z >= 0.0 && p.x[i].z < 0.02 && p.x[i].x >= 0.0 && p.x[i].x < 0.02 && p.x[i].y >= 0.0 && p.x[i].y < 0.02)
      in_region += p.mass[i];
  EXPECT_DOUBLE_EQ(g.mass_in_region(), in_region);
  EXPECT_EQ(g.grid(), 0u);
  EXPECT_EQ(g.inserted(), 2u);
  EXPECT_DOUBLE_EQ(g.inserted_mass(), m_in);
  EXPECT_EQ(g.removed(), 2u);
  EXPECT_DOUBLE_EQ(g.removed_mass(), 0.75);
  ASSERT_EQ(g.occupants_size(), 8);
  EXPECT_EQ(g.occupants(2), 0.018);
  EXPECT_EQ(g.occupants(7), 1.5e-3);
  EXPECT_EQ(g.face_mass_size(), 0);
  EXPECT_EQ(g.cell_stress_size(), 6 * 8);
  EXPECT_EQ(g.cell_volume_fraction_size(), 8);

  EXPECT_FALSE(GridLink(1, make_grid({0, 0, 0}, 0.01, 1, 1, 1, {1e-3, 2e-3}), Role::Coarse).leaves({0, 0, 1.0}));
  EXPECT_THROW(GridLink(1, grid, Role::Coarse), std::invalid_argument);  // no radius bins
}

// --- cell statistics -----------------------------------------------------------
// The coupler asks for some faces' slabs only ([coupling] retry_full_every above 1): every particle a sphere the
// planner may place in those slabs can touch is reported (checked against random candidate spheres, each
// particle tested directly), far fewer than with every face's slabs, and the reply names the faces.
TEST(GridLink, OccupantsOfTheAskedFacesCoverEveryParticleACandidateInTheirSlabsCanTouch) {
  auto grid = make_grid({0, 0, 0}, 0.01, 3, 3, 2);
  grid.set_insert_depth(0.004);
  grid.add_side_faces(4 * 5 + 1);  // +x side of cell (2, 1, 0)
  const bus::CouplingGeometry geo(grid);
  ASSERT_EQ(geo.faces(), 10u);
  const std::vector<uint32_t> asked{4, 9};  // the middle top face and the side face
  const double r_max = 6e-4;
  Particles p;
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int i = 0; i < 20000; ++i)
    add(p, {0.032 * u(rng) - 0.001, 0.032 * u(rng) - 0.001, 0.022 * u(rng)}, r_max * (0.5 + 0.5 * u(rng)));
  const auto reported = [&](const std::vector<uint32_t>& faces) {
    GridLink fine(0, grid, Role::Fine);
    bus::GridCommands c;
    c.set_grid(0);
    c.set_want_occupants(true);
    for (uint32_t f : faces) c.add_occupant_faces(f);
    fine.begin_interval(&c, p, Comm{}, 0, 0.0);
    const bus::GridStats g = fine.finish(p, Comm{}, r_max);
    EXPECT_EQ(std::vector<uint32_t>(g.occupant_faces().begin(), g.occupant_faces().end()), faces);
    std::vector<Vec3> out;
    for (int i = 0; i + 3 < g.occupants_size(); i += 4)
      out.push_back({g.occupants(i), g.occupants(i + 1), g.occupants(i + 2)});
    return out;
  };
  const auto some = reported(asked), all = reported({});
  EXPECT_LT(3 * some.size(), all.size()) << "two faces' slabs of ten";
  const auto listed = [&](const Vec3& x) {
    return std::any_of(some.begin(), some.end(), [&](const Vec3& y) { return y == x; });
  };
  int touching = 0;
  for (const uint32_t f : asked)
    for (int k = 0; k < 300; ++k) {
      // A candidate as the planner draws it: radius up to r_max, the whole sphere inside the slab along its normal.
      const double r = r_max * (0.5 + 0.5 * u(rng));
      Vec3 lo, hi;
      geo.face_slab(f, grid.insert_depth(), lo, hi);
      const int axis = geo.normal_axis(f);
      lo[axis] += r;
      hi[axis] -= r;
      const Vec3 x{lo.x + (hi.x - lo.x) * u(rng), lo.y + (hi.y - lo.y) * u(rng), lo.z + (hi.z - lo.z) * u(rng)};
      for (size_t i = 0; i < p.n_local(); ++i)
        if (norm2(p.x[i] - x) < (r + p.radius[i]) * (r + p.radius[i])) {
          ++touching;
          EXPECT_TRUE(listed(p.x[i])) << "face " << f << ": particle " << i << " touches a candidate, not reported";
        }
    }
  EXPECT_GT(touching, 500);
  EXPECT_THROW(
      {
        GridLink fine(0, grid, Role::Fine);
        bus::GridCommands c;
        c.add_occupant_faces(10);
        fine.begin_interval(&c, p, Comm{}, 0, 0.0);
      },
      std::invalid_argument);
}


// The coupler reads the stress of every cell that holds a boundary face, the top's and an open side's (the
// transition layer's controllers): those cells carry the stress of Eq. 8, summed here particle by particle;
// a cell without a face carries none.
TEST(CellStats, EveryBoundaryFacesCellCarriesItsStressAndNoOtherCellDoes) {
  auto grid = make_grid({0, 0, 0}, 0.01, 2, 2, 2);
  grid.add_side_faces(4 * 3 + 1);  // +x side of cell (1, 1, 0)
  const bus::CouplingGeometry geo(grid);
  ASSERT_EQ(geo.faces(), 5u);
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(0.0005, 0.0195), s(-1.0, 1.0);
  Particles p;
  for (int k = 0; k < 800; ++k) add(p, {u(rng), u(rng), u(rng)}, 4e-4, {0.2 * s(rng), 0.2 * s(rng), -0.3 + 0.1 * s(rng)});
  std::vector<double> stress6(6 * p.size());
  for (double& v : stress6) v = 1e-7 * s(rng);
  CellStats cs(geo);
  cs.sample(p, stress6, Comm{});
  const CellMeans m = cs.take();
  ASSERT_EQ(m.stress.size(), 6 * geo.cells());
  std::vector<char> has_face(geo.cells(), 0);
  for (size_t f = 0; f < geo.faces(); ++f) has_face[geo.cell_of_face(f)] = 1;
  ASSERT_EQ(has_face[3], 1);  // the open side's cell, below the top layer
  for (size_t c = 0; c < geo.cells(); ++c) {
    double mass = 0.0, want[6] = {0, 0, 0, 0, 0, 0};
    Vec3 mom;
    const auto in_cell = [&](size_t i) { return geo.locate(p.x[i]) == static_cast<int>(c); };
    for (size_t i = 0; i < p.size(); ++i)
      if (in_cell(i)) {
        mass += p.mass[i];
        mom += p.mass[i] * p.v[i];
      }
    ASSERT_GT(mass, 0.0) << "cell " << c;
    const Vec3 mean = mom / mass;
    const double vol = 1e-6 * std::max(geo.inside_volume(c), CellStats::kMinInside);
    for (size_t i = 0; i < p.size(); ++i)
      if (in_cell(i)) {
        const Vec3 w = p.v[i] - mean;
        const double k[6] = {w.x * w.x, w.y * w.y, w.z * w.z, w.x * w.y, w.x * w.z, w.y * w.z};
        for (int q = 0; q < 6; ++q) want[q] += (p.mass[i] * k[q] + stress6[6 * i + q]) / vol;
      }
    for (int q = 0; q < 6; ++q) {
      const double got = m.stress[6 * c + q];
      if (has_face[c]) EXPECT_NEAR(got, want[q], 1e-9 * (std::fabs(want[q]) + 1.0)) << "cell " << c << " component " << q;
      else EXPECT_EQ(got, 0.0) << "cell " << c << " component " << q;
    }
    for (int q = 0; q < 3; ++q) EXPECT_NEAR(m.velocity[3 * c + q], mean[q], 1e-12) << "cell " << c;
  }
}
