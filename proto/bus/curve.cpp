#include "bus/curve.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <optional>
#include <sstream>
#include <stdexcept>

#include <fmt/format.h>
#include <zmq_addon.hpp>

namespace mlcg::bus::curve {
namespace fs = std::filesystem;

namespace {

std::optional<SocketKeys> g_process_keys;

bool valid_z85_key(const std::string& k) {
  uint8_t raw[32];
  return k.size() == 40 && zmq_z85_decode(raw, k.c_str()) != nullptr;
}

std::string trim(const std::string& s) {
  const size_t a = s.find_first_not_of(" \t\r");
  if (a == std::string::npos) return {};
  return s.substr(a, s.find_last_not_of(" \t\r") - a + 1);
}

// Writes `text` to `file` through a temporary created with mode 0600, then renames it.
void write_private(const fs::path& file, const std::string& text) {
  const fs::path tmp = file.string() + ".tmp." + std::to_string(getpid());
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
  if (fd < 0) throw std::runtime_error(fmt::format("{}: cannot create: {}", tmp.string(), std::strerror(errno)));
  const bool ok = ::fchmod(fd, 0600) == 0 &&
                  ::write(fd, text.data(), text.size()) == static_cast<ssize_t>(text.size()) && ::fsync(fd) == 0;
  const int err = errno;
  ::close(fd);
  if (!ok || ::rename(tmp.c_str(), file.c_str()) != 0) {
    ::unlink(tmp.c_str());
    throw std::runtime_error(fmt::format("{}: cannot write: {}", file.string(), std::strerror(ok ? errno : err)));
  }
}

// Reads a key file, refusing one that other users can read (it may hold a secret key).
std::vector<std::string> read_private(const fs::path& file) {
  struct stat st {};
  if (::stat(file.c_str(), &st) != 0)
    throw std::runtime_error(fmt::format("{}: cannot read the key file: {}", file.string(), std::strerror(errno)));
  if ((st.st_mode & 077) != 0)
    throw std::runtime_error(fmt::format("{}: mode {:04o} lets other users read the key; allowed: 0600 (chmod 600)",
                                         file.string(), st.st_mode & 07777));
  std::ifstream in(file);
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

std::string peer_of(int fd) {
  sockaddr_storage sa{};
  socklen_t len = sizeof sa;
  if (::getpeername(fd, reinterpret_cast<sockaddr*>(&sa), &len) != 0) return {};
  char host[INET6_ADDRSTRLEN] = {0};
  if (sa.ss_family == AF_INET) {
    const auto* a = reinterpret_cast<const sockaddr_in*>(&sa);
    inet_ntop(AF_INET, &a->sin_addr, host, sizeof host);
    return fmt::format("{}:{}", host, ntohs(a->sin_port));
  }
  if (sa.ss_family == AF_INET6) {
    const auto* a = reinterpret_cast<const sockaddr_in6*>(&sa);
    inet_ntop(AF_INET6, &a->sin6_addr, host, sizeof host);
    return fmt::format("[{}]:{}", host, ntohs(a->sin6_port));
  }
  return "a local process (ipc)";
}

}  // namespace

KeyPair generate() {
  if (!zmq_has("curve")) throw std::runtime_error("this libzmq was built without CURVE; it cannot secure the bus");
  char pub[41], sec[41];
  if (zmq_curve_keypair(pub, sec) != 0)
    throw std::runtime_error(std::string("zmq_curve_keypair failed: ") + zmq_strerror(zmq_errno()));
  return {pub, sec};
}

void write_key_file(const fs::path& file, const KeyPair& keys) {
  std::string text = "# MLCG bus CURVE key (ZeroMQ Z85); issued per run by mlcg, keep private\n";
  text += "public = " + keys.public_key + "\n";
  if (!keys.secret_key.empty()) text += "secret = " + keys.secret_key + "\n";
  write_private(file, text);
}

KeyPair read_key_file(const fs::path& file) {
  KeyPair k;
  const auto lines = read_private(file);
  for (size_t i = 0; i < lines.size(); ++i) {
    const std::string line = trim(lines[i]);
    if (line.empty() || line[0] == '#') continue;
    const size_t eq = line.find('=');
    const std::string key = trim(line.substr(0, eq)), value = eq == std::string::npos ? "" : trim(line.substr(eq + 1));
    const std::string where = fmt::format("{}:{}: ", file.string(), i + 1);
    if (key != "public" && key != "secret")
      throw std::runtime_error(where + "'" + key + "' is not a key file entry; allowed: public = Z85, secret = Z85");
    if (!valid_z85_key(value))
      throw std::runtime_error(where + key + ": not a CURVE key (allowed: 40 Z85 characters)");
    (key == "public" ? k.public_key : k.secret_key) = value;
  }
  if (k.public_key.empty()) throw std::runtime_error(file.string() + ": no 'public = ...' line");
  return k;
}

void write_client_list(const fs::path& file, const std::vector<IssuedKey>& clients) {
  std::string text = "# MLCG bus: client public keys the coupler accepts (NAME Z85), issued per run by mlcg\n";
  for (const auto& c : clients) text += c.name + " " + c.public_key + "\n";
  write_private(file, text);
}

std::vector<IssuedKey> read_client_list(const fs::path& file) {
  std::vector<IssuedKey> out;
  const auto lines = read_private(file);
  for (size_t i = 0; i < lines.size(); ++i) {
    const std::string line = trim(lines[i]);
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ss(line);
    IssuedKey k;
    std::string extra;
    ss >> k.name >> k.public_key >> extra;
    if (!valid_z85_key(k.public_key) || !extra.empty())
      throw std::runtime_error(fmt::format("{}:{}: expected 'NAME PUBLIC_KEY' (a name and 40 Z85 characters)",
                                           file.string(), i + 1));
    out.push_back(k);
  }
  if (out.empty()) throw std::runtime_error(file.string() + ": no client keys (the coupler would accept nobody)");
  return out;
}

bool is_local_endpoint(const std::string& endpoint) {
  if (endpoint.rfind("ipc://", 0) == 0 || endpoint.rfind("inproc://", 0) == 0) return true;
  if (endpoint.rfind("tcp://", 0) != 0) return false;
  std::string addr = endpoint.substr(6);
  if (const size_t semi = addr.find(';'); semi != std::string::npos) addr = addr.substr(semi + 1);  // source;dest
  const size_t colon = addr.rfind(':');
  std::string host = colon == std::string::npos ? addr : addr.substr(0, colon);
  if (host.size() > 2 && host.front() == '[' && host.back() == ']') host = host.substr(1, host.size() - 2);
  if (host == "localhost" || host == "::1" || host == "lo") return true;
  in_addr a{};
  return inet_pton(AF_INET, host.c_str(), &a) == 1 && (ntohl(a.s_addr) >> 24) == 127;
}

void require_curve_for(const std::string& endpoint, bool keys, const std::string& how_to_enable) {
  if (keys || is_local_endpoint(endpoint)) return;
  throw std::runtime_error("endpoint " + endpoint +
                           " is not loopback or ipc: a bus reachable from other hosts must use CURVE "
                           "(authenticated and encrypted); " + how_to_enable);
}

void apply(zmq::socket_t& sock, const SocketKeys& keys, bool server) {
  if (keys.own.secret_key.empty()) throw std::invalid_argument("curve: the socket's own secret key is missing");
  if (server) {
    sock.set(zmq::sockopt::curve_server, 1);
    sock.set(zmq::sockopt::zap_domain, "mlcg");
  } else {
    if (keys.server_public.empty()) throw std::invalid_argument("curve: a client needs the server's public key");
    sock.set(zmq::sockopt::curve_serverkey, keys.server_public);
    sock.set(zmq::sockopt::curve_publickey, keys.own.public_key);
  }
  sock.set(zmq::sockopt::curve_secretkey, keys.own.secret_key);
}

void set_process_keys(const SocketKeys& keys) { g_process_keys = keys; }
const SocketKeys* process_keys() { return g_process_keys ? &*g_process_keys : nullptr; }

namespace {
void both_or_neither(const fs::path& a, const char* fa, const fs::path& b, const char* fb) {
  if (a.empty() != b.empty())
    throw std::runtime_error(fmt::format("{} and {} go together (both or neither); got only {}", fa, fb,
                                         a.empty() ? fb : fa));
}
}  // namespace

std::unique_ptr<Server> server_from_files(zmq::context_t& ctx, const fs::path& server_key, const fs::path& clients,
                                          Authenticator::Report on_refused, Authenticator::Report on_accepted) {
  both_or_neither(server_key, "--curve-server-key", clients, "--curve-clients");
  if (server_key.empty()) return nullptr;
  auto s = std::make_unique<Server>();
  s->keys.own = read_key_file(server_key);
  if (s->keys.own.secret_key.empty()) throw std::runtime_error(server_key.string() + ": no 'secret = ...' line");
  s->auth = std::make_unique<Authenticator>(ctx, read_client_list(clients), std::move(on_refused),
                                            std::move(on_accepted));
  return s;
}

std::optional<SocketKeys> client_from_files(const fs::path& server_public, const fs::path& client_key) {
  both_or_neither(server_public, "--curve-server-public", client_key, "--curve-client-key");
  if (server_public.empty()) return std::nullopt;
  SocketKeys k;
  k.server_public = read_key_file(server_public).public_key;
  k.own = read_key_file(client_key);
  if (k.own.secret_key.empty()) throw std::runtime_error(client_key.string() + ": no 'secret = ...' line");
  return k;
}

Authenticator::Authenticator(zmq::context_t& ctx, const std::vector<IssuedKey>& clients, Report on_refused,
                             Report on_accepted)
    : ctx_(ctx), clients_(clients), on_refused_(std::move(on_refused)), on_accepted_(std::move(on_accepted)) {
  // Bound here, before any server socket exists, so no handshake can slip past an absent handler
  // (libzmq lets every CURVE client in when no ZAP handler is bound).
  zap_ = std::make_unique<zmq::socket_t>(ctx_, zmq::socket_type::rep);
  zap_->set(zmq::sockopt::linger, 0);
  try {
    zap_->bind("inproc://zeromq.zap.01");
  } catch (const zmq::error_t& e) {
    throw std::runtime_error(std::string("curve: cannot start the ZAP handler (one per context): ") + e.what());
  }
  thread_ = std::thread([this] { loop(); });
}

Authenticator::~Authenticator() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
  for (const auto& [key, r] : recent_)  // the attempts counted but not yet logged
    if (r.count > 1 && on_refused_) on_refused_(fmt::format("{} ({} more such attempt(s) after it)", r.line, r.count - 1));
}

void Authenticator::watch(zmq::socket_t& server) {
  static std::atomic<int> n{0};
  const std::string addr = fmt::format("inproc://mlcg-curve-monitor-{}-{}", getpid(), n++);
  const int events = ZMQ_EVENT_ACCEPTED | ZMQ_EVENT_HANDSHAKE_FAILED_NO_DETAIL | ZMQ_EVENT_HANDSHAKE_FAILED_PROTOCOL;
  if (zmq_socket_monitor(server.handle(), addr.c_str(), events) != 0)
    throw std::runtime_error(std::string("curve: cannot monitor the server socket: ") + zmq_strerror(zmq_errno()));
  auto pair = std::make_unique<zmq::socket_t>(ctx_, zmq::socket_type::pair);
  pair->set(zmq::sockopt::linger, 0);
  pair->connect(addr);
  std::lock_guard<std::mutex> lock(mu_);  // hands the socket to the handler thread
  monitors_.push_back(std::move(pair));
  monitored_.push_back(server.get(zmq::sockopt::last_endpoint));
}

void Authenticator::loop() {
  while (!stop_) {
    std::lock_guard<std::mutex> lock(mu_);
    std::vector<zmq::pollitem_t> items{{zap_->handle(), 0, ZMQ_POLLIN, 0}};
    for (auto& m : monitors_) items.push_back({m->handle(), 0, ZMQ_POLLIN, 0});
    zmq::poll(items.data(), items.size(), std::chrono::milliseconds(50));
    if (items[0].revents & ZMQ_POLLIN) answer_zap();
    if (items.size() > 1) read_monitor();
  }
}

void Authenticator::report_refused(const std::string& who, const std::string& line) {
  ++refused_;
  if (!on_refused_) return;
  // A refused client reconnects every 100 ms: the same host and reason within 5 s is counted and
  // its count logged with the next line, so every attempt is accounted without flooding the log.
  const std::string key = who.substr(0, who.rfind(':')) + line.substr(line.rfind(": "));
  const auto now = std::chrono::steady_clock::now();
  auto& r = recent_[key];
  if (r.count > 0 && now - r.logged < std::chrono::seconds(5)) {
    ++r.count;
    return;
  }
  const uint64_t more = r.count > 1 ? r.count - 1 : 0;
  r = {now, 1, line};
  on_refused_(more ? fmt::format("{} ({} more such attempt(s) before this one)", line, more) : line);
}

void Authenticator::answer_zap() {
  std::vector<zmq::message_t> req;
  if (!zmq::recv_multipart(*zap_, std::back_inserter(req), zmq::recv_flags::dontwait)) return;
  // RFC 27: version, request id, domain, address, routing id, mechanism, credentials...
  const auto frame = [&](size_t i) { return i < req.size() ? req[i].to_string() : std::string(); };
  const std::string address = frame(3), mechanism = frame(5);
  std::string reason, name, key;
  if (frame(0) != "1.0") {
    reason = "ZAP version '" + frame(0) + "'";
  } else if (mechanism != "CURVE") {
    reason = "mechanism " + mechanism + " (the bus accepts CURVE only)";
  } else if (req.size() < 7 || req[6].size() != 32) {
    reason = "no CURVE public key in the request";
  } else {
    char z85[41];
    zmq_z85_encode(z85, static_cast<const uint8_t*>(req[6].data()), 32);
    key = z85;
    for (const auto& c : clients_)
      if (c.public_key == key) name = c.name;
    if (name.empty()) reason = "client public key " + key + " was not issued for this run";
  }
  const std::vector<std::string> parts{"1.0", frame(1), reason.empty() ? "200" : "400", reason.empty() ? "OK" : reason,
                                       name, ""};
  std::vector<zmq::const_buffer> bufs;
  for (const auto& p : parts) bufs.push_back(zmq::buffer(p));
  zmq::send_multipart(*zap_, bufs);
  const std::string who = address.empty() ? std::string("a local process (ipc)") : address;
  if (!reason.empty()) {
    report_refused(who, "bus: refused a connection from " + who + ": " + reason);
  } else if (on_accepted_) {
    on_accepted_("bus: accepted the CURVE key of '" + name + "' from " + who);
  }
}

void Authenticator::read_monitor() {
  for (size_t m = 0; m < monitors_.size(); ++m) {
    std::vector<zmq::message_t> ev;
    while (zmq::recv_multipart(*monitors_[m], std::back_inserter(ev), zmq::recv_flags::dontwait)) {
      if (ev.size() < 2 || ev[0].size() < 6) {
        ev.clear();
        continue;
      }
      uint16_t event = 0;
      uint32_t value = 0;
      std::memcpy(&event, ev[0].data(), 2);
      std::memcpy(&value, static_cast<const char*>(ev[0].data()) + 2, 4);
      ev.clear();
      // libzmq reports the bound endpoint, not the peer, on a failed handshake: the peer is the
      // connection accepted just before (exact while handshakes do not interleave).
      if (event == ZMQ_EVENT_ACCEPTED) {
        last_peer_ = peer_of(static_cast<int>(value));
        continue;
      }
      std::string reason;
      if (event == ZMQ_EVENT_HANDSHAKE_FAILED_PROTOCOL && value == ZMQ_PROTOCOL_ERROR_ZMTP_MECHANISM_MISMATCH)
        reason = "the client does not use CURVE (started without the run's keys?)";
      else if (event == ZMQ_EVENT_HANDSHAKE_FAILED_PROTOCOL && value == ZMQ_PROTOCOL_ERROR_ZMTP_CRYPTOGRAPHIC)
        reason = "the client's CURVE handshake does not decrypt (it holds another server public key)";
      else if (event == ZMQ_EVENT_HANDSHAKE_FAILED_NO_DETAIL)  // value: errno; a peer speaking no CURVE, mostly
        reason = fmt::format("the handshake broke off before CURVE was agreed ({})", std::strerror(static_cast<int>(value)));
      else
        reason = fmt::format("handshake failed (ZeroMQ protocol error {:#x})", value);
      // The fd is read after libzmq's own thread accepted it; a client that hangs up at once (a plain
      // client meeting CURVE often does) is closed before it can be asked for its address.
      const std::string who = last_peer_.empty() ? std::string("a peer that hung up before it could be named") : last_peer_;
      report_refused(who, fmt::format("bus: refused a connection on {} from {}: {}", monitored_[m], who, reason));
    }
  }
}

}  // namespace mlcg::bus::curve
