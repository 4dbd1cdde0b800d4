// The level's side of the multi-level coupling: face crossings, controller
// forces, insertion and removal, and the bus client against a scripted coupler
// (a ROUTER in a thread).
#include <gtest/gtest.h>

#include <unistd.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <cmath>
#include <functional>
#include <future>
#include <memory>
#include <numbers>
#include <random>
#include <string>
#include <thread>

#include <zmq.hpp>

#include "bus/case_hash.hpp"
#include "bus/channel.hpp"
#include "core/time_steps.hpp"
#include "coupling/client.hpp"
#include "coupling/controller_forces.hpp"
#include "coupling/face_flux.hpp"
#include "coupling/grid_link.hpp"
#include "scene_support.hpp"

using namespace mlcg;
using namespace mlcg::coupling;
using mlcg::sphere_mass;

namespace {

constexpr double kRho = 1000.0;

bus::CouplingGrid make_grid(Vec3 o, double h, uint32_t nx, uint32_t ny, uint32_t nz, std::vector<double> bins = {}) {
  bus::CouplingGrid g;
  g.set_ox(o.x);
  g.set_oy(o.y);
  g.set_oz(o.z);
  g.set_cell_size(h);
  g.set_nx(nx);
  g.set_ny(ny);
  g.set_nz(nz);
  for (uint32_t c = 0; c < nx * ny * nz; ++c) g.add_cells(c);
  for (double b : bins) g.add_radius_bins(b);
  return g;
}

void add(Particles& p, Vec3 x, double r, Vec3 v = {}) {
  ParticleInit pi;
  pi.id = static_cast<int64_t>(p.size());
  pi.radius = r;
  pi.density = kRho;
  pi.x = x;
  pi.v = v;
  p.add(pi);
}

void drift(Particles& p, double dt) {
  for (size_t i = 0; i < p.n_local(); ++i) p.x[i] += dt * p.v[i];
}

std::string endpoint(const char* tag) {
  return "ipc:///tmp/mlcg_test_" + std::to_string(::getpid()) + "_" + tag + ".ipc";
}

// Removes the socket file of an ipc:// endpoint when the test ends.
struct IpcCleanup {
  std::string ep;
  ~IpcCleanup() {
    std::error_code ec;
    std::filesystem::remove(ep.substr(6), ec);
  }
};

}  // namespace

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

// --- the bus client against a scripted coupler ---------------------------------

namespace {

struct Recorded {
  bus::Register reg;
  std::string reg_peer;
  std::vector<bus::IntervalStats> stats;
  bool bye = false, bye_failed = false;
  std::string bye_reason, error;
  int heartbeats = 0;
};

// Receives one message from `ch` (skipping heartbeats, which it counts), or fails the script.
bus::Incoming next(bus::Channel& ch, Recorded& r, double seconds = 20.0) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (std::chrono::steady_clock::now() < end) {
    auto in = ch.receive(std::chrono::milliseconds(100));
    if (!in) continue;
    if (!in->ok()) throw std::runtime_error("script: bad message: " + in->error);
    if (in->env.has_heartbeat()) {
      ++r.heartbeats;
      continue;
    }
    return *in;
  }
  throw std::runtime_error("script: nothing received");
}

