// The coupler service over a real ZeroMQ socket, driven by scripted levels
// (threads speaking the protocol, no DEM): registration, the interval loop,
// refusal of bad messages, timeouts, determinism and a three-level hierarchy.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <unistd.h>

#include <atomic>
#include <cmath>
#include <filesystem>
#include <thread>

#include <spdlog/sinks/null_sink.h>
#include <spdlog/spdlog.h>

#include "bus/channel.hpp"
#include "files.hpp"
#include "service.hpp"

using namespace mlcg;
using namespace mlcg::coupling;
namespace fs = std::filesystem;
using mlcg::test::read_json;
using mlcg::test::slurp;
using mlcg::test::TempDir;
using std::chrono::milliseconds;

namespace {

constexpr double kR = 1.4e-3;  // fine radius; coarse radii are alpha times it

std::string endpoint() {
  static std::atomic<int> n{0};
  return "ipc:///tmp/mlcg_cpl_" + std::to_string(getpid()) + "_" + std::to_string(n++) + ".ipc";
}

// Removes the socket file of an ipc:// endpoint at the end of its scope (as in test_coupling_client): the
// socket that bound it leaves it behind. Declared before the socket's context, so destroyed after it.
struct IpcCleanup {
  std::string ep;
  ~IpcCleanup() {
    std::error_code ec;
    fs::remove(ep.substr(6), ec);
  }
};

bus::CouplingGrid grid(uint32_t coarse, uint32_t fine, double ratio_coarse_radius, double z0) {
  bus::CouplingGrid g;
  g.set_coarse_level(coarse);
  g.set_fine_level(fine);
  g.set_oz(z0);
  g.set_cell_size(0.02);
  g.set_nx(2);
  g.set_ny(2);
  g.set_nz(2);
  for (uint32_t c = 0; c < 8; ++c) g.add_cells(c);
  g.set_insert_depth(0.012);
  g.set_fade_depth(0.004);
  g.add_radius_bins(ratio_coarse_radius);
  g.add_radius_bins(ratio_coarse_radius);
  return g;
}

// levels: alphas, coarsest first; region l couples level l (coarse) over l + 1.
CouplerConfig config(const std::vector<double>& alphas) {
  CouplerConfig cfg;
  for (size_t l = 0; l < alphas.size(); ++l)
    cfg.levels.push_back({"L" + std::to_string(l), alphas[l], 1e-5 * alphas[l] / alphas.back(), 1});
  cfg.interval = 8e-5 * alphas.front() / alphas.back();
  cfg.heartbeat = 0.05;
  cfg.timeout = 2.0;
  cfg.seed = 99;
  for (size_t l = 0; l + 1 < alphas.size(); ++l) {
    RegionConfig rc;
    rc.grid = grid(static_cast<uint32_t>(l), static_cast<uint32_t>(l + 1), kR * alphas[l], 0.05 * l);
    rc.planner.ratio = alphas[l] / alphas[l + 1];
    rc.planner.radius_bins = {kR * alphas[l], kR * alphas[l]};
    rc.planner.insert_depth = 0.012;
    rc.planner.seed = 5 + l;
    cfg.regions.push_back(rc);
  }
  return cfg;
}

bool fits(const Vec3&, const Vec3& x, double r) {
  return x.x - r > 0.0 && x.x + r < 0.04 && x.y - r > 0.0 && x.y + r < 0.04;
}

struct LevelResult {
  std::string error;           // set when the level was refused or told to stop
  uint64_t intervals = 0;      // commands received
  size_t inserted = 0;         // particles the coupler asked this level to insert
  std::vector<std::vector<double>> received;  // per grid and face: the mass of those particles, counted here
  double traction_sum = 0.0;
  uint64_t heartbeats = 0;     // the coupler's, received while waiting for commands
  std::string waiting_for;     // what the last of them said the coupler waited for
  uint64_t bytes_sent = 0, bytes_received = 0;  // frames of every message, counted on this side
};

// A level without DEM: registers, then answers commands(k) with stats(k). As
// a coarse level it reports a steady downward flux through every face; as a
// fine level the particles it was told to insert, sinking 3 mm per interval.
LevelResult scripted_level(const std::string& ep, const CouplerConfig& cfg, size_t me, const std::string& hash,
                           uint64_t intervals, uint64_t go_silent_after = UINT64_MAX) {
  LevelResult res;
  zmq::context_t ctx;
  bus::Channel ch(ctx, bus::Channel::Role::Dealer, ep, cfg.levels[me].name);
  bus::Envelope reg;
  auto* r = reg.mutable_register_level();
  r->set_level_name(cfg.levels[me].name);
  r->set_alpha(cfg.levels[me].alpha);
  r->set_dt(cfg.levels[me].dt);
  r->set_ranks(1);
  r->set_case_hash(hash);
  const auto send = [&](const bus::Envelope& e) {
    ch.send(e);
    res.bytes_sent += ch.last_send_bytes();
  };
  const auto receive = [&](milliseconds t) {
    auto m = ch.receive(t);
    if (m) res.bytes_received += m->bytes;
    return m;
  };
  send(reg);
  auto in = receive(milliseconds(5000));
  if (!in || !in->env.has_welcome()) {
    res.error = in && in->env.has_refused() ? in->env.refused().reason() : "no welcome";
    return res;
  }
  const bus::Welcome w = in->env.welcome();
  std::vector<bus::CouplingGeometry> geo;
  for (const auto& g : w.grids()) geo.emplace_back(g);
  std::vector<std::vector<Vec3>> mine(geo.size());  // fine particles per region (this level as fine)
  std::vector<bool> want(geo.size(), true);          // the coupler asked for the slab's particles
  for (const auto& g : geo) res.received.emplace_back(g.faces(), 0.0);
  for (uint64_t k = 0; k < intervals; ++k) {
    auto c = receive(milliseconds(5000));
    for (; c && c->env.has_heartbeat(); c = receive(milliseconds(5000))) {
      ++res.heartbeats;
      res.waiting_for = c->env.heartbeat().waiting_for();
    }
    if (!c) { res.error = "no commands"; return res; }
    if (c->env.has_bye()) { res.error = c->env.bye().reason(); return res; }
    if (!c->env.has_commands()) { res.error = std::string("unexpected ") + bus::body_name(c->env); return res; }
    const auto& cmd = c->env.commands();
    EXPECT_EQ(cmd.interval(), k);
    ++res.intervals;
    for (const auto& gc : cmd.grids()) {
      if (w.grids(static_cast<int>(gc.grid())).fine_level() == me) want[gc.grid()] = gc.want_occupants();
      res.inserted += static_cast<size_t>(gc.insert_size() / 7);
      for (int i = 0; i + 6 < gc.insert_size(); i += 7) {
        const Vec3 x{gc.insert(i), gc.insert(i + 1), gc.insert(i + 2)};
        mine[gc.grid()].push_back(x);
        const int f = geo[gc.grid()].face_column(x);  // every face is a top face here
        const double r = gc.insert(i + 3);
        if (f >= 0) res.received[gc.grid()][static_cast<size_t>(f)] += 1000.0 * 4.0 / 3.0 * M_PI * r * r * r;
        else ADD_FAILURE() << "a particle inserted outside every face's column";
      }
      for (double t : gc.traction()) res.traction_sum += t;
    }
    if (k >= go_silent_after) {
      std::this_thread::sleep_for(milliseconds(static_cast<int>(cfg.timeout * 2000)));
      return res;
    }
    bus::Envelope out;
    auto* st = out.mutable_stats();
    st->set_interval(k);
    for (size_t g = 0; g < geo.size(); ++g) {
      const bool coarse = w.grids(static_cast<int>(g)).coarse_level() == me;
      const bool fine = w.grids(static_cast<int>(g)).fine_level() == me;
      if (!coarse && !fine) continue;
      auto* gs = st->add_grids();
      gs->set_grid(static_cast<uint32_t>(g));
      const double stress = coarse ? 300.0 : 100.0 + 0.5 * res.traction_sum / (k + 1);
      for (size_t cell = 0; cell < geo[g].cells(); ++cell) {
        for (double s : {stress, stress, stress, 0.0, 0.0, 0.0}) gs->add_cell_stress(s);
        gs->add_cell_volume_fraction(0.55);
        for (double v : {0.0, 0.0, -0.1}) gs->add_cell_velocity(v);
        gs->add_cell_max_speed(0.5);
      }
      if (coarse) {
        const double rc = cfg.levels[me].alpha * kR, m = 1000.0 * 4.0 / 3.0 * M_PI * rc * rc * rc;
        for (size_t f = 0; f < geo[g].faces(); ++f) {
          const double mf = (k % 4 == 0) ? m : 0.0;  // one coarse particle per face every 4th interval
          const Vec3 x = geo[g].cell_centre(geo[g].cell_of_face(f));
          gs->add_face_mass(mf);
          for (double q : {0.0, 0.0, -0.3 * mf}) gs->add_face_momentum(q);
          for (double q : {mf * x.x, mf * x.y, mf * geo[g].top()}) gs->add_face_moment(q);
          gs->add_face_histogram(mf > 0.0 ? 1 : 0);
        }
      }
      if (fine) {
        for (auto& x : mine[g]) {
          x.z -= 0.003;
          if (want[g])
            for (double q : {x.x, x.y, x.z, kR * cfg.levels[me].alpha}) gs->add_occupants(q);
        }
        gs->set_occupants_sent(want[g]);
      }
    }
    send(out);
  }
  bus::Envelope bye;
  bye.mutable_bye()->set_reason("end time reached");
  send(bye);
  while (receive(milliseconds(300))) {}  // what the coupler sent after our last read (the commands never run)
  return res;
}

struct RunResult {
  int code = -1;
  std::string error;
  uint64_t refused = 0;
  std::vector<LevelResult> levels;
  std::string csv;
  double inserted = 0.0;
  uint64_t placed = 0;
  std::vector<std::vector<FaceState>> faces;  // per region: the coupler's ledger at the end
};

RunResult run_hierarchy(const std::vector<double>& alphas, uint64_t intervals, const fs::path& out,
                  std::function<void(const std::string&)> intruder = {}, size_t silent_level = SIZE_MAX) {
  const CouplerConfig cfg = config(alphas);
  Coupler coupler(cfg, fits);
  const std::string ep = endpoint();
  const IpcCleanup ipc_cleanup{ep};
  zmq::context_t ctx;
  bus::Channel ch(ctx, bus::Channel::Role::Router, ep, {}, 4096 * 16);
  ServiceOptions opt;
  opt.case_hash = "c0ffee";
  opt.out_dir = out;
  Service service(coupler, ch, opt, std::make_shared<spdlog::logger>("t", std::make_shared<spdlog::sinks::null_sink_mt>()));
  RunResult run;
  run.levels.resize(alphas.size());
  std::vector<std::thread> threads;
  // The intruder has its say before the levels register: a run of scripted levels can end within a few of its
  // round trips, and its later messages would then find no coupler.
  std::atomic<bool> intruded{!intruder};
  if (intruder)
    threads.emplace_back([&] {
      intruder(ep);
      intruded = true;
    });
  for (size_t l = 0; l < alphas.size(); ++l)
    threads.emplace_back([&, l] {
      while (!intruded) std::this_thread::sleep_for(milliseconds(1));
      run.levels[l] = scripted_level(ep, cfg, l, "c0ffee", intervals, l == silent_level ? 3 : UINT64_MAX);
    });
  run.code = service.run();
  run.error = service.error();
  for (auto& t : threads) t.join();
  threads.clear();
  for (size_t l = 0; l < run.levels.size(); ++l)
    if (!run.levels[l].error.empty()) run.error += "; level L" + std::to_string(l) + ": " + run.levels[l].error;
  run.refused = service.refused();
  for (auto& t : threads) t.join();
  run.csv = slurp(out / "coupling" / "region0.csv");
  for (size_t r = 0; r + 1 < alphas.size(); ++r) run.faces.push_back(coupler.planner(r).faces());
  for (const auto& fs : coupler.planner(0).faces()) {
    run.inserted += fs.inserted;
    run.placed += fs.placed;
  }
  return run;
}

// Region r of a run of `intervals` against what its scripted levels sent and received, face by face: the
// coarse level sent one particle of its alpha per face every 4th interval; the coupler booked exactly that
// as crossed, booked as inserted exactly what the fine level received there, and kept less than one fine
// particle's mass of it unplaced.
void expect_exact_per_face(const RunResult& run, const std::vector<double>& alphas, size_t r, uint64_t intervals) {
  const double rc = alphas[r] * kR, rf = alphas[r + 1] * kR;
  const double sent = static_cast<double>((intervals + 3) / 4) * 1000.0 * 4.0 / 3.0 * M_PI * rc * rc * rc;
  const double m_fine = 1000.0 * 4.0 / 3.0 * M_PI * rf * rf * rf;
  const auto& received = run.levels[r + 1].received.at(r);
  ASSERT_EQ(run.faces.at(r).size(), received.size());
  for (size_t f = 0; f < received.size(); ++f) {
    const FaceState& s = run.faces[r][f];
    EXPECT_NEAR(s.crossed, sent, 1e-12 * sent) << "region " << r << " face " << f;
    EXPECT_NEAR(s.inserted, received[f], 1e-12 * sent) << "region " << r << " face " << f;
    EXPECT_GE(sent - received[f], -1e-12 * sent) << "region " << r << " face " << f << " received more than sent";
    EXPECT_LT(sent - received[f], m_fine * (1.0 + 1e-12)) << "region " << r << " face " << f << " kept too much";
  }
}

}  // namespace

