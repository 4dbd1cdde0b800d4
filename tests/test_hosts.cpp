// `mlcg run --hosts` and `--curve` refuse what cannot run before starting
// anything: hostfile mistakes name file:line and what is allowed, a placement
// that does not fit names the host, and a non-loopback endpoint without CURVE
// is refused. A level with more ranks than a host has free spans several hosts; inside a Slurm allocation
// the hosts come from Slurm's environment. (The runs themselves: tests/netns, tests/slurm, test_launcher.)
#include <gtest/gtest.h>


#include <filesystem>
#include <fstream>
#include <map>

#include "config/case_parser.hpp"
#include "files.hpp"
#include "shell.hpp"
#include "hosts/hosts.hpp"

namespace fs = std::filesystem;
using mlcg::test::run;
using mlcg::test::slurp;
using mlcg::test::temp_path;

namespace {

const std::string kCase = std::string(MLCG_SOURCE_DIR) + "/cases/quickstart/mlcg.toml";

struct Result {
  int code = -1;
  std::string out;
};

// Runs `mlcg run CASE ARGS --out DIR`; the run folder must not appear when mlcg refuses.
Result mlcg_run(const std::string& kase, const std::string& args) {
  const fs::path dir = temp_path("hosts");
  const std::string log = dir.string() + ".out";
  Result r;
  r.code = run(std::string(MLCG_BIN_DIR) + "/mlcg run " + kase + " " + args + " --out " + dir.string() + " > " + log +
               " 2>&1");
  r.out = slurp(log);
  EXPECT_FALSE(fs::exists(dir)) << "a refused run must not create its folder";
  fs::remove_all(dir);
  fs::remove(log);
  return r;
}

// Writes a hostfile with `text` and returns its path.
std::string hostfile(const std::string& text) {
  const fs::path p = temp_path("hosts").string() + ".hosts";
  std::ofstream(p) << text;
  return p.string();
}

void expect_refused(const std::string& hosts_text, const std::string& message) {
  const std::string hf = hostfile(hosts_text);
  const Result r = mlcg_run(kCase, "--hosts " + hf);
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find(message), std::string::npos) << "expected: " << message << "\ngot: " << r.out;
  fs::remove(hf);
}

}  // namespace

TEST(Hosts, HostfileMistakesNameFileLineAndWhatIsAllowed) {
  const std::string hf = fs::path(hostfile("")).filename().string();
  expect_refused("# hosts\nh1 slots=x\n", hf + ":2: host 'h1': slots=x is not a whole number >= 1");
  expect_refused("h1 slots=2\nh2\n", hf + ":2: host 'h2' needs slots=N");
  expect_refused("h1 slots=2 cpus=4\n", hf + ":1: 'cpus=4' is not a host entry: unknown key; allowed keys: slots, "
                                       "address, coupler, levels; a host line is NAME slots=N");
  expect_refused("h1 slot=2\n", hf + ":1: 'slot=2' is not a host entry: unknown key (did you mean 'slots'?)");
  expect_refused("h1 slots=\n", hf + ":1: 'slots=' is not a host entry; a host line is NAME slots=N");
  expect_refused("h1 slots=2\nh1 slots=1\n", hf + ":2: host 'h1' is listed twice (first at line 1)");
  expect_refused("h1 slots=2 address=10.0.0.300\n", hf + ":1: address=10.0.0.300 is not an IPv4 address");
  expect_refused("mca oob_tcp_if_include\nh1 slots=2\n", hf + ":1: mca takes a key and a value");
  expect_refused("rsh_agent /nonexistent/agent\nh1 slots=2\n", hf + ":1: rsh_agent /nonexistent/agent is not an executable");
  expect_refused("# nothing\n", hf + ": no hosts");
}

TEST(Hosts, PlacementsThatCannotRunAreRefused) {
  const std::string hf = fs::path(hostfile("")).filename().string();
  expect_refused("h1 slots=3 address=10.0.0.1 levels=medium\n",
                 hf + ":1: host 'h1': levels=medium: the case has no such level (it has coarse, fine)");
  expect_refused("h1 slots=1 address=10.0.0.1 coupler\nh2 slots=1\n", "no host has 1 free slot(s) for level 'fine'");
  expect_refused("h1 slots=1 address=10.0.0.1 coupler levels=coarse\n",
                 hf + ":1: host 'h1': the processes placed there need 2 slots, it has slots=1");
  expect_refused("h1 slots=2 coupler address=10.0.0.1\nh2 slots=2 coupler\n",
                 hf + ":2: host 'h2': the coupler is already placed on another host");
  expect_refused("h1 slots=1 address=127.0.0.1\nh2 slots=2\n",
                 "the coupler's address 127.0.0.1 is loopback, which level 'coarse' on host 'h2' cannot reach");
  expect_refused("no-such-host.invalid slots=3\n", "the coupler runs there but the name does not resolve");
  expect_refused("h1 slots=3 address=10.0.0.1 levels=fine,fine\n", hf + ":1: host 'h1': level 'fine' is placed twice");
}