bus::Envelope welcome_env(double interval, double timeout, double heartbeat) {
  bus::Envelope env;
  bus::Welcome& w = *env.mutable_welcome();
  w.set_level_index(1);
  w.set_level_count(3);
  w.set_coupling_interval(interval);
  w.set_seed(5);
  w.set_start_interval(0);
  w.set_heartbeat_seconds(heartbeat);
  w.set_timeout_seconds(timeout);
  // Grid 0: this level (1) is the fine level under level 0. Top z = 0, 16 faces.
  auto g0 = make_grid({-0.008, -0.008, -0.008}, 0.004, 4, 4, 2, {2e-3, 3e-3});
  g0.set_coarse_level(0);
  g0.set_fine_level(1);
  g0.set_insert_depth(0.004);
  g0.set_fade_depth(0.002);
  *w.add_grids() = g0;
  // Grid 1: this level is the coarse level over level 2. Top z = -0.005, 16 faces, 2 radius bins.
  auto g1 = make_grid({-0.01, -0.01, -0.01}, 0.005, 4, 4, 1, {1e-3, 1.4e-3, 2e-3});
  g1.set_coarse_level(1);
  g1.set_fine_level(2);
  *w.add_grids() = g1;
  // Grid 2 does not concern this level.
  auto g2 = make_grid({-0.01, -0.01, -0.01}, 0.005, 1, 1, 1, {1e-3, 2e-3});
  g2.set_coarse_level(0);
  g2.set_fine_level(2);
  *w.add_grids() = g2;
  return env;
}

config::CaseSpec client_case() {
  auto cs = test::load("collision/head_on.toml");  // level "fine", zero gravity, two particles of r = 1.4 mm
  cs.levels[0].dt = 5e-6;
  cs.particles[0].position = {-0.004, 0.0, -0.006};
  cs.particles[1].position = {0.004, 0.0, -0.006};
  cs.particles[0].velocity = cs.particles[1].velocity = {};
  auto riser = cs.particles[0];  // leaves the fine region (grid 0) upward
  riser.position = {0.0, 0.004, -0.0008};
  riser.velocity = {0.0, 0.0, 20.0};
  auto faller = cs.particles[0];  // crosses grid 1's boundary face 5 downward in interval 0
  faller.position = {-0.0025, -0.0025, -0.0047};
  faller.velocity = {0.0, 0.0, -10.0};
  cs.particles.push_back(riser);
  cs.particles.push_back(faller);
  return cs;
}

// The coupler on `ep` in a thread: `body` runs once a level registered (errors go to rec.error).
// Returns once the coupler is bound.
std::thread scripted_coupler(const std::string& ep, Recorded& rec,
                             std::function<void(bus::Channel&, const bus::Incoming&)> body) {
  std::promise<void> bound;
  auto ready = bound.get_future();
  std::thread t([&rec, ep, body = std::move(body), bound = std::move(bound)]() mutable {
    bool told = false;
    try {
      zmq::context_t ctx;
      bus::Channel ch(ctx, bus::Channel::Role::Router, ep, {});
      bound.set_value();
      told = true;
      body(ch, next(ch, rec));
    } catch (const std::exception& e) {
      rec.error = e.what();
      if (!told) bound.set_value();
    }
  });
  ready.wait();
  return t;
}

// Level 'fine''s client of the coupler at `ep` (not yet registered).
std::unique_ptr<Client> fine_client(const Comm& comm, const std::string& ep, double timeout = 60.0) {
  ClientOptions o;
  o.endpoint = ep;
  o.level_name = "fine";
  o.timeout = timeout;
  return std::make_unique<Client>(comm, o);
}

bus::Register registration() {
  bus::Register reg;
  reg.set_level_name("fine");
  return reg;
}

}  // namespace