TEST(CouplerService, TwoScriptedLevelsRunToTheEndWithExactMass) {
  const TempDir out("cpl_two");
  const RunResult run = run_hierarchy({2.0, 1.0}, 60, out.path());
  ASSERT_EQ(run.code, 0) << run.error;
  EXPECT_EQ(run.levels[0].intervals, 60u);
  EXPECT_EQ(run.levels[1].intervals, 60u);
  EXPECT_TRUE(run.levels[0].error.empty());
  // 4 faces x 15 coarse particles of 8 fine ones each, less than one fine particle per face still carried.
  expect_exact_per_face(run, {2.0, 1.0}, 0, 60);
  EXPECT_EQ(run.levels[0].inserted, 0u);
  const double m_fine = 1000.0 * 4.0 / 3.0 * M_PI * kR * kR * kR;
  EXPECT_NEAR(run.inserted, m_fine * static_cast<double>(run.levels[1].inserted), 1e-12 * run.inserted);
  // The list computed after the last interval never ran: the coupler counts only what the level got.
  EXPECT_EQ(run.placed, run.levels[1].inserted);
  EXPECT_GT(run.levels[1].traction_sum, 0.0) << "the fine stress is below the coarse one: the PI must push";
  // One log row per interval the coupler computed (59: the last stats end the run).
  EXPECT_EQ(std::count(run.csv.begin(), run.csv.end(), '\n'), 1 + 60);
}

