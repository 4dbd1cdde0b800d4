#include "hosts/hosts.hpp"

#include <arpa/inet.h>
#include <netdb.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <cstdlib>
#include <chrono>
#include <fstream>
#include <sstream>
#include <thread>

#include <fmt/format.h>

#include "bus/curve.hpp"
#include "config/case_keys.hpp"
#include "process/process.hpp"

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
        const auto& spec = config::schema::at(config::schema::kHostEntry, "slots");  // its bounds
        try {
          size_t used = 0;
          h.slots = std::stoi(value, &used);
          if (used != value.size() || !spec.bounds.contains(h.slots)) throw std::invalid_argument(value);
        } catch (const std::exception&) {
          throw err("host '" + h.name + "': slots=" + value + " is not a whole number >= " +
                    fmt::format("{:g}", spec.bounds.lo));
        }
        slots = true;
      } else if (key == "address" && !value.empty()) {
        in_addr a{};
        if (inet_pton(AF_INET, value.c_str(), &a) != 1) throw err("address=" + value + " is not an IPv4 address");
        h.address = value;
      } else if (key == "levels" && !value.empty()) {
        h.levels = split(value, ',');
      } else {
        const auto& known = config::keys::kHostEntry;
        const bool is_key = std::find(known.begin(), known.end(), key) != known.end();
        throw err("'" + t + "' is not a host entry" + (is_key ? "" : ": " + config::unknown_key(key, known)) +
                  "; a host line is NAME slots=N [address=IP] [coupler] [levels=A,B]; other lines: rsh_agent PATH, "
                  "mca KEY VALUE");
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

namespace {

// Splits at the commas outside brackets: "n[1-2,4],m" -> "n[1-2,4]", "m".
std::vector<std::string> split_top(const std::string& s) {
  std::vector<std::string> out;
  std::string cur;
  int depth = 0;
  for (const char c : s) {
    if (c == '[') ++depth;
    if (c == ']') --depth;
    if (depth < 0 || depth > 1) throw HostError("'" + s + "': unbalanced brackets in a Slurm node list");
    if (c == ',' && depth == 0) {
      out.push_back(cur);
      cur.clear();
    } else {
      cur += c;
    }
  }
  if (depth != 0) throw HostError("'" + s + "': unbalanced brackets in a Slurm node list");
  out.push_back(cur);
  return out;
}

int whole_number(const std::string& t, const std::string& in) {
  size_t used = 0;
  int v = -1;
  try {
    v = std::stoi(t, &used);
  } catch (const std::exception&) {
  }
  if (t.empty() || used != t.size() || v < 0 || !std::isdigit(static_cast<unsigned char>(t[0])))
    throw HostError("'" + in + "': '" + t + "' is not a whole number");
  return v;
}

// One item of a node list with zero or more bracket groups: "r[1-2]n[01-02]" -> r1n01 r1n02 r2n01 r2n02.
void expand_item(const std::string& item, const std::string& whole, std::vector<std::string>& out) {
  const size_t open = item.find('[');
  if (open == std::string::npos) {
    out.push_back(item);
    return;
  }
  const size_t close = item.find(']', open);
  const std::string prefix = item.substr(0, open), rest = item.substr(close + 1);
  for (const auto& range : split(item.substr(open + 1, close - open - 1), ',')) {
    const size_t dash = range.find('-');
    const std::string a = range.substr(0, dash), b = dash == std::string::npos ? a : range.substr(dash + 1);
    const int from = whole_number(a, whole), to = whole_number(b, whole);
    if (to < from) throw HostError("'" + whole + "': the range " + range + " runs backwards");
    for (int k = from; k <= to; ++k)
      expand_item(prefix + fmt::format("{:0{}}", k, a.size()) + rest, whole, out);
  }
}

// Slurm's NodeAddr of `node` (scontrol show node), "" when scontrol cannot tell.
std::string slurm_node_addr(const std::string& node) {
  for (const char c : node)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '-' && c != '.' && c != '_') return {};
  FILE* p = popen(("scontrol show node -o '" + node + "' 2>/dev/null").c_str(), "r");
  if (!p) return {};
  std::string text;
  char buf[4096];
  for (size_t n; (n = fread(buf, 1, sizeof buf, p)) > 0;) text.append(buf, n);
  pclose(p);
  const size_t at = text.find(" NodeAddr=");
  if (at == std::string::npos) return {};
  const size_t from = at + 10;
  return text.substr(from, text.find_first_of(" \n", from) - from);
}

}  // namespace

std::vector<std::string> expand_slurm_nodelist(const std::string& list) {
  std::vector<std::string> out;
  for (const auto& item : split_top(list)) {
    if (item.empty()) throw HostError("'" + list + "': an empty name in a Slurm node list");
    expand_item(item, list, out);
  }
  return out;
}

std::vector<int> expand_slurm_counts(const std::string& list) {
  std::vector<int> out;
  for (const auto& item : split(list, ',')) {
    const size_t x = item.find("(x");
    const int n = whole_number(item.substr(0, x), list);
    int times = 1;
    if (x != std::string::npos) {
      if (item.back() != ')') throw HostError("'" + list + "': '" + item + "' is not N or N(xK)");
      times = whole_number(item.substr(x + 2, item.size() - x - 3), list);
    }
    out.insert(out.end(), times, n);
  }
  return out;
}

