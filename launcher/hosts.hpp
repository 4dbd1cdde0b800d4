#pragma once
// Where the processes of a hierarchy run (`mlcg run CASE --hosts HOSTFILE`) and
// how they reach the coupler. The default Placement is the local one: every
// process on this machine over ipc://, CURVE only when asked (--curve).
//
// Hostfile (Open MPI style, one entry per line, `#` starts a comment):
//   NAME slots=N [address=IP] [coupler] [levels=A,B]   a host: N processes/ranks;
//                      `coupler` puts the coupler there (default: the first host),
//                      `levels=` the named [[levels]] (others: first host with room)
//   rsh_agent PATH     mpirun starts remote processes through PATH (plm_rsh_agent)
//   mca KEY VALUE      passed to every mpirun as --mca KEY VALUE
// With hosts, every process (the coupler too) is started by mpirun --host, the
// coupler binds tcp://ADDRESS:* on its host and reports the port through a file
// in the run folder, and the bus uses CURVE with keys issued for this run.
#include <sys/types.h>

#include <filesystem>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "config/case_spec.hpp"

namespace mlcg::launcher {

// A hostfile mistake: "file:line: what is wrong; what is allowed".
struct HostError : std::runtime_error { using std::runtime_error::runtime_error; };

struct Host {
  std::string name;
  int slots = 1;
  std::string address;  // the coupler's bus address when it runs here (address= or the name resolved)
  int line = 0;
  bool coupler = false;
  std::vector<std::string> levels;
};

struct HostFile {
  std::string path;
  std::vector<Host> hosts;
  std::string rsh_agent;
  std::vector<std::pair<std::string, std::string>> mca;
};
HostFile read_hostfile(const std::string& path);

class Placement {
 public:
  Placement() = default;  // local: this machine, the given endpoint, no CURVE
  // Places the coupler and every level of `cs` on the hosts (throws HostError).
  Placement(const HostFile& hf, const config::CaseSpec& cs);
  void enable_curve() { curve_ = true; }
  bool curve() const { return curve_; }
  bool remote() const { return !hosts_.empty(); }

  // Refuses what cannot run before anything starts (a non-loopback endpoint without CURVE).
  void check(const config::CaseSpec& cs) const;
  // Issues the keys into <run>/keys (CURVE) and returns the endpoint the coupler binds:
  // `local_endpoint` here, tcp://ADDRESS:* on the coupler's host.
  std::string prepare(const config::CaseSpec& cs, const std::filesystem::path& run_dir,
                      const std::string& local_endpoint);
  // argv before the program of process `who` ("coupler" or a level name) with `ranks` ranks.
  std::vector<std::string> launch_prefix(const std::string& who, int ranks) const;
  // Arguments after the program: the key files (and the coupler's endpoint file).
  std::vector<std::string> extra_args(const std::string& who) const;
  // The endpoint the coupler bound (waits for its endpoint file when remote). Stops the
  // coupler and throws when it exits or does not bind within `timeout` seconds.
  std::string bound_endpoint(pid_t coupler, double timeout = 60.0) const;
  // Removes the endpoint file a previous coupler of this run wrote (before a restart).
  void forget_bound_endpoint() const;
  // One line per process: where it runs.
  std::string describe() const;

 private:
  const Host& host_of(const std::string& who) const;

  bool curve_ = false;
  std::vector<Host> hosts_;
  std::map<std::string, size_t> where_;  // "coupler" / level name -> host index
  std::string rsh_agent_;
  std::vector<std::pair<std::string, std::string>> mca_;
  std::string endpoint_;
  std::filesystem::path keys_, endpoint_file_;
};

}  // namespace mlcg::launcher
