// The level's side of the multi-level coupling against a scripted coupler (a ROUTER in a thread): the
// bus client, and a grid's statistics across intervals and a checkpoint. The units (face crossings,
// controller forces, insertion and removal) are test_grid_link.cpp.
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
#include <string>
#include <thread>

#include <zmq.hpp>

#include "bus/case_hash.hpp"
#include "bus/channel.hpp"
#include "core/time_steps.hpp"
#include "coupling/client.hpp"
#include "coupling/grid_link.hpp"
#include "coupling_support.hpp"
#include "scene_support.hpp"

using namespace mlcg;
using namespace mlcg::coupling;
using mlcg::sphere_mass;
using namespace mlcg::test;

namespace {

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