std::optional<HostFile> slurm_hosts(const EnvLookup& lookup) {
  const auto env = [&](const std::string& name) -> std::string {
    if (lookup) return lookup(name);
    const char* v = std::getenv(name.c_str());
    return v ? v : "";
  };
  const std::string job = env("SLURM_JOB_ID"), nodelist = env("SLURM_JOB_NODELIST");
  if (job.empty() || nodelist.empty()) return std::nullopt;
  std::string counts_var = "SLURM_TASKS_PER_NODE", counts_text = env("SLURM_TASKS_PER_NODE");
  if (counts_text.empty()) counts_text = env(counts_var = "SLURM_JOB_CPUS_PER_NODE");
  HostFile hf;
  hf.path = "Slurm job " + job;
  const auto nodes = expand_slurm_nodelist(nodelist);
  const auto counts = counts_text.empty() ? std::vector<int>(nodes.size(), 1) : expand_slurm_counts(counts_text);
  if (counts.size() != nodes.size())
    throw HostError(fmt::format("{}: SLURM_JOB_NODELIST={} names {} node(s) but {}={} gives {} count(s)", hf.path,
                                nodelist, nodes.size(), counts_var, counts_text, counts.size()));
  for (size_t k = 0; k < nodes.size(); ++k) {
    if (counts[k] < 1) continue;  // a node without tasks of this job
    Host h;
    h.name = nodes[k];
    h.slots = counts[k];
    h.line = static_cast<int>(k + 1);
    hf.hosts.push_back(h);
  }
  if (hf.hosts.empty()) throw HostError(hf.path + ": the allocation has no tasks (" + counts_var + "=" + counts_text + ")");
  // The coupler runs on the first node: bind the address Slurm reaches it at when that is not its name.
  if (!lookup) {
    const std::string addr = slurm_node_addr(hf.hosts[0].name);
    in_addr a{};
    if (!addr.empty() && addr != hf.hosts[0].name)
      hf.hosts[0].address = inet_pton(AF_INET, addr.c_str(), &a) == 1 ? addr : resolve_ipv4(addr);
  }
  return hf;
}

namespace {

using Where = std::map<std::string, std::vector<std::pair<size_t, int>>>;

// Places the coupler and the levels on the hosts, slot by slot: the coupler, the levels a host names, then
// the others where they fit.
class Placer {
 public:
  Placer(const HostFile& hf, const std::vector<Host>& hosts, Where& where)
      : hf_(hf), hosts_(hosts), where_(where), used_(hosts.size(), 0) {}

  std::string at(const Host& h) const { return fmt::format("{}:{}: host '{}'", hf_.path, h.line, h.name); }

  // coupler=1 on one host, else the first.
  void coupler() {
    for (size_t h = 0; h < hosts_.size(); ++h) {
      if (!hosts_[h].coupler) continue;
      if (where_.count("coupler")) throw HostError(at(hosts_[h]) + ": the coupler is already placed on another host");
      place("coupler", h, 1);
    }
    if (!where_.count("coupler")) place("coupler", 0, 1);
  }

  // levels=: a level named on one host runs there; named on several, its ranks fill them in the file's order
  // (each host up to its free slots, the last one takes the rest).
  void named_levels(const config::CaseSpec& cs) {
    std::vector<std::pair<std::string, std::vector<size_t>>> named;
    for (size_t h = 0; h < hosts_.size(); ++h)
      for (const auto& name : hosts_[h].levels) {
        const auto l = std::find_if(cs.levels.begin(), cs.levels.end(), [&](const auto& x) { return x.name == name; });
        if (l == cs.levels.end()) {
          std::string all;
          for (const auto& x : cs.levels) all += (all.empty() ? "" : ", ") + x.name;
          throw HostError(at(hosts_[h]) + ": levels=" + name + ": the case has no such level (it has " + all + ")");
        }
        auto n = std::find_if(named.begin(), named.end(), [&](const auto& x) { return x.first == name; });
        if (n == named.end()) n = named.insert(named.end(), {name, {}});
        if (std::find(n->second.begin(), n->second.end(), h) != n->second.end())
          throw HostError(at(hosts_[h]) + ": level '" + name + "' is placed twice");
        n->second.push_back(h);
      }
    for (const auto& [name, on] : named) {
      const auto& l = *std::find_if(cs.levels.begin(), cs.levels.end(), [&](const auto& x) { return x.name == name; });
      int left = l.ranks;
      for (size_t k = 0; k < on.size(); ++k) {
        const int n = k + 1 == on.size() ? left : std::min(left, free_on(on[k]));
        if (n == 0)
          throw HostError(fmt::format("{}: levels={}: the level's {} rank(s) already fill the hosts named before "
                                      "this one; name it on fewer hosts",
                                      at(hosts_[on[k]]), name, l.ranks));
        place(name, on[k], n);
        left -= n;
      }
    }
  }

