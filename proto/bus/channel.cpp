#include "bus/channel.hpp"

#include <algorithm>
#include <stdexcept>
#include <vector>

#include <fmt/format.h>
#include <zmq_addon.hpp>

namespace mlcg::bus {

namespace {
void stamp(Envelope& env, const std::string& sender) {  // what every message on the bus carries
  env.set_protocol(kProtocolVersion);
  env.set_sender(sender);
}
}  // namespace

std::string encode(Envelope env, const std::string& sender) {
  stamp(env, sender);
  std::string out;
  if (!env.SerializeToString(&out)) throw std::runtime_error("bus: cannot serialise a " + std::string(body_name(env)));
  return out;
}

Decoded decode(const void* data, size_t size, size_t max_bytes) {
  Decoded d;
  if (size > max_bytes) {
    d.error = "message of " + std::to_string(size) + " bytes exceeds the limit of " + std::to_string(max_bytes);
    return d;
  }
  if (!d.env.ParseFromArray(data, static_cast<int>(size))) {
    d.error = "message of " + std::to_string(size) + " bytes is not a valid mlcg.bus.Envelope";
    return d;
  }
  if (d.env.protocol() != kProtocolVersion) {
    d.error = "protocol version " + std::to_string(d.env.protocol()) + " from '" + d.env.sender() +
              "', this build speaks " + std::to_string(kProtocolVersion) +
              " (rebuild the peer from the same commit)";
    return d;
  }
  if (d.env.body_case() == Envelope::BODY_NOT_SET) {
    d.error = "message from '" + d.env.sender() + "' has no body (unknown message type from a newer peer?)";
  }
  return d;
}

const char* body_name(const Envelope& env) {
  switch (env.body_case()) {
    case Envelope::kRegisterLevel: return "register";
    case Envelope::kWelcome: return "welcome";
    case Envelope::kRefused: return "refused";
    case Envelope::kStats: return "stats";
    case Envelope::kCommands: return "commands";
    case Envelope::kHeartbeat: return "heartbeat";
    case Envelope::kBye: return "bye";
    case Envelope::BODY_NOT_SET: break;
  }
  return "empty";
}

std::string peer_name(const std::string& id) {
  const bool printable =
      !id.empty() && std::all_of(id.begin(), id.end(), [](char c) { return c >= 0x20 && c < 0x7f && c != '\''; });
  if (printable) return "'" + id + "'";
  std::string hex = "0x";
  for (const unsigned char c : id) hex += fmt::format("{:02x}", c);
  return hex;
}

Channel::Channel(zmq::context_t& ctx, Role role, const std::string& endpoint, const std::string& identity,
                 size_t max_bytes, const curve::SocketKeys* keys)
    : role_(role), identity_(identity), max_bytes_(max_bytes),
      sock_(ctx, role == Role::Router ? zmq::socket_type::router : zmq::socket_type::dealer) {
  // A level's last message (Bye) must reach the coupler after the socket closes;
  // the coupler itself never waits on departed levels.
  sock_.set(zmq::sockopt::linger, role == Role::Dealer ? 2000 : 0);
  // Hard cap far above the checked one: a flood is cut off by ZeroMQ, a merely
  // oversized message still arrives and is refused with a logged reason.
  sock_.set(zmq::sockopt::maxmsgsize, static_cast<int64_t>(4 * max_bytes + 4096));
  if (!keys) keys = curve::process_keys();
  curve::require_curve_for(endpoint, keys != nullptr, curve::kHowToEnable);
  if (keys) curve::apply(sock_, *keys, role == Role::Router);
  if (role == Role::Router) {
    // Mandatory: a send to a full or unknown peer fails instead of vanishing (send() below).
    sock_.set(zmq::sockopt::router_mandatory, 1);
    sock_.set(zmq::sockopt::sndhwm, kRouterSendHwm);
    sock_.bind(endpoint);
  } else {
    if (identity.empty()) throw std::invalid_argument("bus: a dealer needs an identity (its level name)");
    sock_.set(zmq::sockopt::routing_id, identity);
    sock_.connect(endpoint);
  }
}

std::string Channel::endpoint() const { return sock_.get(zmq::sockopt::last_endpoint); }

bool Channel::send(const Envelope& env, const std::string& peer) { return send(Envelope(env), peer); }

bool Channel::send(Envelope&& env, const std::string& peer) {
  // Stamped in place and serialised straight into the frame: a fine level's statistics (up to a few
  // hundred kB of occupants every interval) are not copied on their way out.
  stamp(env, role_ == Role::Router ? std::string("coupler") : identity_);
  const size_t size = env.ByteSizeLong();
  zmq::message_t frame(size);
  env.SerializeWithCachedSizesToArray(static_cast<uint8_t*>(frame.data()));
  try {
    if (role_ == Role::Router) {
      if (peer.empty()) throw std::invalid_argument("bus: router send needs a peer");
      // The coupler's loop must never wait on one peer: a full queue fails at the routing frame (EAGAIN).
      if (!sock_.send(zmq::buffer(peer), zmq::send_flags::sndmore | zmq::send_flags::dontwait)) return false;
      sock_.send(frame, zmq::send_flags::dontwait);
    } else {
      sock_.send(frame, zmq::send_flags::none);
    }
    last_send_bytes_ = size;
    return true;
  } catch (const zmq::error_t& e) {
    throw std::runtime_error("bus: cannot send " + std::string(body_name(env)) +
                             (peer.empty() ? std::string() : " to '" + peer + "'") + ": " + e.what());
  }
}

std::optional<Incoming> Channel::receive(std::chrono::milliseconds timeout) {
  zmq::pollitem_t item{sock_.handle(), 0, ZMQ_POLLIN, 0};
  if (zmq::poll(&item, 1, timeout) == 0) return std::nullopt;
  std::vector<zmq::message_t> parts;
  if (!zmq::recv_multipart(sock_, std::back_inserter(parts), zmq::recv_flags::dontwait)) return std::nullopt;
  Incoming in;
  const size_t want = role_ == Role::Router ? 2 : 1;
  if (role_ == Role::Router && !parts.empty()) in.peer = parts.front().to_string();
  if (parts.size() != want) {
    in.error = "expected " + std::to_string(want) + " frame(s), got " + std::to_string(parts.size());
    return in;
  }
  // CURVE: the authenticator names the issued key's owner (User-Id); a peer may only speak as itself.
  if (role_ == Role::Router)
    if (const char* uid = zmq_msg_gets(parts.back().handle(), "User-Id"); uid && *uid && in.peer != uid) {
      in.error = "the CURVE key issued to '" + std::string(uid) + "' was used by '" + in.peer + "'";
      return in;
    }
  in.bytes = parts.back().size();
  Decoded d = decode(parts.back().data(), parts.back().size(), max_bytes_);
  in.env = std::move(d.env);
  in.error = std::move(d.error);
  return in;
}

}  // namespace mlcg::bus