// The bus load the coupler reports per level (coupling/summary.json) is what the levels counted on
// their side of the socket, to the byte.
TEST(CouplerService, ReportsTheBusBytesEachLevelCounted) {
  const TempDir out("cpl_bytes");
  const RunResult run = run_hierarchy({4.0, 2.0, 1.0}, 25, out.path());
  ASSERT_EQ(run.code, 0) << run.error;
  const auto j = read_json(out / "coupling" / "summary.json");
  ASSERT_EQ(j["levels"].size(), 3u);
  for (size_t l = 0; l < 3; ++l) {
    const auto& lv = j["levels"][l];
    EXPECT_EQ(lv["bytes_from_level"].get<uint64_t>(), run.levels[l].bytes_sent) << lv["name"];
    EXPECT_EQ(lv["bytes_to_level"].get<uint64_t>(), run.levels[l].bytes_received) << lv["name"];
    EXPECT_NEAR(lv["bytes_per_interval_from_level"].get<double>(), run.levels[l].bytes_sent / 25.0,
                1e-9 * run.levels[l].bytes_sent);
  }
  // The middle level reports two grids, so it sends the most.
  EXPECT_GT(run.levels[1].bytes_sent, run.levels[0].bytes_sent);
}

TEST(CouplerService, SameSeedGivesIdenticalCouplerLogs) {
  const TempDir out_a("cpl_det_a"), out_b("cpl_det_b");
  const RunResult a = run_hierarchy({2.0, 1.0}, 40, out_a.path());
  const RunResult b = run_hierarchy({2.0, 1.0}, 40, out_b.path());
  ASSERT_EQ(a.code, 0) << a.error;
  ASSERT_EQ(b.code, 0) << b.error;
  EXPECT_GT(a.csv.size(), 1000u);
  EXPECT_EQ(a.csv, b.csv);
}

