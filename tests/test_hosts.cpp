// `mlcg run --hosts` and `--curve` refuse what cannot run before starting
// anything: hostfile mistakes name file:line and what is allowed, a placement
// that does not fit names the host, and a non-loopback endpoint without CURVE
// is refused. (The runs themselves: tests/netns, test_launcher.)
#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>

namespace fs = std::filesystem;

namespace {

const std::string kCase = std::string(MLCG_SOURCE_DIR) + "/cases/quickstart/mlcg.toml";

struct Result {
  int code = -1;
  std::string out;
};

// Runs `mlcg run CASE ARGS --out DIR`; the run folder must not appear when mlcg refuses.
Result mlcg_run(const std::string& kase, const std::string& args) {
  const fs::path dir = fs::temp_directory_path() / ("mlcg_hosts_" + std::to_string(getpid()));
  const std::string log = dir.string() + ".out";
  const int s = std::system((std::string(MLCG_BIN_DIR) + "/mlcg run " + kase + " " + args + " --out " + dir.string() +
                             " > " + log + " 2>&1")
                                .c_str());
  Result r;
  r.code = WIFEXITED(s) ? WEXITSTATUS(s) : -1;
  std::ifstream in(log);
  r.out.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  EXPECT_FALSE(fs::exists(dir)) << "a refused run must not create its folder";
  fs::remove_all(dir);
  fs::remove(log);
  return r;
}

// Writes a hostfile with `text` and returns its path.
std::string hostfile(const std::string& text) {
  const fs::path p = fs::temp_directory_path() / ("mlcg_hosts_" + std::to_string(getpid()) + ".hosts");
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
  expect_refused("h1 slots=2 cpus=4\n", hf + ":1: 'cpus=4' is not a host entry; allowed: NAME slots=N");
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
}

TEST(Hosts, NonLoopbackEndpointWithoutCurveIsRefusedByTheLauncher) {
  const fs::path kase = fs::temp_directory_path() / ("mlcg_hosts_case_" + std::to_string(getpid()) + ".toml");
  {
    std::ifstream src(kCase);
    std::string text((std::istreambuf_iterator<char>(src)), std::istreambuf_iterator<char>());
    text.replace(text.find("[coupling]"), 10, "[coupling]\nendpoint = \"tcp://10.77.0.9:5555\"");
    std::ofstream(kase) << text;
  }
  const Result r = mlcg_run(kase.string(), "");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("endpoint tcp://10.77.0.9:5555 is not loopback or ipc"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("run with --curve"), std::string::npos) << r.out;
  fs::remove(kase);
}