namespace {

using mlcg::launcher::HostError;
using mlcg::launcher::Placement;

// The quickstart hierarchy with `fine_ranks` ranks on its fine level.
mlcg::config::CaseSpec quickstart(int fine_ranks) {
  std::string text = slurp(kCase);
  const std::string fine = "name = \"fine\"\nalpha = 1.0\n";
  text.replace(text.find(fine), fine.size(), fine + "ranks = " + std::to_string(fine_ranks) + "\n");
  return mlcg::config::parse_case(text, kCase);  // kCase's folder holds its base
}

Placement place(const std::string& hosts_text, int fine_ranks) {
  const std::string hf = hostfile(hosts_text);
  auto h = mlcg::launcher::read_hostfile(hf);
  fs::remove(hf);
  return Placement(h, quickstart(fine_ranks));
}

// The value after --host in the mpirun arguments of `who`.
std::string host_arg(const Placement& p, const std::string& who, int ranks) {
  const auto a = p.launch_prefix(who, ranks);
  for (size_t k = 0; k + 1 < a.size(); ++k)
    if (a[k] == "--host") return a[k + 1];
  return "";
}

std::string refusal(const std::string& hosts_text, int fine_ranks) {
  try {
    place(hosts_text, fine_ranks);
  } catch (const HostError& e) {
    return e.what();
  }
  return "(accepted)";
}

}  // namespace

TEST(Hosts, ALevelLargerThanAnyHostSpansTheHostsWithFreeSlots) {
  // The coupler and the coarse level fill h1; the 4-rank fine level fits on no single host.
  const auto p = place("h1 slots=2 address=10.0.0.1\nh2 slots=2\nh3 slots=3\n", 4);
  EXPECT_EQ(host_arg(p, "coupler", 1), "h1:2");
  EXPECT_EQ(host_arg(p, "coarse", 1), "h1:2");
  EXPECT_EQ(host_arg(p, "fine", 4), "h2:2,h3:2");
  EXPECT_NE(p.describe().find("level 'fine' on hosts h2 (2 rank(s)), h3 (2 rank(s))"), std::string::npos)
      << p.describe();
  // One host with room takes the whole level (as before): h3 has 3 free slots for 3 ranks.
  EXPECT_EQ(host_arg(place("h1 slots=2 address=10.0.0.1\nh2 slots=2\nh3 slots=3\n", 3), "fine", 3), "h3:3");
  // Free slots left on the coupler's host are used first.
  EXPECT_EQ(host_arg(place("h1 slots=3 address=10.0.0.1\nh2 slots=2\n", 3), "fine", 3), "h1:1,h2:2");
  EXPECT_NE(refusal("h1 slots=2 address=10.0.0.1\nh2 slots=2\nh3 slots=1\n", 4)
                .find("no host has 4 free slot(s) for level 'fine' (4 rank(s)), and all hosts together have 3"),
            std::string::npos);
}

TEST(Hosts, ALevelNamedOnSeveralHostsFillsThemInOrder) {
  const auto p = place("h1 slots=2 address=10.0.0.1 coupler levels=coarse\nh2 slots=3 levels=fine\n"
                       "h3 slots=2 levels=fine\n", 4);
  EXPECT_EQ(host_arg(p, "fine", 4), "h2:3,h3:1");
  const std::string hf = fs::path(hostfile("")).filename().string();
  // The last named host takes the rest, and must have the slots for it.
  EXPECT_NE(refusal("h1 slots=2 address=10.0.0.1 levels=coarse\nh2 slots=1 levels=fine\nh3 slots=1 levels=fine\n", 4)
                .find(hf + ":3: host 'h3': the processes placed there need 3 slots, it has slots=1"),
            std::string::npos);
  EXPECT_NE(refusal("h1 slots=2 address=10.0.0.1 levels=coarse\nh2 slots=4 levels=fine\nh3 slots=1 levels=fine\n", 4)
                .find(hf + ":3: host 'h3': levels=fine: the level's 4 rank(s) already fill the hosts named before"),
            std::string::npos);
}