TEST(CouplerService, MalformedOversizedAndWrongVersionMessagesAreRefusedAndTheRunGoesOn) {
  std::vector<std::string> answers;
  auto intruder = [&](const std::string& ep) {
    zmq::context_t ctx;
    zmq::socket_t s(ctx, zmq::socket_type::dealer);
    s.set(zmq::sockopt::routing_id, "intruder");
    s.set(zmq::sockopt::linger, 0);
    s.connect(ep);
    bus::Envelope old;
    old.set_protocol(bus::kProtocolVersion - 1);
    old.mutable_heartbeat()->set_step(1);
    bus::Envelope empty;
    empty.set_protocol(bus::kProtocolVersion);
    const std::vector<std::string> frames = {std::string("\xff\xff\xff garbage", 12), std::string(200000, 'x'),
                                             old.SerializeAsString(), empty.SerializeAsString()};
    for (const auto& f : frames) {
      s.send(zmq::buffer(f), zmq::send_flags::none);
      zmq::message_t m;
      zmq::pollitem_t item{s.handle(), 0, ZMQ_POLLIN, 0};
      if (zmq::poll(&item, 1, milliseconds(3000)) > 0 && s.recv(m)) {
        const auto d = bus::decode(m.data(), m.size());
        answers.push_back(d.ok() && d.env.has_refused() ? d.env.refused().reason() : "?");
      }
    }
  };
  const TempDir out("cpl_bad");
  const RunResult run = run_hierarchy({2.0, 1.0}, 30, out.path(), intruder);
  ASSERT_EQ(run.code, 0) << run.error;
  EXPECT_EQ(run.refused, 4u);
  ASSERT_EQ(answers.size(), 4u);
  EXPECT_NE(answers[0].find("not a valid"), std::string::npos) << answers[0];
  EXPECT_NE(answers[1].find("exceeds the limit"), std::string::npos) << answers[1];
  EXPECT_NE(answers[2].find("protocol version " + std::to_string(bus::kProtocolVersion - 1)), std::string::npos)
      << answers[2];
  EXPECT_NE(answers[3].find("no body"), std::string::npos) << answers[3];
}

