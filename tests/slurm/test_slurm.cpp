// `mlcg submit` and `mlcg run` inside a Slurm allocation, against real Slurm daemons that the test starts
// itself (start_cluster.sh): munged, slurmctld and one slurmd per node, each node a network namespace of this
// machine with its own address and host name (mlcs-h1..3, 2 CPUs each). `mlcg submit` sizes the batch
// script from the case and sbatch queues it; inside the job mlcg takes the allocation's nodes from Slurm's
// environment, and Open MPI's mpirun starts the processes on the other nodes through Slurm (srun), no
// hostfile, no rsh agent. The per-face totals are those of the local run. Skipped (with the reason) unless
// root; fails (not skips) when a program scripts/setup.sh installs is missing or the namespaces cannot be made.
// The daemons are stopped and the namespaces removed in every case.
#include <gtest/gtest.h>

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <regex>
#include <thread>

#include "launch_support.hpp"
#include "run_checks.hpp"

namespace fs = std::filesystem;
using launch_support::kBin;
using launch_support::kSrc;
using launch_support::run;
using mlcg::test::fresh_temp_path;
using mlcg::test::slurp;

namespace {

const std::string kSlurm = kSrc + "/tests/slurm";
std::string g_cluster;  // the cluster's folder, for the signal handler

// Interrupted (Ctrl-C, ctest's timeout): stop the daemons and remove the namespaces before dying.
extern "C" void stop_and_exit(int sig) {
  const pid_t p = fork();
  if (p == 0) {
    const std::string stop = kSlurm + "/stop_cluster.sh";
    execl("/bin/sh", "sh", stop.c_str(), g_cluster.c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  if (p > 0) waitpid(p, nullptr, 0);
  _exit(128 + sig);
}

class Slurm : public ::testing::Test {
 protected:
  static constexpr int kNodes = 3, kCpus = 2;
  static void SetUpTestSuite() {
    cluster_ = mlcg::test::temp_path("slurm_cluster");
    g_cluster = cluster_.string();
    fs::remove_all(cluster_);
    if (geteuid() != 0) {
      skip_ = "needs root to start slurmd and make network namespaces";
      return;
    }
    for (const int sig : {SIGINT, SIGTERM, SIGHUP}) signal(sig, stop_and_exit);
    const std::string log = cluster_.string() + ".start.out";
    const int rc = run(kSlurm + "/start_cluster.sh " + cluster_.string() + " " + std::to_string(kNodes) + " " +
                       std::to_string(kCpus) + " > " + log + " 2>&1");
    if (rc == 77) skip_ = "cannot start the Slurm daemons: " + slurp(cluster_ / "skip_reason");
    else if (rc != 0) failed_ = "start_cluster.sh failed (" + std::to_string(rc) + "): " + slurp(log);
    fs::remove(log);
    setenv("SLURM_CONF", (cluster_ / "slurm.conf").c_str(), 1);
    // The jobs inherit this environment (sbatch --export=ALL) and mpirun hands OMPI_MCA_ variables to every
    // rank. All the nodes share this machine's 2 cores: a rank busy-polling for its neighbour on another node
    // would hold the core that neighbour needs (a 3-rank level over two nodes ran 100 times slower).
    setenv("OMPI_MCA_mpi_yield_when_idle", "1", 1);
  }
  static void TearDownTestSuite() {
    if (geteuid() == 0) run(kSlurm + "/stop_cluster.sh " + cluster_.string());
    if (!HasFailure()) fs::remove_all(cluster_);  // else kept: its daemons' logs
  }
  void SetUp() override {
    if (!skip_.empty()) GTEST_SKIP() << skip_;
    ASSERT_TRUE(failed_.empty()) << failed_;
  }
  static bool HasFailure() { return ::testing::UnitTest::GetInstance()->failed_test_count() > 0; }

  // `mlcg submit CASE --out RUN --quiet EXTRA`: the job id (0 when refused; its output in RUN.submit).
  static int submit(const std::string& kase, const fs::path& out, const std::string& extra = "") {
    const std::string log = out.string() + ".submit";
    EXPECT_EQ(run(kBin + "/mlcg submit " + kase + " --out " + out.string() + " --quiet " + extra + " > " + log +
                  " 2>&1"),
              0)
        << slurp(log);
    std::smatch m;
    const std::string text = slurp(log);
    if (!std::regex_search(text, m, std::regex("submitted Slurm job ([0-9]+)"))) return 0;
    return std::stoi(m[1]);
  }
  // The job's final state (COMPLETED, FAILED, ...) once it has ended; "" when it did not within `seconds`.
  static std::string wait_job(int job, double seconds) {
    const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
    const fs::path f = cluster_ / ("job" + std::to_string(job));
    while (std::chrono::steady_clock::now() < until) {
      run("scontrol show job -o " + std::to_string(job) + " > " + f.string() + " 2>&1");
      std::smatch m;
      const std::string text = slurp(f);
      if (std::regex_search(text, m, std::regex("JobState=([A-Z_]+)"))) {
        const std::string st = m[1];
        if (st != "PENDING" && st != "RUNNING" && st != "CONFIGURING" && st != "COMPLETING") return st;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(500));
    }
    return "";
  }

  static fs::path cluster_;
  static std::string skip_, failed_;
};
fs::path Slurm::cluster_;
std::string Slurm::skip_, Slurm::failed_;

}  // namespace

// The quickstart hierarchy through sbatch: 3 tasks (2 level ranks + the coupler) on nodes of 2 CPUs, so the
// coupler and the coarse level run on mlcs-h1 (the batch node) and the fine level on mlcs-h2.
TEST_F(Slurm, SubmittedHierarchyRunsOnTheAllocationsNodesWithTheLocalRunsNumbers) {
  const fs::path dir = fresh_temp_path("slurm_run");
  const std::string kase = kSrc + "/cases/quickstart/mlcg.toml";
  const int job = submit(kase, dir);
  ASSERT_GT(job, 0) << slurp(dir.string() + ".submit");
  const std::string script = slurp(dir / "mlcg_submit.sh");
  EXPECT_NE(script.find("#SBATCH --ntasks=3\n"), std::string::npos) << script;
  EXPECT_NE(script.find("run '" + kase + "' --out '" + dir.string() + "' --quiet"), std::string::npos) << script;
  const std::string state = wait_job(job, 600);
  const std::string out = slurp(dir / ("slurm-" + std::to_string(job) + ".out"));
  ASSERT_EQ(state, "COMPLETED") << out;
  EXPECT_NE(out.find("mlcg: inside Slurm job " + std::to_string(job) + ": hosts mlcs-h1 (slots=2), mlcs-h2 (slots=1)"),
            std::string::npos)
      << out;
  EXPECT_NE(out.find("coupler on host mlcs-h1"), std::string::npos) << out;
  EXPECT_NE(out.find("level 'coarse' on host mlcs-h1"), std::string::npos) << out;
  EXPECT_NE(out.find("level 'fine' on host mlcs-h2"), std::string::npos) << out;
  const auto s = run_checks::read_json(dir / "summary.json");
  EXPECT_EQ(s["status"], "completed") << out;
  run_checks::check_region(dir, s, 0, "fine");
  // The fine level really ran on mlcs-h2: the coupler (on mlcs-h1, 10.78.0.1) saw its key from that address.
  const std::string log = slurp(dir / "coupler.log");
  EXPECT_NE(log.find("accepted the CURVE key of 'fine' from 10.78.0.2"), std::string::npos) << log;
  EXPECT_NE(log.find("accepted the CURVE key of 'coarse' from 10.78.0.1"), std::string::npos) << log;

  const fs::path local = launch_support::run_hierarchy_case("cases/quickstart/mlcg.toml", "slurm_local");
  launch_support::expect_same_result(dir, local);
  // A second submit into the same folder is refused before sbatch: the folder holds a run now.
  const std::string again = dir.string() + ".again";
  EXPECT_EQ(run(kBin + "/mlcg submit " + kase + " --out " + dir.string() + " > " + again + " 2>&1"), 2);
  EXPECT_NE(slurp(again).find("already holds a run"), std::string::npos) << slurp(again);
  fs::remove(again);
  if (!HasFailure())
    for (const auto& d : {dir, local}) {
      launch_support::remove_run(d);
      fs::remove(d.string() + ".submit");
    }
}

// A level across nodes under Slurm: a 3-rank fine level in an allocation of 5 tasks over 3 nodes of 2 CPUs
// (mlcs-h1: the coupler and the coarse level; the fine level's ranks on mlcs-h2 (2) and mlcs-h3 (1)), one
// mpirun --host mlcs-h2:2,mlcs-h3:1. Same per-face totals as the 3-rank fine level on this machine.
TEST_F(Slurm, ALevelSpansTwoNodesOfTheAllocation) {
  const fs::path cfile = launch_support::short_quickstart(30.0, 3, "slurm_span");
  const fs::path dir = fresh_temp_path("slurm_span_run");
  const int job = submit(cfile.string(), dir);
  ASSERT_GT(job, 0) << slurp(dir.string() + ".submit");
  EXPECT_NE(slurp(dir / "mlcg_submit.sh").find("#SBATCH --ntasks=5\n"), std::string::npos);
  const std::string state = wait_job(job, 800);
  const std::string out = slurp(dir / ("slurm-" + std::to_string(job) + ".out"));
  ASSERT_EQ(state, "COMPLETED") << out;
  EXPECT_NE(out.find("hosts mlcs-h1 (slots=2), mlcs-h2 (slots=2), mlcs-h3 (slots=1)"), std::string::npos) << out;
  EXPECT_NE(out.find("level 'fine' on hosts mlcs-h2 (2 rank(s)), mlcs-h3 (1 rank(s))"), std::string::npos) << out;
  const auto s = run_checks::read_json(dir / "summary.json");
  EXPECT_EQ(s["status"], "completed") << out;
  EXPECT_EQ(s["levels"][1]["ranks"], 3);
  const std::string log = slurp(dir / "coupler.log");
  EXPECT_NE(log.find("accepted the CURVE key of 'fine' from 10.78.0.2"), std::string::npos) << log;
  const fs::path local = launch_support::run_hierarchy_case(cfile.string(), "slurm_span_local");
  launch_support::expect_same_result(dir, local);
  if (!HasFailure()) {
    for (const auto& d : {dir, local}) {
      launch_support::remove_run(d);
      fs::remove(d.string() + ".submit");
    }
    mlcg::test::remove_case_copy(cfile);
  }
}
