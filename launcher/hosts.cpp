#include "hosts.hpp"

#include <arpa/inet.h>
#include <netdb.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <fstream>
#include <sstream>
#include <thread>

#include <fmt/format.h>

#include "bus/curve.hpp"
#include "process.hpp"

namespace fs = std::filesystem;

namespace mlcg::launcher {
namespace {

std::string resolve_ipv4(const std::string& name) {
  addrinfo hints{};
  hints.ai_family = AF_INET;
  addrinfo* res = nullptr;
  if (getaddrinfo(name.c_str(), nullptr, &hints, &res) != 0 || !res) return {};
  char buf[INET_ADDRSTRLEN] = {0};
  inet_ntop(AF_INET, &reinterpret_cast<const sockaddr_in*>(res->ai_addr)->sin_addr, buf, sizeof buf);
  freeaddrinfo(res);
  return buf;
}

std::vector<std::string> split(const std::string& s, char sep) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  for (std::string t; std::getline(ss, t, sep);) out.push_back(t);
  return out;
}

}  // namespace

HostFile read_hostfile(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw HostError(path + ": cannot read the hostfile");
  HostFile hf;
  hf.path = path;
  int n = 0;
  for (std::string line; std::getline(in, line);) {
    ++n;
    if (const size_t hash = line.find('#'); hash != std::string::npos) line.erase(hash);
    std::istringstream ss(line);
    std::vector<std::string> tok;
    for (std::string t; ss >> t;) tok.push_back(t);
    if (tok.empty()) continue;
    const auto err = [&](const std::string& what) { return HostError(fmt::format("{}:{}: {}", path, n, what)); };
    if (tok[0] == "rsh_agent") {
      if (tok.size() != 2) throw err("rsh_agent takes one path (the program mpirun runs as `PATH HOST COMMAND...`)");
      hf.rsh_agent = fs::absolute(tok[1]).string();
      if (access(hf.rsh_agent.c_str(), X_OK) != 0) throw err("rsh_agent " + hf.rsh_agent + " is not an executable file");
      continue;
    }
    if (tok[0] == "mca") {
      if (tok.size() != 3) throw err("mca takes a key and a value (mca oob_tcp_if_include 10.77.0.0/24)");
      hf.mca.emplace_back(tok[1], tok[2]);
      continue;
    }
    Host h;
    h.name = tok[0];
    h.line = n;
    bool slots = false;
    for (size_t i = 1; i < tok.size(); ++i) {
      const std::string& t = tok[i];
      const size_t eq = t.find('=');
      const std::string key = t.substr(0, eq), value = eq == std::string::npos ? "" : t.substr(eq + 1);
      if (t == "coupler") {
        h.coupler = true;
      } else if (key == "slots" && !value.empty()) {
        try {
          size_t used = 0;
          h.slots = std::stoi(value, &used);
          if (used != value.size() || h.slots < 1) throw std::invalid_argument(value);
        } catch (const std::exception&) {
          throw err("host '" + h.name + "': slots=" + value + " is not a whole number >= 1");
        }
        slots = true;
      } else if (key == "address" && !value.empty()) {
        in_addr a{};
        if (inet_pton(AF_INET, value.c_str(), &a) != 1) throw err("address=" + value + " is not an IPv4 address");
        h.address = value;
      } else if (key == "levels" && !value.empty()) {
        h.levels = split(value, ',');
      } else {
        throw err("'" + t + "' is not a host entry; allowed: NAME slots=N [address=IP] [coupler] [levels=A,B], "
                  "rsh_agent PATH, mca KEY VALUE");
      }
    }
    if (!slots) throw err("host '" + h.name + "' needs slots=N (how many processes it runs)");
    for (const auto& o : hf.hosts)
      if (o.name == h.name) throw err(fmt::format("host '{}' is listed twice (first at line {})", h.name, o.line));
    hf.hosts.push_back(h);
  }
  if (hf.hosts.empty()) throw HostError(path + ": no hosts (lines NAME slots=N)");
  return hf;
}

Placement::Placement(const HostFile& hf, const config::CaseSpec& cs)
    : hosts_(hf.hosts), rsh_agent_(hf.rsh_agent), mca_(hf.mca) {
  curve_ = true;  // across hosts the bus is never left open
  const auto at = [&](const Host& h) { return fmt::format("{}:{}: host '{}'", hf.path, h.line, h.name); };
  std::vector<int> used(hosts_.size(), 0);
  const auto place = [&](const std::string& who, size_t h, int ranks) {
    where_[who] = h;
    used[h] += ranks;
  };
  for (size_t h = 0; h < hosts_.size(); ++h) {
    if (!hosts_[h].coupler) continue;
    if (where_.count("coupler")) throw HostError(at(hosts_[h]) + ": the coupler is already placed on another host");
    place("coupler", h, 1);
  }
  if (!where_.count("coupler")) place("coupler", 0, 1);
  for (size_t h = 0; h < hosts_.size(); ++h)
    for (const auto& name : hosts_[h].levels) {
      const auto l = std::find_if(cs.levels.begin(), cs.levels.end(), [&](const auto& x) { return x.name == name; });
      if (l == cs.levels.end()) {
        std::string all;
        for (const auto& x : cs.levels) all += (all.empty() ? "" : ", ") + x.name;
        throw HostError(at(hosts_[h]) + ": levels=" + name + ": the case has no such level (it has " + all + ")");
      }
      if (where_.count(name)) throw HostError(at(hosts_[h]) + ": level '" + name + "' is placed twice");
      place(name, h, l->ranks);
    }
  const auto check_fit = [&] {
    for (size_t h = 0; h < hosts_.size(); ++h)
      if (used[h] > hosts_[h].slots)
        throw HostError(fmt::format("{}: the processes placed there need {} slots, it has slots={}", at(hosts_[h]),
                                    used[h], hosts_[h].slots));
  };
  check_fit();  // the explicit placements; the rest go only where they fit
  for (const auto& l : cs.levels) {
    if (where_.count(l.name)) continue;
    size_t h = 0;
    while (h < hosts_.size() && used[h] + l.ranks > hosts_[h].slots) ++h;
    if (h == hosts_.size())
      throw HostError(fmt::format("{}: no host has {} free slot(s) for level '{}' ({} rank(s)); add slots or hosts",
                                  hf.path, l.ranks, l.name, l.ranks));
    place(l.name, h, l.ranks);
  }
  Host& ch = hosts_[where_.at("coupler")];
  if (ch.address.empty()) ch.address = resolve_ipv4(ch.name);
  if (ch.address.empty())
    throw HostError(at(ch) + ": the coupler runs there but the name does not resolve; give address=IP");
  for (const auto& [who, h] : where_)
    if (h != where_.at("coupler") && bus::curve::is_local_endpoint("tcp://" + ch.address + ":0"))
      throw HostError(fmt::format("{}: the coupler's address {} is loopback, which level '{}' on host '{}' cannot "
                                  "reach; give address=IP", at(ch), ch.address, who, hosts_[h].name));
}