TEST(CouplerService, ALevelOfAnotherCaseIsRefusedAndTheMissingLevelNamed) {
  const CouplerConfig cfg = config({2.0, 1.0});
  Coupler coupler(cfg, fits);
  const std::string ep = endpoint();
  const IpcCleanup ipc_cleanup{ep};
  zmq::context_t ctx;
  bus::Channel ch(ctx, bus::Channel::Role::Router, ep, {});
  ServiceOptions opt;
  opt.case_hash = "c0ffee";
  Service service(coupler, ch, opt, std::make_shared<spdlog::logger>("t", std::make_shared<spdlog::sinks::null_sink_mt>()));
  LevelResult coarse, fine;
  std::thread a([&] { coarse = scripted_level(ep, cfg, 0, "c0ffee", 1); });
  std::thread b([&] { fine = scripted_level(ep, cfg, 1, "deadbeef", 1); });
  EXPECT_EQ(service.run(), 2);
  a.join();
  b.join();
  EXPECT_NE(fine.error.find("another case"), std::string::npos) << fine.error;
  EXPECT_NE(service.error().find("'L1'"), std::string::npos) << service.error();
  EXPECT_NE(service.error().find("did not register"), std::string::npos) << service.error();
}

TEST(CouplerService, ASilentLevelIsNamedAndTheOthersAreStopped) {
  const TempDir out("cpl_silent");
  const RunResult run = run_hierarchy({2.0, 1.0}, 20, out.path(), {}, 1);
  EXPECT_EQ(run.code, 2);
  EXPECT_NE(run.error.find("level 'L1' went silent"), std::string::npos) << run.error;
  EXPECT_NE(run.levels[0].error.find("level 'L1' went silent"), std::string::npos)
      << "the coarse level must be told: " << run.levels[0].error;
  // While it waited (2 s of timeout, heartbeat 0.05 s) the coupler kept it alive and named the level it waited for.
  EXPECT_GE(run.levels[0].heartbeats, 10u);
  EXPECT_EQ(run.levels[0].waiting_for, "'L1'");
}

TEST(CouplerService, ThreeLevelsCoupleThroughTheMiddleOne) {
  const TempDir out("cpl_three");
  const RunResult run = run_hierarchy({4.0, 2.0, 1.0}, 40, out.path());
  ASSERT_EQ(run.code, 0) << run.error;
  EXPECT_EQ(run.levels[0].inserted, 0u);
  EXPECT_GT(run.levels[1].inserted, 0u) << "the middle level is fine in region 0";
  EXPECT_GT(run.levels[2].inserted, 0u) << "and coarse in region 1, whose fine level gets particles";
  expect_exact_per_face(run, {4.0, 2.0, 1.0}, 0, 40);
  expect_exact_per_face(run, {4.0, 2.0, 1.0}, 1, 40);
}
