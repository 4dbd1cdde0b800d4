#pragma once
// The typed send/receive layer over cppzmq that the coupler, every level and
// the launcher share. One Envelope per ZeroMQ message; the coupler binds a
// ROUTER, each level's rank 0 connects a DEALER whose identity is its level
// name.
//
// Contract: receive() never throws on bad input. A frame that is too large,
// does not parse, carries no body or another protocol version comes back as
// an Incoming with `error` set (naming the peer and the reason), so the
// receiver logs it, may answer with Refused, and goes on.
#include <chrono>
#include <cstdint>
#include <optional>
#include <string>

#include <zmq.hpp>

#include "bus/curve.hpp"
#include "mlcg/bus.pb.h"

namespace mlcg::bus {

// Bump on any change of mlcg/bus.proto an older peer would misread.
#ifdef MLCG_PROTOCOL_VERSION_OVERRIDE  // a test build speaking another version (dem_level_protocol_test)
inline constexpr uint32_t kProtocolVersion = MLCG_PROTOCOL_VERSION_OVERRIDE;
#else
inline constexpr uint32_t kProtocolVersion = 2;
#endif
// Messages above this are refused (an insertion list of a few 100k particles fits).
inline constexpr size_t kDefaultMaxBytes = size_t{64} << 20;

// Serialises `env` with this build's protocol version and sender.
std::string encode(Envelope env, const std::string& sender);

struct Decoded {
  Envelope env;
  std::string error;  // empty when env is valid
  bool ok() const { return error.empty(); }
};
// Parses one frame; refuses oversized, unparsable, empty and other-version messages.
Decoded decode(const void* data, size_t size, size_t max_bytes = kDefaultMaxBytes);

// Name of the body case, for logs ("stats", "commands", ...).
const char* body_name(const Envelope& env);

// A routing id for logs: 'name' when it is printable ASCII, else its bytes in hex (0x00ff...), so a
// stranger's binary id cannot garble a log.
std::string peer_name(const std::string& id);

// Router: messages queued for one peer before a send to it fails (a peer that does not read).
inline constexpr int kRouterSendHwm = 1000;

struct Incoming {
  std::string peer;   // ROUTER: the sender's identity; DEALER: empty
  Envelope env;
  std::string error;  // set when the message was refused
  size_t bytes = 0;   // the message frame's size on the wire
  bool ok() const { return error.empty(); }
};

class Channel {
 public:
  enum class Role { Router, Dealer };
  // Router: binds `endpoint`. Dealer: connects to it with `identity`.
  // CURVE: `keys`, else the process's (curve::process_keys()); without keys only a loopback or
  // ipc endpoint is accepted (std::runtime_error otherwise).
  Channel(zmq::context_t& ctx, Role role, const std::string& endpoint, const std::string& identity,
          size_t max_bytes = kDefaultMaxBytes, const curve::SocketKeys* keys = nullptr);

  // Router: `peer` names the destination (throws std::runtime_error if it is not connected). Never
  // blocks: false, and nothing sent, when kRouterSendHwm messages wait for the peer (it does not read).
  // Dealer: blocks while the router's queue is full; always true.
  bool send(const Envelope& env, const std::string& peer = {});
  bool send(Envelope&& env, const std::string& peer = {});  // the same, without copying env
  // Waits up to `timeout` for one message; nullopt when none arrived.
  std::optional<Incoming> receive(std::chrono::milliseconds timeout);
  // The message frame's size of the last send that returned true (for the bus load per level).
  size_t last_send_bytes() const { return last_send_bytes_; }

  // The endpoint actually bound (tcp://...:0 resolves to a port).
  std::string endpoint() const;
  const std::string& identity() const { return identity_; }
  zmq::socket_t& socket() { return sock_; }

 private:
  Role role_;
  std::string identity_;
  size_t max_bytes_;
  zmq::socket_t sock_;
  size_t last_send_bytes_ = 0;
};

}  // namespace mlcg::bus