void Placement::check(const config::CaseSpec& cs) const {
  if (!remote() && !curve_ && cs.coupling && !cs.coupling->endpoint.empty())
    bus::curve::require_curve_for(cs.coupling->endpoint, false,
                                  "[coupling] endpoint (" + cs.coupling->loc.str() +
                                      "): run with --curve (keys for this run) or --hosts HOSTFILE");
}

std::string Placement::prepare(const config::CaseSpec& cs, const fs::path& run_dir, const std::string& local_endpoint) {
  endpoint_ = remote() ? "tcp://" + hosts_[where_.at("coupler")].address + ":*" : local_endpoint;
  endpoint_file_ = fs::absolute(run_dir) / "coupler.endpoint";
  fs::remove(endpoint_file_);
  if (!curve_) return endpoint_;
  keys_ = fs::absolute(run_dir) / "keys";
  fs::create_directories(keys_);
  fs::permissions(keys_, fs::perms::owner_all, fs::perm_options::replace);
  const bus::curve::KeyPair server = bus::curve::generate();
  bus::curve::write_key_file(keys_ / "server.key", server);
  bus::curve::write_key_file(keys_ / "server.pub", {server.public_key, {}});
  std::vector<bus::curve::IssuedKey> clients;
  for (const auto& l : cs.levels) {
    const bus::curve::KeyPair k = bus::curve::generate();
    bus::curve::write_key_file(keys_ / (l.name + ".key"), k);
    clients.push_back({l.name, k.public_key});
  }
  bus::curve::write_client_list(keys_ / "clients.pub", clients);
  return endpoint_;
}

const Host& Placement::host_of(const std::string& who) const { return hosts_.at(where_.at(who)); }

std::vector<std::string> Placement::launch_prefix(const std::string& who, int ranks) const {
  if (!remote()) return ranks > 1 ? mpirun_prefix(ranks) : std::vector<std::string>{};
  std::vector<std::string> a = mpirun_prefix(ranks);
  const Host& h = host_of(who);
  a.insert(a.end(), {"--host", fmt::format("{}:{}", h.name, h.slots)});
  if (!rsh_agent_.empty()) a.insert(a.end(), {"--mca", "plm_rsh_agent", rsh_agent_});
  for (const auto& [k, v] : mca_) a.insert(a.end(), {"--mca", k, v});
  return a;
}

std::vector<std::string> Placement::extra_args(const std::string& who) const {
  std::vector<std::string> a;
  if (who == "coupler") {
    a = {"--endpoint-file", endpoint_file_.string()};
    if (curve_)
      a.insert(a.end(), {"--curve-server-key", (keys_ / "server.key").string(), "--curve-clients",
                         (keys_ / "clients.pub").string()});
  } else if (curve_) {
    a = {"--curve-server-public", (keys_ / "server.pub").string(), "--curve-client-key",
         (keys_ / (who + ".key")).string()};
  }
  return a;
}

std::string Placement::bound_endpoint(pid_t coupler, double timeout) const {
  const auto t0 = std::chrono::steady_clock::now();
  for (;;) {
    std::ifstream in(endpoint_file_);
    std::string ep;
    if (in >> ep && ep.find('*') == std::string::npos) return ep;
    int status = 0;
    if (waitpid(coupler, &status, WNOHANG) == coupler)
      throw std::runtime_error(fmt::format("the coupler exited (code {}) before binding {}; see its coupler.log",
                                           WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status), endpoint_));
    if (std::chrono::steady_clock::now() - t0 > std::chrono::duration<double>(timeout)) {
      kill(-coupler, SIGTERM);
      waitpid(coupler, &status, 0);
      throw std::runtime_error(fmt::format("the coupler did not bind {} within {} s (no {}); stopped it", endpoint_,
                                           timeout, endpoint_file_.string()));
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
}

void Placement::forget_bound_endpoint() const {
  std::error_code ec;
  if (!endpoint_file_.empty()) fs::remove(endpoint_file_, ec);
}

std::string Placement::describe() const {
  std::string out;
  for (const auto& [who, h] : where_)
    out += fmt::format("mlcg: {} on host {}\n", who == "coupler" ? who : "level '" + who + "'", hosts_[h].name);
  if (curve_) out += fmt::format("mlcg: bus secured with CURVE, keys issued in {}\n", keys_.string());
  return out;
}

}  // namespace mlcg::launcher
