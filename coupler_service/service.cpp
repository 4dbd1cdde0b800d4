#include "service.hpp"

#include <algorithm>
#include <chrono>
#include <cerrno>
#include <cmath>
#include <sstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "io/atomic_file.hpp"

namespace mlcg::coupling {
namespace {

double now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

}  // namespace

Service::Service(Coupler& coupler, bus::Channel& channel, ServiceOptions opt, std::shared_ptr<spdlog::logger> log)
    : coupler_(coupler), ch_(channel), opt_(std::move(opt)), log_(std::move(log)) {
  for (const auto& l : coupler_.config().levels) {
    peers_.emplace_back();
    peers_.back().identity = l.name;
  }
  if (opt_.resume) {
    coupler_.restore(*opt_.resume);
    k_ = opt_.resume->interval();
    k_start_ = k_;
    busy_ = opt_.resume->busy_seconds();
    resume_cmds_.assign(opt_.resume->commands().begin(), opt_.resume->commands().end());
    if (resume_cmds_.size() != peers_.size())
      throw std::invalid_argument(fmt::format("coupler checkpoint: commands for {} levels, the case has {}",
                                              resume_cmds_.size(), peers_.size()));
  }
  if (!opt_.out_dir.empty()) {
    std::filesystem::create_directories(opt_.out_dir / "coupling");
    if (opt_.resume) resume_logs();
    for (size_t r = 0; r < coupler_.config().regions.size(); ++r) {
      const auto path = opt_.out_dir / "coupling" / fmt::format("region{}.csv", r);
      if (opt_.resume && std::filesystem::exists(path)) {
        csv_.emplace_back(path, std::ios::app);
        continue;
      }
      csv_.emplace_back(path);
      csv_.back() << "interval,time_s,crossed_kg,inserted_kg,remainder_kg,inserted_now,inserted_now_kg,"
                     "setpoint_mean_pa,measured_mean_pa,traction_mean_pa,traction_max_pa,acceleration_max,"
                     "returned_kg,returned_now_kg,coarse_mass_in_region_kg,fine_mass_in_region_kg,fine_mass_leaving_kg\n";
    }
  }
}

Service::~Service() = default;

std::string Service::names(const std::function<bool(const Peer&)>& pick) const {
  std::string out;
  for (const auto& p : peers_)
    if (pick(p)) out += (out.empty() ? "'" : ", '") + p.identity + "'";
  return out;
}

bool Service::all(bool Peer::*flag) const {
  for (const auto& p : peers_)
    if (!(p.*flag)) return false;
  return true;
}

void Service::refuse(const std::string& peer, const std::string& why) {
  ++refused_;
  const uint64_t n = ++refusals_[peer];
  if (n <= kLoggedRefusals) log_->warn("refused a message from {}: {}", bus::peer_name(peer), why);
  if (n == kLoggedRefusals)
    log_->warn("further refusals of {} are counted, not logged (coupling/summary.json: refused_messages)",
               bus::peer_name(peer));
  if (peer.empty()) return;
  bus::Envelope env;
  env.mutable_refused()->set_reason(why);
  deliver(env, peer);
}

bool Service::deliver(const bus::Envelope& env, const std::string& peer) {
  try {
    if (!ch_.send(env, peer)) {
      stalled(peer, env);
      return false;
    }
  } catch (const std::exception& e) {
    log_->warn("could not tell {}: {}", bus::peer_name(peer), e.what());
    return false;
  }
  for (auto& p : peers_)
    if (p.identity == peer) {
      p.last_sent = now();
      p.bytes_out += ch_.last_send_bytes();
    }
  return true;
}

void Service::stalled(const std::string& peer, const bus::Envelope& env) {
  const int l = coupler_.level_index(peer);
  if (l >= 0 && peers_[static_cast<size_t>(l)].registered) {
    log_->warn("level '{}' does not read the coupler's messages ({} queued): a {} was not sent", peer,
               bus::kRouterSendHwm, bus::body_name(env));
    return;
  }
  dropped_.insert(peer);
  log_->warn("dropped peer {}: it sends but does not read the coupler's replies ({} queued); its messages are "
             "ignored from now on (a local process that is not a level of this run?)",
             bus::peer_name(peer), bus::kRouterSendHwm);
}

std::string Service::awaited() const {
  if (!started_) return names([](const Peer& p) { return !p.registered; });
  return names([](const Peer& p) { return !p.finished && !p.has_stats; });
}

void Service::send_heartbeats(double t) {
  std::string waiting;
  for (auto& p : peers_) {
    const bool waits = p.registered && !p.finished && (!started_ || p.has_stats);
    if (!waits || t - p.last_sent < coupler_.config().heartbeat) continue;
    if (waiting.empty()) waiting = awaited();
    bus::Envelope env;
    env.mutable_heartbeat()->set_waiting_for(waiting);
    deliver(env, p.identity);
  }
}

void Service::fail(const std::string& why) {
  error_ = why;
  log_->error("{}", why);
  bus::Envelope env;
  env.mutable_bye()->set_reason(why);
  env.mutable_bye()->set_failed(true);
  for (const auto& p : peers_)
    if (p.registered && !p.finished) deliver(env, p.identity);
}

void Service::on_register(const bus::Incoming& in) {
  const bus::Register& r = in.env.register_level();
  const int l = coupler_.level_index(r.level_name());
  if (l < 0 || r.level_name() != in.peer) {
    return refuse(in.peer, fmt::format("unknown level '{}' (the case has {}; the socket identity must be the level "
                                       "name)", r.level_name(), names([](const Peer&) { return true; })));
  }
  Peer& p = peers_[static_cast<size_t>(l)];
  const LevelConfig& lc = coupler_.config().levels[static_cast<size_t>(l)];
  if (p.registered) return refuse(in.peer, fmt::format("level '{}' is already registered", lc.name));
  if (r.case_hash() != opt_.case_hash)
    return refuse(in.peer, fmt::format("level '{}' runs another case (hash {}, the coupler's is {})", lc.name,
                                       r.case_hash(), opt_.case_hash));
  if (std::fabs(r.alpha() - lc.alpha) > 1e-12 * lc.alpha || std::fabs(r.dt() - lc.dt) > 1e-12 * lc.dt)
    return refuse(in.peer, fmt::format("level '{}' registers alpha {} dt {} s, the case says alpha {} dt {} s",
                                       lc.name, r.alpha(), r.dt(), lc.alpha, lc.dt));
  if (r.start_interval() != k_)
    return refuse(in.peer, fmt::format("level '{}' starts at interval {}, the coupler is at {}", lc.name,
                                       r.start_interval(), k_));
  p.registered = true;
  p.last_seen = now();
  bus::Envelope env;
  *env.mutable_welcome() = coupler_.welcome(static_cast<size_t>(l), k_);
  deliver(env, p.identity);
  log_->info("level '{}' registered: alpha {}, dt {} s, {} rank(s), binary {}", lc.name, r.alpha(), r.dt(),
             r.ranks(), r.binary());
}

void Service::handle(bus::Incoming& in) {
  if (dropped_.count(in.peer)) {
    ++ignored_;
    return;
  }
  if (!in.ok()) return refuse(in.peer, in.error);
  const bus::Envelope& env = in.env;
  const int l = coupler_.level_index(in.peer);
  if (l >= 0) peers_[static_cast<size_t>(l)].bytes_in += in.bytes;
  if (env.has_register_level()) return on_register(in);
  if (l < 0 || !peers_[static_cast<size_t>(l)].registered)
    return refuse(in.peer, fmt::format("{} sent {} before registering", bus::peer_name(in.peer), bus::body_name(env)));
  Peer& p = peers_[static_cast<size_t>(l)];
  p.last_seen = now();
  if (env.has_heartbeat()) return;
  if (env.has_bye()) {
    p.finished = true;
    if (env.bye().failed()) {
      failed_ = p.identity;
      return fail(fmt::format("level '{}' failed: {}", p.identity, env.bye().reason()));
    }
    log_->info("level '{}' finished at interval {}", p.identity, k_);
    return;
  }
  if (env.has_stats()) {
    if (p.has_stats || env.stats().interval() != k_)
      return fail(fmt::format("level '{}' sent statistics of interval {} while the coupler is at {}", p.identity,
                              env.stats().interval(), k_));
    p.stats.Swap(in.env.mutable_stats());  // taken, not copied (a fine level's occupants: up to a few 100 kB)
    p.has_stats = true;
    p.stats_at = now();
    return;
  }
  refuse(in.peer, fmt::format("{} sent {}, which the coupler does not accept", bus::peer_name(in.peer),
                              bus::body_name(env)));
}

void Service::send_commands(std::vector<bus::IntervalCommands> cmds) {
  const bool last = k_ + 1 >= opt_.max_intervals;
  decide_checkpoint(cmds);
  // Finest level first: it is the slowest, and a coarser level woken first may take the core
  // from the coupler for a whole time slice before the next send (measured: 2 ms per interval).
  std::vector<size_t> order(peers_.size());
  for (size_t l = 0; l < order.size(); ++l) order[l] = l;
  const auto& lv = coupler_.config().levels;
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) { return lv[a].alpha < lv[b].alpha; });
  for (const size_t l : order) {
    if (peers_[l].finished) continue;
    bus::Envelope env;
    if (last && cmds[l].interval() > 0) cmds[l].set_stop(true);
    *env.mutable_commands() = std::move(cmds[l]);
    deliver(env, peers_[l].identity);
  }
}