TEST(GridLink, WhatFollowsTheStatisticsCountsIntoTheNextOnesAndSurvivesACheckpoint) {
  // [coupling] lead: a level builds its statistics before the interval ends. The crossings and removals of the
  // steps after finish() belong to the next statistics; a checkpoint at the interval's end carries them
  // (pending / set_pending), and a link restored from them reports what the uninterrupted one does.
  const auto grid = make_grid({0, 0, 0}, 0.01, 2, 1, 2, {1e-3, 2e-3, 3e-3});
  GridLink coarse(0, grid, Role::Coarse);
  Particles p;
  add(p, {0.005, 0.005, 0.0205}, 1.5e-3, {0.1, 0, -1.0});  // A: through face 0 before the statistics
  add(p, {0.015, 0.005, 0.0230}, 2.5e-3, {0, 0, -1.0});    // B: through face 1 after them
  coarse.refresh(p, 0.01);
  const double dt = 1e-3;
  drift(p, dt);
  coarse.after_drift(p);
  const bus::GridStats first = coarse.finish(p, Comm{}, 3e-3);
  ASSERT_EQ(first.face_mass_size(), 2);
  EXPECT_DOUBLE_EQ(first.face_mass(0), p.mass[0]);
  EXPECT_EQ(first.face_mass(1), 0.0);
  for (int s = 0; s < 4; ++s) {  // the interval's last steps: B crosses
    drift(p, dt);
    coarse.after_drift(p);
  }
  GridLink restored(0, grid, Role::Coarse);
  restored.set_pending(coarse.pending());
  EXPECT_DOUBLE_EQ(restored.pending_mass(), p.mass[1]);
  EXPECT_THROW(restored.set_pending(std::vector<double>(3, 0.0)), std::invalid_argument);
  const bus::GridStats next = coarse.finish(p, Comm{}, 3e-3), again = restored.finish(p, Comm{}, 3e-3);
  EXPECT_EQ(next.face_mass(0), 0.0) << "A counted once";
  EXPECT_DOUBLE_EQ(next.face_mass(1), p.mass[1]);
  EXPECT_DOUBLE_EQ(next.face_momentum(5), -p.mass[1]);
  EXPECT_EQ(next.face_histogram(3), 1);  // face 1, bin 1 (2.5 mm)
  EXPECT_EQ(again.SerializeAsString(), next.SerializeAsString());

  // Fine role: a removal after the statistics is returned to its face in the next ones, through a checkpoint too.
  auto fg = make_grid({0, 0, 0}, 0.01, 2, 2, 2);
  fg.set_insert_depth(0.004);
  GridLink fine(0, fg, Role::Fine), fine_restored(0, fg, Role::Fine);
  Particles q;
  add(q, {0.005, 0.005, 0.019}, 1e-3, {0.0, 0.2, -0.5});  // in the insertion slab, moving
  fine.begin_interval(nullptr, q, Comm{}, 0, 0.0);
  // Sent 2 ms before the interval's end: the occupant is where its velocity takes it by then.
  const bus::GridStats sent = fine.finish(q, Comm{}, 1e-3, 0.002);
  ASSERT_EQ(sent.occupants_size(), 4);
  EXPECT_DOUBLE_EQ(sent.occupants(1), 0.005 + 0.2 * 0.002);
  EXPECT_DOUBLE_EQ(sent.occupants(2), 0.019 - 0.5 * 0.002);
  fine.count_removed({0.005, 0.005, 0.0201}, 0.25);
  fine_restored.set_pending(fine.pending());
  const bus::GridStats f1 = fine.finish(q, Comm{}, 1e-3), f2 = fine_restored.finish(q, Comm{}, 1e-3);
  const int f0 = fine.geometry().face_column({0.005, 0.005, 0.0});
  EXPECT_DOUBLE_EQ(f1.face_returned_mass(f0), 0.25);
  EXPECT_EQ(f1.removed(), 1u);
  EXPECT_EQ(f2.face_returned_mass(f0), f1.face_returned_mass(f0));
  EXPECT_EQ(f2.removed(), 1u);
  EXPECT_EQ(f2.removed_mass(), f1.removed_mass());
}

