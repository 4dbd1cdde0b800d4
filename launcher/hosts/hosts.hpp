#pragma once
// Where the processes of a hierarchy run (`mlcg run CASE --hosts HOSTFILE`) and
// how they reach the coupler. The default Placement is the local one: every
// process on this machine over ipc://, CURVE only when asked (--curve).
//
// Hostfile (Open MPI style, one entry per line, `#` starts a comment):
//   NAME slots=N [address=IP] [coupler] [levels=A,B]   a host: N processes/ranks;
//                      `coupler` puts the coupler there (default: the first host),
//                      `levels=` the named [[levels]] (others: first host with room;
//                      a level with more ranks than any host has free spans several,
//                      as does a level named on several hosts)
//   rsh_agent PATH     mpirun starts remote processes through PATH (plm_rsh_agent)
//   mca KEY VALUE      passed to every mpirun as --mca KEY VALUE
// Inside a Slurm allocation the hosts come from Slurm's environment instead
// (slurm_hosts: the allocation's nodes and their task counts as slots).
// With hosts, every process (the coupler too) is started by mpirun --host, the
// coupler binds tcp://ADDRESS:* on its host and reports the port through a file
// in the run folder, and the bus uses CURVE with keys issued for this run.
#include <sys/types.h>

#include <filesystem>
#include <functional>
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

// Slurm's compressed lists: "n[1-3,5],m" -> n1 n2 n3 n5 m (the form of SLURM_JOB_NODELIST), and
// "2(x3),1" -> 2 2 2 1 (SLURM_TASKS_PER_NODE, SLURM_JOB_CPUS_PER_NODE). Throw HostError when malformed.
std::vector<std::string> expand_slurm_nodelist(const std::string& list);
std::vector<int> expand_slurm_counts(const std::string& list);
// Inside a Slurm allocation (SLURM_JOB_ID and SLURM_JOB_NODELIST set): the allocation's nodes as hosts,
// slots = the job's tasks on each (SLURM_TASKS_PER_NODE, else SLURM_JOB_CPUS_PER_NODE), the coupler on
// the first node, its address Slurm's NodeAddr of that node (scontrol) when that differs from the name.
// `env` looks a variable up ("" when unset; getenv when not given). std::nullopt outside an allocation.
using EnvLookup = std::function<std::string(const std::string&)>;
std::optional<HostFile> slurm_hosts(const EnvLookup& env = {});

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
  const Host& host_of(const std::string& who) const;  // the (first) host of `who`

  bool curve_ = false;
  std::vector<Host> hosts_;
  // "coupler" / level name -> (host index, its ranks there), one entry per host it runs on
  std::map<std::string, std::vector<std::pair<size_t, int>>> where_;
  std::string rsh_agent_;
  std::vector<std::pair<std::string, std::string>> mca_;
  std::string endpoint_;
  std::filesystem::path keys_, endpoint_file_;
};

}  // namespace mlcg::launcher