void Service::write_final(const std::string& status) const {
  if (opt_.out_dir.empty()) return;
  nlohmann::json j;
  j["status"] = status;
  j["checkpoints"] = checkpoints_;
  j["error"] = error_;
  j["silent_level"] = silent_;
  j["failed_level"] = failed_;
  j["intervals"] = k_;
  j["interval_s"] = coupler_.config().interval;
  j["coupler_busy_seconds"] = busy_;
  // The wait of a level between its statistics and its commands, in parts: the other levels' statistics
  // (per level) and the coupler's response; the rest is the bus (this coupler's run only, not a resumed one's).
  j["coupler_response_seconds"] = response_;
  j["refused_messages"] = refused_;
  j["dropped_peers"] = nlohmann::json::array();
  for (const auto& p : dropped_) j["dropped_peers"].push_back(bus::peer_name(p));
  j["ignored_messages"] = ignored_;
  // The bus load per level: message frames as sent and received (ZeroMQ adds a few bytes of framing).
  const double run_intervals = static_cast<double>(std::max<uint64_t>(1, k_ - k_start_));
  j["levels"] = nlohmann::json::array();
  for (const auto& p : peers_)
    j["levels"].push_back({{"name", p.identity}, {"bytes_from_level", p.bytes_in}, {"bytes_to_level", p.bytes_out},
                           {"bytes_per_interval_from_level", static_cast<double>(p.bytes_in) / run_intervals},
                           {"bytes_per_interval_to_level", static_cast<double>(p.bytes_out) / run_intervals},
                           {"waited_for_other_levels_seconds", p.waited_others}});
  j["regions"] = nlohmann::json::array();
  for (size_t r = 0; r < coupler_.config().regions.size(); ++r) {
    const auto& geo = coupler_.geometry(r);
    std::string csv = "face,x,y,crossed_kg,inserted_kg,remainder_kg,placed,short_intervals,returned_kg,side,z\n";
    double crossed = 0.0, inserted = 0.0, remainder = 0.0, returned = 0.0, worst = 0.0;
    uint64_t placed = 0, bounded = 0;
    const auto& faces = coupler_.planner(r).faces();
    for (size_t f = 0; f < faces.size(); ++f) {
      const auto& s = faces[f];
      Vec3 lo, hi;
      geo.face_slab(f, 0.0, lo, hi);
      const Vec3 c = 0.5 * (lo + hi);  // the face's centre
      static constexpr const char* kSide[] = {"top", "-x", "+x", "-y", "+y", "bottom"};
      csv += fmt::format("{},{:.6g},{:.6g},{:.17g},{:.17g},{:.17g},{},{},{:.17g},{},{:.6g}\n", f, c.x, c.y, s.crossed,
                         s.inserted, s.remainder, s.placed, s.short_intervals, s.returned,
                         kSide[static_cast<int>(geo.side_of_face(f))], c.z);
      crossed += s.crossed;
      returned += s.returned;
      inserted += s.inserted;
      remainder += s.remainder;
      placed += s.placed;
      bounded += s.bounded;
      // Rounding only (the remainder is defined by the ledger): the mass checks are elsewhere.
      if (s.crossed != 0.0)
        worst = std::max(worst, std::fabs(s.crossed + s.returned - s.inserted - s.remainder) / std::fabs(s.crossed));
    }
    io::write_file_atomic(opt_.out_dir / "coupling" / fmt::format("faces_region{}.csv", r), csv);
    j["regions"].push_back({{"cells", geo.cells()}, {"faces", geo.faces()}, {"side_faces", geo.faces() - geo.top_faces()},
                            {"top", geo.top()},
                            {"crossed_kg", crossed}, {"inserted_kg", inserted}, {"remainder_kg", remainder},
                            {"returned_kg", returned},
                            {"inserted_particles", placed}, {"worst_face_mass_error", worst},
                            {"velocities_bounded", bounded}});
    const std::string unplaced = unplaced_warning(r, remainder, crossed + returned, placed);
    if (!unplaced.empty()) j["regions"].back()["unplaced_warning"] = unplaced;
  }
  io::write_file_atomic(opt_.out_dir / "coupling" / "summary.json", j.dump(2) + "\n");
}