TEST(Hosts, SlurmNodeListsAndTaskCountsExpand) {
  using mlcg::launcher::expand_slurm_counts;
  using mlcg::launcher::expand_slurm_nodelist;
  EXPECT_EQ(expand_slurm_nodelist("n1"), (std::vector<std::string>{"n1"}));
  EXPECT_EQ(expand_slurm_nodelist("mlcs-h[1-2]"), (std::vector<std::string>{"mlcs-h1", "mlcs-h2"}));
  EXPECT_EQ(expand_slurm_nodelist("a,gpu[08-10],b[1,3-4]x"),
            (std::vector<std::string>{"a", "gpu08", "gpu09", "gpu10", "b1x", "b3x", "b4x"}));
  EXPECT_EQ(expand_slurm_nodelist("r[1-2]n[1-2]"), (std::vector<std::string>{"r1n1", "r1n2", "r2n1", "r2n2"}));
  EXPECT_EQ(expand_slurm_counts("2(x3),1"), (std::vector<int>{2, 2, 2, 1}));
  EXPECT_EQ(expand_slurm_counts("4"), (std::vector<int>{4}));
  EXPECT_THROW(expand_slurm_nodelist("n[1-2"), HostError);
  EXPECT_THROW(expand_slurm_nodelist("n[3-1]"), HostError);
  EXPECT_THROW(expand_slurm_nodelist("n[a-b]"), HostError);
  EXPECT_THROW(expand_slurm_counts("2(x"), HostError);
  EXPECT_THROW(expand_slurm_counts("x"), HostError);
}

TEST(Hosts, InsideASlurmAllocationTheNodesAreTheHosts) {
  std::map<std::string, std::string> env;
  const auto lookup = [&](const std::string& k) { return env.count(k) ? env.at(k) : std::string(); };
  EXPECT_FALSE(mlcg::launcher::slurm_hosts(lookup).has_value()) << "outside an allocation";
  env = {{"SLURM_JOB_ID", "7"}, {"SLURM_JOB_NODELIST", "n[1-3]"}, {"SLURM_TASKS_PER_NODE", "1,2(x2)"},
         {"SLURM_JOB_CPUS_PER_NODE", "4(x3)"}};
  auto hf = mlcg::launcher::slurm_hosts(lookup);
  ASSERT_TRUE(hf.has_value());
  ASSERT_EQ(hf->hosts.size(), 3u);
  EXPECT_EQ(hf->hosts[0].name, "n1");
  EXPECT_EQ(hf->hosts[0].slots, 1);  // the job's tasks, not the node's CPUs
  EXPECT_EQ(hf->hosts[2].slots, 2);
  EXPECT_TRUE(hf->rsh_agent.empty()) << "mpirun reaches the nodes through Slurm";
  // The same placement as a hostfile's: the coupler on the first node, levels where they fit, a 3-rank fine
  // level over the two nodes left.
  hf->hosts[0].address = "10.0.0.1";
  const Placement p(*hf, quickstart(3));
  EXPECT_EQ(host_arg(p, "coupler", 1), "n1:1");
  EXPECT_EQ(host_arg(p, "coarse", 1), "n2:2");
  EXPECT_EQ(host_arg(p, "fine", 3), "n2:1,n3:2");
  env.erase("SLURM_TASKS_PER_NODE");  // salloc without --ntasks: the CPUs
  EXPECT_EQ(mlcg::launcher::slurm_hosts(lookup)->hosts[0].slots, 4);
  env["SLURM_TASKS_PER_NODE"] = "2";
  try {
    mlcg::launcher::slurm_hosts(lookup);
    ADD_FAILURE() << "a count list shorter than the node list was accepted";
  } catch (const HostError& e) {
    EXPECT_NE(std::string(e.what()).find("Slurm job 7: SLURM_JOB_NODELIST=n[1-3] names 3 node(s) but "
                                         "SLURM_TASKS_PER_NODE=2 gives 1 count(s)"),
              std::string::npos)
        << e.what();
  }
}

TEST(Hosts, NonLoopbackEndpointWithoutCurveIsRefusedByTheLauncher) {
  const fs::path kase = mlcg::test::copy_case(kCase, mlcg::test::fresh_temp_path("hosts_case"),
                                              {{"[coupling]", "[coupling]\nendpoint = \"tcp://10.77.0.9:5555\""}});
  const Result r = mlcg_run(kase.string(), "");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("endpoint tcp://10.77.0.9:5555 is not loopback or ipc"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("run with --curve"), std::string::npos) << r.out;
  mlcg::test::remove_case_copy(kase);
}
