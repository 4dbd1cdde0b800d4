#pragma once
// The level's end of the bus (DESIGN.md section 4). Rank 0 owns a DEALER whose
// identity is the level name, connected to the coupler's ROUTER; the other
// ranks learn everything rank 0 receives through a broadcast, so every call
// below is made on every rank and returns the same on every rank.
//
//   handshake:  Register -> Welcome (Refused -> CouplingError with the coupler's reason)
//   interval k: commands(k) -> ... steps ... -> send_stats(k)
//   end:        bye()
//
// While waiting, rank 0 sends a Heartbeat every heartbeat seconds; the coupler
// sends its own to a level waiting on it. When nothing arrives for timeout
// seconds it stops the level with an error naming the coupler's endpoint (and
// the levels the coupler last said it waited for). Nothing here exists (no ZeroMQ context, no socket) unless
// a level is started with a coupler.
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>

#include "mlcg/bus.pb.h"
#include "parallel/comm.hpp"

namespace zmq { class context_t; }
namespace mlcg::bus { class Channel; }

namespace mlcg::coupling {

// The coupler refused the level, fell silent, or sent something this level cannot use.
struct CouplingError : std::runtime_error { using std::runtime_error::runtime_error; };

struct ClientOptions {
  std::string endpoint;     // the coupler's ROUTER (tcp://... or ipc://...)
  std::string level_name;   // DEALER identity and Register.level_name
  double timeout = 60.0;    // [wall s] until the Welcome; then the Welcome's timeout_seconds
  double heartbeat = 1.0;   // [wall s] until the Welcome; then the Welcome's heartbeat_seconds
  std::function<void(const std::string&)> warn;  // rank 0: a message that was ignored
  // Rank 0, at least every 100 ms while waiting: true ends the wait with a CouplingError (a SIGTERM whose
  // handler ran on another thread, or before the wait, does not wake the poll).
  std::function<bool()> stop;
};

class Client {
 public:
  Client(const Comm& comm, ClientOptions opt);  // rank 0 connects (connecting never blocks)
  ~Client();
  Client(const Client&) = delete;
  Client& operator=(const Client&) = delete;

  // Collective: sends `reg` (rank 0) and returns the coupler's Welcome on every rank.
  bus::Welcome handshake(const bus::Register& reg);
  // Collective: waits for the commands of interval k (heartbeats carry sim_time and step).
  bus::IntervalCommands commands(uint64_t k, double sim_time, uint64_t step);
  // Rank 0 sends; the other ranks do nothing.
  void send_stats(bus::IntervalStats&& s);  // takes s's contents (not copied)
  // Rank 0: a heartbeat if nothing was sent for heartbeat seconds (cheap: one clock read).
  void keepalive(double sim_time, uint64_t step);
  // Rank 0: tells the coupler this level is done (never throws).
  void bye(const std::string& reason, bool failed);

  const std::string& endpoint() const { return opt_.endpoint; }
  double timeout() const { return opt_.timeout; }
  double heartbeat() const { return opt_.heartbeat; }

 private:
  using Clock = std::chrono::steady_clock;
  // Rank 0: the body of the first message of kind `want`, serialised; throws CouplingError.
  std::string wait_for(int want, const std::string& what, bool heartbeats, double sim_time, uint64_t step);
  // Every rank: rank 0's result (or error) of `fetch`.
  std::string broadcast(const std::function<std::string()>& fetch);
  void send(bus::Envelope&& env);
  // The error for the coupler's Bye received while waiting for `what`.
  CouplingError ended(const bus::Bye& bye, const std::string& what) const;

  const Comm& comm_;
  ClientOptions opt_;
  std::unique_ptr<zmq::context_t> ctx_;
  std::unique_ptr<bus::Channel> ch_;
  Clock::time_point last_sent_;
  std::string awaited_;  // the levels the coupler's last heartbeat said it waited for
};

}  // namespace mlcg::coupling