// Mass that crossed into a region and found no place on its fine level is missing from the fine level's flow.
// A face carries less than a particle between intervals, and full slabs delay more: the quickstart ends carrying
// 6 % of what crossed (its region packed when the run stops), the belt feeder 0.1 %. A region that placed
// nothing while more than 10 of its largest fine particles crossed (the feeder's shallow region counted from a
// point outside its hopper: none of 0.024 kg), or carries more than a quarter of what crossed, the planner
// cannot fill.
std::string Service::unplaced_warning(size_t r, double remainder, double crossed, uint64_t placed) const {
  const PlannerParams& prm = coupler_.config().regions[r].planner;
  const double r_fine = prm.radius_bins.empty() ? 0.0 : prm.radius_bins.back() / prm.ratio;
  if (!(remainder > 10.0 * coupler_.planner(r).mass_of(r_fine) && (placed == 0 || remainder > 0.25 * crossed)))
    return "";
  return fmt::format(
      "region {}: {:.3g} kg of the {:.3g} kg that crossed into it ({:.0f} %) found no place on its fine level ({} fine "
      "particles placed); the fine level's flow misses that mass, so its probes read low{}",
      r, remainder, crossed, 100.0 * remainder / crossed, placed,
      placed == 0 ? ". No particle found room under the region's top: its insertion slab may lie outside the walls as "
                    "seen from the region's inside point (give `inside`, cases/README.md, [[coupling.regions]])"
                  : "");
}

