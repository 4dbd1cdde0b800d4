#pragma once
// The coupler's bus loop: registers the case's levels on one ROUTER endpoint,
// checks protocol, case and level parameters, then runs the interval loop
// (DESIGN.md section 3-4): send commands for interval k, wait for every
// level's statistics of k, compute commands for k + 1. Levels are watched by
// heartbeat: one silent past the timeout is named, every other level is told
// to stop (Bye, failed) and run() returns non-zero. A malformed, oversized or
// wrong-version message is logged and answered with Refused; it never stops
// the coupler.
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>
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
};

class Service {
 public:
  Service(Coupler& coupler, bus::Channel& channel, ServiceOptions opt, std::shared_ptr<spdlog::logger> log);
  ~Service();

  // 0 when every level finished and said bye; 2 on a failure (error() says which).
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
    bus::IntervalStats stats;
  };
  int loop();
  void handle(const bus::Incoming& in);
  void on_register(const bus::Incoming& in);
  void refuse(const std::string& peer, const std::string& why);
  void fail(const std::string& why);
  void send_commands(std::vector<bus::IntervalCommands> cmds);
  void write_logs();
  // Per-face totals and a summary (coupling/faces_region<r>.csv, coupling/summary.json), atomically.
  void write_final(const std::string& status) const;
  bool all(bool Peer::*flag) const;
  std::string names(const std::function<bool(const Peer&)>& pick) const;  // 'a', 'b'

  Coupler& coupler_;
  bus::Channel& ch_;
  ServiceOptions opt_;
  std::shared_ptr<spdlog::logger> log_;
  std::vector<Peer> peers_;
  uint64_t k_ = 0;          // interval the levels are running
  uint64_t refused_ = 0;
  double busy_ = 0.0;       // wall seconds spent computing commands and logs
  bool started_ = false;
  std::string error_;
  std::vector<std::ofstream> csv_;
};

}  // namespace mlcg::coupling