  void check_fit() const {
    for (size_t h = 0; h < hosts_.size(); ++h)
      if (used_[h] > hosts_[h].slots)
        throw HostError(fmt::format("{}: the processes placed there need {} slots, it has slots={}", at(hosts_[h]),
                                    used_[h], hosts_[h].slots));
  }

  // The others: the first host with room for the whole level, else (a level larger than any host's free
  // slots) the hosts with free slots in order, each filled, as Open MPI maps ranks by slot.
  void other_levels(const config::CaseSpec& cs) {
    for (const auto& l : cs.levels) {
      if (where_.count(l.name)) continue;
      size_t h = 0;
      while (h < hosts_.size() && free_on(h) < l.ranks) ++h;
      if (h < hosts_.size()) {
        place(l.name, h, l.ranks);
        continue;
      }
      int total = 0;
      for (size_t k = 0; k < hosts_.size(); ++k) total += free_on(k);
      if (total < l.ranks)
        throw HostError(fmt::format("{}: no host has {} free slot(s) for level '{}' ({} rank(s)), and all hosts "
                                    "together have {}; add slots or hosts",
                                    hf_.path, l.ranks, l.name, l.ranks, total));
      int left = l.ranks;
      for (size_t k = 0; k < hosts_.size() && left > 0; ++k) {
        const int n = std::min(left, free_on(k));
        if (n == 0) continue;
        place(l.name, k, n);
        left -= n;
      }
    }
  }

 private:
  int free_on(size_t h) const { return std::max(0, hosts_[h].slots - used_[h]); }
  void place(const std::string& who, size_t h, int ranks) {
    where_[who].emplace_back(h, ranks);
    used_[h] += ranks;
  }

  const HostFile& hf_;
  const std::vector<Host>& hosts_;
  Where& where_;
  std::vector<int> used_;
};

}  // namespace

Placement::Placement(const HostFile& hf, const config::CaseSpec& cs)
    : hosts_(hf.hosts), rsh_agent_(hf.rsh_agent), mca_(hf.mca) {
  curve_ = true;  // across hosts the bus is never left open
  Placer placer(hf, hosts_, where_);
  placer.coupler();
  placer.named_levels(cs);
  placer.check_fit();  // the explicit placements; the rest go only where they fit
  placer.other_levels(cs);
  Host& ch = hosts_[where_.at("coupler").front().first];
  if (ch.address.empty()) ch.address = resolve_ipv4(ch.name);
  if (ch.address.empty())
    throw HostError(placer.at(ch) + ": the coupler runs there but the name does not resolve; give address=IP");
  const size_t coupler_host = where_.at("coupler").front().first;
  for (const auto& [who, on] : where_)
    for (const auto& [h, n] : on)
      if (h != coupler_host && bus::curve::is_local_endpoint("tcp://" + ch.address + ":0"))
        throw HostError(fmt::format("{}: the coupler's address {} is loopback, which level '{}' on host '{}' cannot "
                                    "reach; give address=IP", placer.at(ch), ch.address, who, hosts_[h].name));
}

void Placement::check(const config::CaseSpec& cs) const {
  if (!remote() && !curve_ && cs.coupling && !cs.coupling->endpoint.empty())
    bus::curve::require_curve_for(cs.coupling->endpoint, false,
                                  "[coupling] endpoint (" + cs.coupling->loc.str() +
                                      "): run with --curve (keys for this run) or --hosts HOSTFILE");
}

std::string Placement::prepare(const config::CaseSpec& cs, const fs::path& run_dir, const std::string& local_endpoint) {
  endpoint_ = remote() ? "tcp://" + host_of("coupler").address + ":*" : local_endpoint;
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

const Host& Placement::host_of(const std::string& who) const { return hosts_.at(where_.at(who).front().first); }

std::vector<std::string> Placement::launch_prefix(const std::string& who, int ranks) const {
  if (!remote()) return ranks > 1 ? mpirun_prefix(ranks) : std::vector<std::string>{};
  std::vector<std::string> a = mpirun_prefix(ranks);
  const auto& on = where_.at(who);
  std::string hosts;  // one host: all its slots (as before); several: the ranks placed on each, in order
  if (on.size() == 1) hosts = fmt::format("{}:{}", host_of(who).name, host_of(who).slots);
  for (size_t k = 0; on.size() > 1 && k < on.size(); ++k)
    hosts += fmt::format("{}{}:{}", k ? "," : "", hosts_[on[k].first].name, on[k].second);
  a.insert(a.end(), {"--host", hosts});
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
  for (const auto& [who, on] : where_) {
    const std::string name = who == "coupler" ? who : "level '" + who + "'";
    if (on.size() == 1) {
      out += fmt::format("mlcg: {} on host {}\n", name, hosts_[on[0].first].name);
      continue;
    }
    std::string list;
    for (const auto& [h, n] : on) list += fmt::format("{}{} ({} rank(s))", list.empty() ? "" : ", ", hosts_[h].name, n);
    out += fmt::format("mlcg: {} on hosts {}\n", name, list);
  }
  if (curve_) out += fmt::format("mlcg: bus secured with CURVE, keys issued in {}\n", keys_.string());
  return out;
}

}  // namespace mlcg::launcher