void Service::write_logs(uint64_t k) {
  const double t = static_cast<double>(k + 1) * coupler_.config().interval;
  for (size_t r = 0; r < csv_.size(); ++r) {
    const RegionLog& lg = coupler_.log(r);
    double crossed = 0.0, inserted = 0.0, rem = 0.0, ret = 0.0, sp = 0.0, pv = 0.0, tr = 0.0, tmax = 0.0, amax = 0.0;
    for (const auto& f : coupler_.planner(r).faces()) {
      crossed += f.crossed;
      ret += f.returned;
      inserted += f.inserted;
      rem += f.remainder;
    }
    const size_t nf = lg.traction.size();
    for (size_t f = 0; f < nf; ++f) {
      sp += lg.setpoint[f] / nf;
      pv += lg.measured[f] / nf;
      tr += lg.traction[f] / nf;
      tmax = std::max(tmax, lg.traction[f]);
    }
    for (const auto& a : lg.acceleration) amax = std::max(amax, norm(a));
    csv_[r] << fmt::format("{},{:.9g},{:.12g},{:.12g},{:.6g},{},{:.9g},{:.6g},{:.6g},{:.6g},{:.6g},{:.6g},{:.12g},{:.9g},"
                           "{:.12g},{:.12g},{:.12g}\n",
                           k, t, crossed, inserted, rem, lg.inserted, lg.inserted_mass, sp, pv, tr, tmax, amax, ret,
                           lg.returned_mass, lg.coarse_mass, lg.fine_mass, lg.fine_leaving);
  }
}

int Service::run() {
  const int code = loop();
  try {
    write_final(code == 0 ? "completed" : code == kInterruptedCode ? "interrupted" : "failed");
  } catch (const std::exception& e) {
    log_->error("cannot write the coupling summary: {}", e.what());
  }
  return code;
}

