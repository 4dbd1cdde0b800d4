#pragma once
// The coupler's bus loop: registers the case's levels on one ROUTER endpoint,
// checks protocol, case and level parameters, then runs the interval loop
// (DESIGN.md section 3-4): send commands for interval k, wait for every
// level's statistics of k, compute commands for k + 1. Levels are watched by
// heartbeat: one silent past the timeout is named, every other level is told
// to stop (Bye, failed) and run() returns non-zero. The coupler sends
// heartbeats to the levels waiting on it, so they blame the silent level, not
// the coupler. A malformed, oversized or
// wrong-version message is logged and answered with Refused; it never stops
// the coupler. Sends never block the loop: a peer that is not a level and does
// not read its replies is dropped (logged once, its id in hex) and ignored.
//
// Consistent checkpoints (service_checkpoint.cpp): the commands of interval k
// ask every level to write its checkpoint at the end of k into
// checkpoints/i<k+1>/; the statistics of k name the file written; once every
// level's are in, the coupler writes its own state (coupler.pb) there and
// then checkpoints/manifest.json, which names the set. A run resumes from the
// set the manifest names, and gives the results of an uninterrupted run.
#include <atomic>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "bus/channel.hpp"
#include "coupler.hpp"

namespace spdlog { class logger; }

namespace mlcg::coupling {

struct ServiceOptions {
  std::string case_hash;                 // every level must register with this hash
  std::filesystem::path out_dir;         // coupling logs go to out_dir/coupling; empty = none
  uint64_t max_intervals = UINT64_MAX;   // stop (telling levels) after this many intervals
  uint64_t checkpoint_every = 0;         // intervals between consistent checkpoints; 0 = on request only
  std::shared_ptr<const bus::CouplerCheckpoint> resume;  // continue from this state (null = fresh start)
  double end_time = -1.0;                // the case's end [s] (for the ETA in coupling/progress.json); < 0 = unknown
};

// Requests from signal handlers (coupler_service/main.cpp sets them; lock-free atomics):
// checkpoint = a consistent checkpoint at the next interval boundary; stop = the same, then every
// level stops (interrupted); abort = stop now without a checkpoint (the launcher's stop on a failure).
struct Requests {
  std::atomic<bool> checkpoint{false}, stop{false}, abort{false};
};
Requests& requests();

// Exit code of run() after a requested stop with its checkpoint written.
inline constexpr int kInterruptedCode = 130;

class Service {
 public:
  Service(Coupler& coupler, bus::Channel& channel, ServiceOptions opt, std::shared_ptr<spdlog::logger> log);
  ~Service();

  // 0 when every level finished and said bye; kInterruptedCode after a requested stop; 2 on a
  // failure (error() says which).
  int run();
  const std::string& error() const { return error_; }
  uint64_t intervals() const { return k_; }
  // Messages refused so far (malformed, oversized, wrong version, unexpected).
  uint64_t refused() const { return refused_; }

 private:
  struct Peer {
    std::string identity;  // ZeroMQ routing id (the level name)
    bool registered = false, finished = false, has_stats = false;
    double last_seen = 0.0;
    double last_sent = -1.0;  // wall time of the coupler's last message to it (for its heartbeats)
    bus::IntervalStats stats;
    double psteps = 0.0, pwall = 0.0;  // particle-steps and wall seconds since the last progress file
    double rate = 0.0;                 // particle-steps per wall second, as last reported
    uint64_t bytes_in = 0, bytes_out = 0;  // bus payload from / to it since this coupler started
    double stats_at = 0.0;      // wall time its statistics of the running interval arrived
    double waited_others = 0.0; // seconds its statistics waited for the other levels' (since this coupler started)
  };
  int loop();
  // Fails the run (true) when interval k_ can never complete: a level finished early or went silent.
  bool fail_if_stuck(double t);
  void handle(bus::Incoming& in);  // may take in's statistics
  void on_register(const bus::Incoming& in);
  void refuse(const std::string& peer, const std::string& why);
  // Every message to a peer goes through here; false when it could not be sent (logged).
  bool deliver(const bus::Envelope& env, const std::string& peer);
  // `peer`'s queue is full: a level is only warned about (its silence is the timeout's to report);
  // anyone else is dropped.
  void stalled(const std::string& peer, const bus::Envelope& env);
  // A heartbeat every heartbeat seconds to each level waiting on the coupler: without one, a level
  // waiting on a hung peer would time out on the coupler and blame it (issue 13).
  void send_heartbeats(double t);
  // The levels whose statistics (before the start: registrations) the coupler waits for.
  std::string awaited() const;
  void fail(const std::string& why);
  void send_commands(std::vector<bus::IntervalCommands> cmds);
  void write_logs(uint64_t k);  // the region logs' rows of interval k
  std::string unplaced_warning(size_t r, double remainder, double crossed, uint64_t placed) const;  // "" if none
  // Per-face totals and a summary (coupling/faces_region<r>.csv, coupling/summary.json), atomically.
  void write_final(const std::string& status) const;
  // Consistent checkpoints (service_checkpoint.cpp).
  void decide_checkpoint(std::vector<bus::IntervalCommands>& cmds);  // flags for the commands of k_
  void write_checkpoint(const std::vector<bus::IntervalStats>& stats, const std::vector<bus::IntervalCommands>& next);
  void resume_logs();  // keeps the rows of region<r>.csv before the resumed interval
  // coupling/progress.json (service_progress.cpp): per level simulated time, particles, particle-steps/s; ETA.
  // At most once per wall second, and always for the run's last interval (the end time's, or `last`: a stop
  // sent), so that `mlcg ps` of a finished run shows where it ended.
  void write_progress(const std::vector<bus::IntervalStats>& stats, uint64_t k, bool last);
  bool all(bool Peer::*flag) const;
  std::string names(const std::function<bool(const Peer&)>& pick) const;  // 'a', 'b'

  Coupler& coupler_;
  bus::Channel& ch_;
  ServiceOptions opt_;
  std::shared_ptr<spdlog::logger> log_;
  std::vector<Peer> peers_;
  uint64_t k_ = 0;          // interval the levels are running
  uint64_t k_start_ = 0;    // the interval this coupler started at (a resume's), for bytes per interval
  uint64_t refused_ = 0;
  std::map<std::string, uint64_t> refusals_;  // per peer, to log only the first kLoggedRefusals
  static constexpr uint64_t kLoggedRefusals = 10;
  std::set<std::string> dropped_;             // peers whose messages are ignored (they do not read)
  uint64_t ignored_ = 0;                      // messages of dropped peers
  double busy_ = 0.0;       // wall seconds spent computing commands and logs
  double response_ = 0.0;   // wall seconds from the last level's statistics to the commands sent (since this coupler started)
  bool started_ = false;
  bool checkpoint_due_ = false;  // the commands of k_ asked for a checkpoint
  bool stopping_ = false;        // the commands of k_ told every level to stop (requested stop)
  uint64_t checkpoints_ = 0;     // consistent sets written
  std::vector<bus::IntervalCommands> resume_cmds_;
  double stop_since_ = -1.0;     // wall time of the stop request
  static constexpr double kStopWaitSeconds = 10.0;  // a stop waits this long for a periodic boundary
  double progress_wall_ = -1.0, start_wall_ = 0.0, start_sim_ = 0.0;  // for the progress file and its ETA
  std::string error_;
  std::string silent_;  // the level that went silent (coupling/summary.json silent_level), if one did
  std::string failed_;  // the level that said it failed (failed_level), if one did
  std::vector<std::ofstream> csv_;
};

}  // namespace mlcg::coupling