TEST(CouplingClient, ScriptedCouplerRunsThreeIntervals) {
  const std::string ep = endpoint("run");
  const IpcCleanup cleanup{ep};
  const auto cs = client_case();
  const double dt = 5e-6, interval = 10 * dt, r_in = 1e-3;
  Recorded rec;
  std::promise<void> bound;
  std::thread coupler([&] {
    try {
      zmq::context_t ctx;
      bus::Channel ch(ctx, bus::Channel::Role::Router, ep, {});
      bound.set_value();
      bus::Incoming in = next(ch, rec);
      if (!in.env.has_register_level()) throw std::runtime_error("script: expected register");
      rec.reg = in.env.register_level();
      rec.reg_peer = in.peer;
      ch.send(welcome_env(interval, 10.0, 0.2), in.peer);
      for (uint64_t k = 0; k < 3; ++k) {
        bus::Envelope env;
        bus::IntervalCommands& c = *env.mutable_commands();
        c.set_interval(k);
        if (k == 0) {  // two fine particles just below grid 0's boundary surface
          bus::GridCommands& g = *c.add_grids();
          g.set_grid(0);
          g.set_want_occupants(true);
          for (double v : {0.004, 0.004, -0.0015, r_in, 0.0, 0.0, 0.0, -0.004, -0.004, -0.002, r_in, 0.0, 0.0, 0.0})
            g.add_insert(v);
        }
        if (k == 1) {  // a traction on the fine level, zero accelerations on the coarse one
          bus::GridCommands& g = *c.add_grids();
          g.set_grid(0);
          for (int f = 0; f < 16; ++f) {
            g.add_traction(f == 15 ? 50.0 : 0.0);
            g.add_speed_limit(1.0);
          }
          bus::GridCommands& a = *c.add_grids();
          a.set_grid(1);
          for (int v = 0; v < 48; ++v) a.add_acceleration(0.0);
        }
        c.set_stop(k == 2);
        ch.send(env, in.peer);
        bus::Incoming s = next(ch, rec);
        if (!s.env.has_stats()) throw std::runtime_error("script: expected stats");
        rec.stats.push_back(s.env.stats());
      }
      bus::Incoming b = next(ch, rec);
      if (!b.env.has_bye()) throw std::runtime_error("script: expected bye");
      rec.bye = true;
      rec.bye_failed = b.env.bye().failed();
      rec.bye_reason = b.env.bye().reason();
    } catch (const std::exception& e) {
      rec.error = e.what();
    }
  });
  bound.get_future().wait();
  LevelOptions opt = test::quiet();
  opt.level = "fine";
  opt.coupler = ep;
  RunStatus status = RunStatus::Failed;
  double m_faller = 0.0, m_particle = 0.0;
  MassBalance mb;
  uint64_t steps = 0;
  {
    Level level(cs, opt);
    EXPECT_TRUE(level.coupled());
    m_particle = level.particles().mass[0];
    m_faller = level.particles().mass[3];
    status = level.run();
    steps = level.step();
    mb = level.mass_balance();
  }
  coupler.join();
  ASSERT_EQ(rec.error, "");
  EXPECT_EQ(status, RunStatus::Completed);
  EXPECT_EQ(steps, 30u);

  EXPECT_EQ(rec.reg_peer, "fine");
  EXPECT_EQ(rec.reg.level_name(), "fine");
  EXPECT_EQ(rec.reg.dt(), dt);
  EXPECT_EQ(rec.reg.alpha(), 1.0);
  EXPECT_EQ(rec.reg.ranks(), 1u);
  EXPECT_EQ(rec.reg.start_interval(), 0u);
  EXPECT_EQ(rec.reg.case_hash(), bus::case_hash(cs.path));
  EXPECT_EQ(rec.reg.case_hash().size(), 16u);

  ASSERT_EQ(rec.stats.size(), 3u);
  uint64_t removed = 0;
  double removed_mass = 0.0;
  for (uint64_t k = 0; k < 3; ++k) {
    const auto& s = rec.stats[k];
    EXPECT_EQ(s.interval(), k);
    EXPECT_NEAR(s.sim_time(), (k + 1) * interval, 1e-15);
    ASSERT_EQ(s.grids_size(), 2);  // grids 0 and 1, not grid 2
    const auto& fine = s.grids(0);
    const auto& coarse = s.grids(1);
    EXPECT_EQ(fine.grid(), 0u);
    EXPECT_EQ(coarse.grid(), 1u);
    // Face arrays only from the coarse role; cell arrays from both.
    EXPECT_EQ(fine.face_mass_size(), 0);
    EXPECT_EQ(coarse.face_mass_size(), 16);
    EXPECT_EQ(coarse.face_momentum_size(), 48);
    EXPECT_EQ(coarse.face_moment_size(), 48);
    EXPECT_EQ(coarse.face_histogram_size(), 32);
    EXPECT_EQ(fine.cell_stress_size(), 6 * 32);
    EXPECT_EQ(fine.cell_velocity_size(), 3 * 32);
    EXPECT_EQ(coarse.cell_stress_size(), 6 * 16);
    EXPECT_EQ(coarse.cell_max_speed_size(), 16);
    EXPECT_EQ(fine.occupants_size() % 4, 0);
    EXPECT_EQ(coarse.occupants_size(), 0);
    EXPECT_EQ(fine.inserted(), k == 0 ? 2u : 0u);
    removed += fine.removed();
    removed_mass += fine.removed_mass();
  }
  const double m_in = sphere_mass(1000.0, r_in);
  EXPECT_NEAR(rec.stats[0].grids(0).inserted_mass(), 2 * m_in, 1e-15 * m_in);
  EXPECT_GE(rec.stats[0].grids(0).occupants_size(), 8);  // the two inserted particles at least
  EXPECT_EQ(removed, 1u);                                // the riser
  EXPECT_DOUBLE_EQ(removed_mass, m_particle);
  // The faller crossed grid 1's face 5 downward in interval 0 (radius 1.4 mm: bin 1 of [1, 1.4, 2] mm).
  const auto& c0 = rec.stats[0].grids(1);
  EXPECT_DOUBLE_EQ(c0.face_mass(5), m_faller);
  EXPECT_DOUBLE_EQ(c0.face_momentum(3 * 5 + 2), -10.0 * m_faller);
  EXPECT_NEAR(c0.face_moment(3 * 5 + 2), -0.005 * m_faller, 1e-12 * m_faller);
  EXPECT_EQ(c0.face_histogram(2 * 5 + 1), 1);
  double crossed = 0.0;
  for (double m : c0.face_mass()) crossed += m;
  EXPECT_DOUBLE_EQ(crossed, m_faller);
  // Interval 2: four particles of 1.4 mm and two of 1 mm sit in grid 0's cells at every sample.
  const auto& f2 = rec.stats[2].grids(0);
  const double h3 = 0.004 * 0.004 * 0.004;
  double volume = 0.0;
  for (double phi : f2.cell_volume_fraction()) volume += phi * h3;
  const double v14 = 4.0 / 3.0 * std::numbers::pi * 1.4e-3 * 1.4e-3 * 1.4e-3, v10 = 4.0 / 3.0 * std::numbers::pi * 1e-9;
  EXPECT_NEAR(volume, 3 * v14 + 2 * v10, 1e-12 * volume);  // the two at rest, the faller, the inserted pair
  EXPECT_TRUE(rec.bye);
  EXPECT_FALSE(rec.bye_failed);
  EXPECT_NE(rec.bye_reason.find("finished"), std::string::npos) << rec.bye_reason;
  // Coupled insertion and removal keep the level's mass balance.
  EXPECT_EQ(mb.inserted, mb.present + mb.removed);
  EXPECT_EQ(mb.inserted, 6);
  EXPECT_EQ(mb.removed, 1);
}

