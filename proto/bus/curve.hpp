#pragma once
// ZeroMQ CURVE on the bus: per-run keys, key files, the socket options and the
// coupler's authenticator.
//
// The launcher generates a server keypair and one client keypair per process it
// starts, writes them into <run>/keys/ (mode 0600) and hands each process only
// the paths it needs. The coupler's ROUTER is the CURVE server; an Authenticator
// (a ZAP handler thread in the coupler's context) accepts only the issued client
// public keys and reports every refused attempt. Rule: a tcp endpoint that is not
// loopback must use CURVE (require_curve_for).
#include <atomic>
#include <chrono>
#include <map>
#include <filesystem>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <zmq.hpp>

namespace mlcg::bus::curve {

// Z85 text of a 32-byte CURVE key (40 characters).
struct KeyPair {
  std::string public_key;
  std::string secret_key;  // empty when only the public half is known
};

// What one socket needs. Server: `own` (its keypair). Client: `own` and `server_public`.
struct SocketKeys {
  KeyPair own;
  std::string server_public;
};

// A fresh keypair (zmq_curve_keypair). Throws when libzmq was built without CURVE.
KeyPair generate();

// Key files: lines `public = Z85`, `secret = Z85`, `# comments`. Written mode 0600
// (created so, never world-readable even for a moment); read errors name file:line.
void write_key_file(const std::filesystem::path& file, const KeyPair& keys);
KeyPair read_key_file(const std::filesystem::path& file);
// The coupler's list of accepted clients: lines `NAME Z85` (mode 0600).
struct IssuedKey {
  std::string name, public_key;
};
void write_client_list(const std::filesystem::path& file, const std::vector<IssuedKey>& clients);
std::vector<IssuedKey> read_client_list(const std::filesystem::path& file);

// True for ipc://, inproc:// and tcp:// on 127.0.0.0/8, ::1 or localhost.
bool is_local_endpoint(const std::string& endpoint);
inline constexpr const char* kHowToEnable =
    "`mlcg run --curve` or `--hosts` issues keys (coupler_service --curve-server-key FILE --curve-clients FILE, "
    "dem_level --curve-server-public FILE --curve-client-key FILE)";
// Throws std::runtime_error naming the endpoint when it is not local and `keys` is false.
void require_curve_for(const std::string& endpoint, bool keys, const std::string& how_to_enable);

// Sets the CURVE options before bind/connect: server = the ROUTER that binds.
void apply(zmq::socket_t& sock, const SocketKeys& keys, bool server);

// Keys a process was given on its command line (dem_level's --curve-* flags);
// every bus::Channel created without explicit keys uses them. Null when none.
void set_process_keys(const SocketKeys& keys);
const SocketKeys* process_keys();

// ZAP handler (RFC 27) for the CURVE server sockets of `ctx`: accepts exactly the
// issued client public keys. `on_refused(text)` receives one line per refused
// attempt naming the peer address and the reason; watch() also reports
// handshakes that fail before ZAP (a client without keys, a wrong server key).
class Authenticator {
 public:
  using Report = std::function<void(const std::string&)>;
  Authenticator(zmq::context_t& ctx, const std::vector<IssuedKey>& clients, Report on_refused,
                Report on_accepted = {});
  ~Authenticator();
  Authenticator(const Authenticator&) = delete;
  Authenticator& operator=(const Authenticator&) = delete;

  // Reports failed handshakes of `server` (call from the thread owning it, before peers connect).
  void watch(zmq::socket_t& server);
  uint64_t refused() const { return refused_.load(); }

 private:
  void loop();
  void answer_zap();
  void read_monitor();
  void report_refused(const std::string& who, const std::string& line);

  zmq::context_t& ctx_;
  std::vector<IssuedKey> clients_;
  Report on_refused_, on_accepted_;
  std::unique_ptr<zmq::socket_t> zap_;
  std::mutex mu_;                            // guards monitors_ handed over by watch()
  std::vector<std::unique_ptr<zmq::socket_t>> monitors_;
  std::vector<std::string> monitored_;       // endpoint of each monitored socket
  struct Recent {
    std::chrono::steady_clock::time_point logged;
    uint64_t count = 0;  // attempts since `logged`, that one included
    std::string line;    // the one logged
  };
  std::map<std::string, Recent> recent_;     // by peer host and reason
  std::string last_peer_;                    // address of the last accepted tcp connection
  std::atomic<bool> stop_{false};
  std::atomic<uint64_t> refused_{0};
  std::thread thread_;
};

// The coupler's CURVE from its flags (both files or neither; nullptr for neither): its
// keys and an authenticator already answering, so it must exist before the socket binds.
struct Server {
  SocketKeys keys;
  std::unique_ptr<Authenticator> auth;
};
std::unique_ptr<Server> server_from_files(zmq::context_t& ctx, const std::filesystem::path& server_key,
                                          const std::filesystem::path& clients, Authenticator::Report on_refused,
                                          Authenticator::Report on_accepted = {});
// A level's keys from its flags (both files or neither; nullopt for neither).
std::optional<SocketKeys> client_from_files(const std::filesystem::path& server_public,
                                            const std::filesystem::path& client_key);

}  // namespace mlcg::bus::curve
