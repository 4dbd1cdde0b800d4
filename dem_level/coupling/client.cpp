#include "coupling/client.hpp"

#include <algorithm>
#include <cerrno>
#include <optional>

#include <zmq.hpp>

#include "bus/channel.hpp"

namespace mlcg::coupling {

namespace {
constexpr int64_t kStopCheckMs = 100;  // longest poll between looks at ClientOptions::stop
constexpr double kLongestWait = 1e9;   // [s]: some 30 years

std::string seconds(double s) {
  std::string t = std::to_string(s);
  t.erase(t.find_last_not_of('0') + 1);
  if (!t.empty() && t.back() == '.') t.pop_back();
  return t + " s";
}
}  // namespace

Client::Client(const Comm& comm, ClientOptions opt) : comm_(comm), opt_(std::move(opt)) {
  if (opt_.endpoint.empty()) throw std::invalid_argument("coupling client: no coupler endpoint");
  if (opt_.level_name.empty()) throw std::invalid_argument("coupling client: no level name");
  if (comm_.rank() != 0) return;
  ctx_ = std::make_unique<zmq::context_t>(1);
  try {
    ch_ = std::make_unique<bus::Channel>(*ctx_, bus::Channel::Role::Dealer, opt_.endpoint, opt_.level_name);
  } catch (const zmq::error_t& e) {
    throw CouplingError("cannot connect to the coupler at " + opt_.endpoint + ": " + e.what());
  }
  last_sent_ = Clock::now();
}

Client::~Client() = default;  // the socket (linger 0) closes before its context

void Client::send(bus::Envelope&& env) {
  ch_->send(std::move(env));
  last_sent_ = Clock::now();
}

std::string Client::wait_for(int want, const std::string& what, bool heartbeats, double sim_time, uint64_t step) {
  // A Welcome (or case) may say 1e300 s: beyond kLongestWait it means "for ever", and the conversion to
  // the clock's integer ticks must not overflow.
  const auto span = [](double s) {
    return std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(std::min(s, kLongestWait)));
  };
  auto deadline = Clock::now() + span(opt_.timeout);
  const auto interrupted = [&] {
    // What is queued may have nobody to go to (a coupler that never came): the exit must not wait for it.
    ch_->socket().set(zmq::sockopt::linger, 0);
    // The launcher stops the levels once the coupler ended the run: its goodbye, if here, says why.
    try {
      while (auto in = ch_->receive(std::chrono::milliseconds(0)))
        if (in->ok() && in->env.has_bye()) return ended(in->env.bye(), what);
    } catch (const zmq::error_t&) {  // interrupted again: the signal is reason enough
    }
    return CouplingError("interrupted by a signal while level '" + opt_.level_name + "' waited for " + what);
  };
  for (;;) {
    if (opt_.stop && opt_.stop()) throw interrupted();
    const auto now = Clock::now();
    if (now >= deadline)
      throw CouplingError("no message from the coupler at " + opt_.endpoint + " for " + seconds(opt_.timeout) +
                          " while waiting for " + what + " (timeout)" +
                          (awaited_.empty() ? "" : "; it last said it waited for level(s) " + awaited_) +
                          "; is coupler_service running and reachable there?");
    auto until = deadline;
    if (heartbeats) until = std::min(until, last_sent_ + span(opt_.heartbeat));
    const auto wait = std::clamp<int64_t>(
        std::chrono::duration_cast<std::chrono::milliseconds>(until - now).count() + 1, 0, kStopCheckMs);
    std::optional<bus::Incoming> in;
    try {
      in = ch_->receive(std::chrono::milliseconds(wait));
    } catch (const zmq::error_t& e) {
      if (e.num() != EINTR) throw;
      throw interrupted();
    }
    if (!in) {
      if (heartbeats && Clock::now() >= last_sent_ + span(opt_.heartbeat)) {
        bus::Envelope hb;
        hb.mutable_heartbeat()->set_sim_time(sim_time);
        hb.mutable_heartbeat()->set_step(step);
        send(std::move(hb));
      }
      continue;
    }
    deadline = Clock::now() + span(opt_.timeout);  // the coupler is alive
    if (!in->ok()) {
      // The only answer to a registration is Welcome or Refused: one this level cannot read comes
      // from a coupler of another protocol version; waiting for the timeout would not help.
      if (want == bus::Envelope::kWelcome)
        throw CouplingError("the coupler at " + opt_.endpoint + " answered the registration of level '" +
                            opt_.level_name + "' with a message this build cannot read: " + in->error);
      if (opt_.warn) opt_.warn("ignored a message from the coupler at " + opt_.endpoint + ": " + in->error);
      continue;
    }
    const bus::Envelope& env = in->env;
    if (env.body_case() == want) {
      switch (env.body_case()) {
        case bus::Envelope::kWelcome: return env.welcome().SerializeAsString();
        case bus::Envelope::kCommands: return env.commands().SerializeAsString();
        default: return {};
      }
    }
    if (env.has_refused())
      throw CouplingError("the coupler at " + opt_.endpoint + " refused level '" + opt_.level_name +
                          "': " + env.refused().reason());
    if (env.has_bye()) throw ended(env.bye(), what);
    if (env.has_heartbeat()) {
      awaited_ = env.heartbeat().waiting_for();
      continue;
    }
    if (opt_.warn) opt_.warn("ignored a " + std::string(bus::body_name(env)) + " from the coupler while waiting for " + what);
  }
}