TEST(CouplingClient, RefusedRegistrationStopsWithTheCouplersReason) {
  const std::string ep = endpoint("refused");
  const IpcCleanup cleanup{ep};
  Recorded rec;
  std::thread coupler = scripted_coupler(ep, rec, [](bus::Channel& ch, const bus::Incoming& in) {
    bus::Envelope env;
    env.mutable_refused()->set_reason("level 'fine' runs another case (hash 0123456789abcdef)");
    ch.send(env, in.peer);
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  });
  LevelOptions opt = test::quiet();
  opt.coupler = ep;
  std::string what;
  try {
    Level level(client_case(), opt);
  } catch (const std::runtime_error& e) {
    what = e.what();
  }
  coupler.join();
  EXPECT_EQ(rec.error, "");
  EXPECT_NE(what.find("refused"), std::string::npos) << what;
  EXPECT_NE(what.find("runs another case (hash 0123456789abcdef)"), std::string::npos) << what;
}

TEST(CouplingClient, SilentCouplerTimesOutNamingTheEndpointAfterHeartbeats) {
  const std::string ep = endpoint("silent");
  const IpcCleanup cleanup{ep};
  Recorded rec;
  std::atomic<bool> done{false};
  std::thread coupler = scripted_coupler(ep, rec, [&](bus::Channel& ch, const bus::Incoming& in) {
    ch.send(welcome_env(1e-4, 0.6, 0.1), in.peer);
    while (!done) {  // never sends commands; counts the heartbeats
      if (auto m = ch.receive(std::chrono::milliseconds(50)); m && m->ok() && m->env.has_heartbeat()) ++rec.heartbeats;
    }
  });
  Comm serial;
  const auto client = fine_client(serial, ep, 5.0);
  const bus::Welcome w = client->handshake(registration());
  EXPECT_EQ(w.grids_size(), 3);
  EXPECT_EQ(client->timeout(), 0.6);
  EXPECT_EQ(client->heartbeat(), 0.1);
  std::string what;
  const auto t0 = std::chrono::steady_clock::now();
  try {
    client->commands(0, 0.0, 0);
  } catch (const CouplingError& e) {
    what = e.what();
  }
  const double waited = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  done = true;
  coupler.join();
  EXPECT_EQ(rec.error, "");
  EXPECT_NE(what.find(ep), std::string::npos) << what;
  EXPECT_NE(what.find("timeout"), std::string::npos) << what;
  EXPECT_NE(what.find("interval 0"), std::string::npos) << what;
  EXPECT_GE(waited, 0.55);
  EXPECT_LT(waited, 3.0);
  EXPECT_GE(rec.heartbeats, 3);
}