bool Service::fail_if_stuck(double t) {
  const auto& cfg = coupler_.config();
  // Levels share the end time: if one finished without statistics of k while
  // another delivered them, interval k can never complete.
  bool stuck = true, waiting = false, gone = false;
  for (const auto& p : peers_) {
    stuck = stuck && (p.finished || p.has_stats);
    waiting = waiting || (!p.finished && p.has_stats);
    gone = gone || (p.finished && !p.has_stats);
  }
  if (stuck && waiting && gone) {
    fail(fmt::format("level(s) {} finished before interval {} while {} continue (levels share the end time)",
                     names([](const Peer& p) { return p.finished && !p.has_stats; }), k_,
                     names([](const Peer& p) { return !p.finished; })));
    return true;
  }
  for (const auto& p : peers_) {
    if (p.finished) continue;
    // A level that delivered its statistics waits on the coupler, it is not silent.
    if (!p.has_stats && t - p.last_seen > cfg.timeout) {
      silent_ = p.identity;
      fail(fmt::format("level '{}' went silent: no message for {:.1f} s (timeout {} s) at interval {}; it is hung, "
                       "stopped (SIGSTOP) or starved of CPU (raise [coupling] timeout if it is only slow)",
                       p.identity, t - p.last_seen, cfg.timeout, k_));
      return true;
    }
  }
  return false;
}

int Service::loop() {
  const auto& cfg = coupler_.config();
  const double t0 = now();
  const auto poll = std::chrono::milliseconds(std::max<int64_t>(1, static_cast<int64_t>(cfg.heartbeat * 250.0)));
  log_->info("coupler on {}: {} levels, {} region(s), interval {} s, waiting for registrations", ch_.endpoint(),
             cfg.levels.size(), cfg.regions.size(), cfg.interval);
  for (;;) {
    try {
      if (auto in = ch_.receive(poll)) handle(*in);
    } catch (const zmq::error_t& e) {
      if (e.num() != EINTR) throw;  // a signal (a stop or checkpoint request) woke the poll
    }
    if (!error_.empty()) return 2;
    if (requests().abort.load()) {
      fail(fmt::format("stopped by a signal at interval {} (no checkpoint)", k_));
      return 2;
    }
    const double t = now();
    send_heartbeats(t);
    if (!started_) {
      // A stop asked for now still waits for the levels: the first checkpoint boundary stops them.
      if (all(&Peer::registered)) {
        started_ = true;
        for (auto& p : peers_) p.last_seen = t;
        send_commands(resume_cmds_.empty() ? coupler_.initial_commands() : std::move(resume_cmds_));
      } else if (t - t0 > cfg.timeout) {
        fail(fmt::format("level(s) {} did not register within {} s", names([](const Peer& p) { return !p.registered; }),
                         cfg.timeout));
        return 2;
      }
      continue;
    }
    if (all(&Peer::has_stats)) {
      std::vector<bus::IntervalStats> stats;
      for (auto& p : peers_) stats.push_back(std::move(p.stats));
      try {
        // The levels wait for these commands: what they do not need (the logs, the progress file) is written
        // after they are sent, except that the logs a checkpoint covers are on disk before it.
        const uint64_t k = k_;
        const double b0 = now();
        auto cmds = coupler_.advance(k, stats);
        const bool checkpoint = checkpoint_due_;
        if (checkpoint) write_logs(k);
        ++k_;
        if (checkpoint) write_checkpoint(stats, cmds);
        for (auto& p : peers_) p.has_stats = false;
        send_commands(std::move(cmds));
        const double sent = now();
        double arrived = 0.0;  // the last level's statistics
        for (const auto& p : peers_) arrived = std::max(arrived, p.stats_at);
        for (auto& p : peers_) p.waited_others += arrived - p.stats_at;
        response_ += sent - arrived;
        if (!checkpoint) write_logs(k);
        write_progress(stats, k, k_ + 1 >= opt_.max_intervals || stopping_);  // always where the run ends
        busy_ += now() - b0;
      } catch (const std::exception& e) {
        fail(e.what());
        return 2;
      }
      continue;
    }
    if (all(&Peer::finished)) {
      coupler_.cancel_last_insertions();  // sent after the levels' last interval, never run
      log_->info("all levels finished after {} intervals; {} message(s) refused; coupler busy {:.2f} s", k_,
                 refused_, busy_);
      for (auto& f : csv_) f.flush();
      return stopping_ ? kInterruptedCode : 0;
    }
    if (fail_if_stuck(t)) return 2;
  }
}

}  // namespace mlcg::coupling