CouplingError Client::ended(const bus::Bye& bye, const std::string& what) const {
  return CouplingError("the coupler at " + opt_.endpoint + " ended the run" + (bye.failed() ? " (failed)" : "") +
                       " while level '" + opt_.level_name + "' waited for " + what + ": " + bye.reason());
}

std::string Client::broadcast(const std::function<std::string()>& fetch) {
  // Rank 0 sends 'O' + payload or 'E' + the error, so every rank stops together.
  std::string msg;
  if (comm_.rank() == 0) {
    msg.assign(1, 'O');
    try {
      msg += fetch();
    } catch (const std::exception& e) {
      msg.assign(1, 'E');
      msg += e.what();
    }
  }
  msg = comm_.bcast(msg, 0);
  if (msg.empty() || msg[0] != 'O') throw CouplingError(msg.empty() ? std::string("coupling: empty broadcast") : msg.substr(1));
  return msg.substr(1);
}

bus::Welcome Client::handshake(const bus::Register& reg) {
  const std::string bytes = broadcast([&] {
    bus::Envelope env;
    *env.mutable_register_level() = reg;
    send(std::move(env));
    return wait_for(bus::Envelope::kWelcome, "the welcome (registration as '" + opt_.level_name + "')", false, 0.0, 0);
  });
  bus::Welcome w;
  if (!w.ParseFromString(bytes)) throw CouplingError("coupling: the welcome did not survive the broadcast");
  if (w.timeout_seconds() > 0.0) opt_.timeout = w.timeout_seconds();
  if (w.heartbeat_seconds() > 0.0) opt_.heartbeat = w.heartbeat_seconds();
  return w;
}

bus::IntervalCommands Client::commands(uint64_t k, double sim_time, uint64_t step) {
  const std::string what = "the commands of interval " + std::to_string(k);
  const std::string bytes = broadcast([&] {
    const std::string b = wait_for(bus::Envelope::kCommands, what, true, sim_time, step);
    bus::IntervalCommands c;
    if (!c.ParseFromString(b)) throw CouplingError("coupling: unreadable commands");
    if (c.interval() != k)
      throw CouplingError("the coupler at " + opt_.endpoint + " sent the commands of interval " +
                          std::to_string(c.interval()) + " while level '" + opt_.level_name + "' waited for " +
                          std::to_string(k));
    return b;
  });
  bus::IntervalCommands c;
  c.ParseFromString(bytes);
  return c;
}

void Client::send_stats(bus::IntervalStats&& s) {
  if (comm_.rank() != 0) return;
  bus::Envelope env;
  env.mutable_stats()->Swap(&s);
  send(std::move(env));
}

void Client::keepalive(double sim_time, uint64_t step) {
  if (comm_.rank() != 0) return;
  const auto now = Clock::now();
  if (now - last_sent_ < std::chrono::duration<double>(opt_.heartbeat)) return;
  bus::Envelope hb;
  hb.mutable_heartbeat()->set_sim_time(sim_time);
  hb.mutable_heartbeat()->set_step(step);
  send(std::move(hb));
}

void Client::bye(const std::string& reason, bool failed) {
  if (comm_.rank() != 0 || !ch_) return;
  bus::Envelope env;
  env.mutable_bye()->set_reason(reason);
  env.mutable_bye()->set_failed(failed);
  try {
    send(std::move(env));
    // The socket closes with the level; give the goodbye a moment to leave (linger is 0 otherwise).
    ch_->socket().set(zmq::sockopt::linger, 2000);
  } catch (const std::exception&) {  // the coupler is gone: nothing to tell
  }
}

}  // namespace mlcg::coupling