// Found by fuzzing the level's side of the bus (tests/fuzz/fuzz_bus_level): a Welcome whose interval is more than
// 2^63 steps made the conversion to a step count undefined; it is no whole number of steps.
TEST(CouplingClient, AnIntervalOfMoreThan2To63StepsIsNoWholeNumberOfSteps) {
  EXPECT_EQ(whole_steps(8e-5, 1e-5), 8u);
  EXPECT_EQ(whole_steps(0x1p63 * 1e-5, 1e-5), uint64_t{1} << 63);
  EXPECT_EQ(whole_steps(1e300, 1e-5), 0u);
  EXPECT_EQ(whole_steps(INFINITY, 1e-5), 0u);
}

// A Welcome's timeout of 1e300 s means "wait for ever": the level waits for the commands instead of
// timing out at once (the wait's deadline overflowed the clock).
TEST(CouplingClient, AWelcomeTimeoutOf1e300SecondsWaitsForTheCommands) {
  const std::string ep = endpoint("forever");
  const IpcCleanup cleanup{ep};
  Recorded rec;
  std::thread coupler = scripted_coupler(ep, rec, [](bus::Channel& ch, const bus::Incoming& in) {
    ch.send(welcome_env(1e-4, 1e300, 0.1), in.peer);
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    bus::Envelope env;
    env.mutable_commands()->set_interval(0);
    ch.send(env, in.peer);
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  });
  Comm serial;
  const auto client = fine_client(serial, ep);
  client->handshake(registration());
  std::string what;
  try {
    EXPECT_EQ(client->commands(0, 0.0, 0).interval(), 0u);
  } catch (const CouplingError& e) {
    what = e.what();
  }
  coupler.join();
  EXPECT_EQ(rec.error, "");
  EXPECT_EQ(what, "");
}
