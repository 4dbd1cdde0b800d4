// `mlcg run CASE`: a single-level case starts one dem_level (through mpirun
// when it has several ranks) and no coupler; a hierarchy goes to run_hierarchy.
#include "run/run_case.hpp"

#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <stdexcept>

#include <sys/resource.h>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "config/case_parser.hpp"
#include "config/region_rules.hpp"
#include "run/checkpoints.hpp"
#include "run/hierarchy.hpp"
#include "hosts/hosts.hpp"
#include "io/atomic_file.hpp"
#include "process/process.hpp"
#include "run/run_folder.hpp"
#include "scene/outlets.hpp"
#include "scene/vessel.hpp"
#include "stability/stability_preview.hpp"

namespace fs = std::filesystem;

namespace mlcg::launcher {

std::string default_run_dir(const std::string& case_file) {
  const std::time_t now = std::time(nullptr);
  char stamp[32];
  std::strftime(stamp, sizeof stamp, "%Y%m%d-%H%M%S", std::localtime(&now));
  const fs::path p(case_file);
  return (fs::path("runs") / fmt::format("{}-{}-{}", p.parent_path().filename().string(), p.stem().string(), stamp))
      .string();
}

namespace {

// `code`: the level's exit code. A level that failed on a full disk may have left the summary it wrote last.
void print_summary(const fs::path& run_dir, int code) {
  std::ifstream in(run_dir / "summary.json");
  if (!in) {
    std::printf("no summary.json in %s\n", run_dir.c_str());
    return;
  }
  const auto j = nlohmann::json::parse(in);
  std::string status = j.value("status", "?");
  if (code != 0 && status == "running") status = "failed (summary.json could not be updated since, it says running)";
  std::printf("\n== %s: %s ==\n", run_dir.c_str(), status.c_str());
  if (!j.value("reason", "").empty()) std::printf("reason: %s\n", j["reason"].get<std::string>().c_str());
  std::printf("simulated %.4f s in %.1f s wall\n", j.value("simulated_time", 0.0), j.value("wall_seconds", 0.0));
  for (const auto& l : j["levels"])
    std::printf("level %s: alpha %g, dt %.3g s, %d rank(s), up to %d particles, %.3g particle-steps/s\n",
                l.value("name", "?").c_str(), l.value("alpha", 0.0), l.value("dt", 0.0), l.value("ranks", 1),
                l.value("particles_max", 0), l.value("particle_steps_per_second", 0.0));
  for (const auto& p : j["probes"])
    std::printf("probe %s: %s (%d samples in window)\n", p.value("name", "?").c_str(), probe_flow_text(p).c_str(),
                p.value("samples_in_window", 0));
  const auto& b = j["mass_balance"];
  std::printf("particles: %lld inserted = %lld present + %lld removed; %lld failed to place\n",
              b.value("inserted", 0LL), b.value("present", 0LL), b.value("removed", 0LL),
              b.value("failed_to_place", 0LL));
  std::printf("files: %s/{summary.json, series.csv, probes/, particles.xmf, grids/, log.txt, checkpoint.h5}\n",
              run_dir.c_str());
}

// User + system CPU seconds of every descendant this process has waited for (mpirun waits
// for its ranks, so they count too).
double children_cpu_seconds() {
  rusage ru{};
  getrusage(RUSAGE_CHILDREN, &ru);
  auto sec = [](const timeval& t) { return static_cast<double>(t.tv_sec) + 1e-6 * static_cast<double>(t.tv_usec); };
  return sec(ru.ru_utime) + sec(ru.ru_stime);
}

// Adds the measured CPU time of the run's processes to its summary.json: the cost of a run
// whose levels wait for each other is the CPU they used, not wall time x cores.
void record_cpu_seconds(const fs::path& run_dir, double cpu) {
  auto j = read_json_or_null(run_dir / "summary.json");
  if (!j.is_object()) return;
  j["cpu_seconds"] = cpu;
  try {
    io::write_file_atomic(run_dir / "summary.json", j.dump(2) + "\n");
  } catch (const std::exception& e) {  // a full disk: the level's summary stays as it was
    std::fprintf(stderr, "mlcg: cannot add the CPU time to the summary: %s\n", e.what());
  }
}

int run_launched(const config::CaseSpec& cs, const std::string& case_file, const std::string& out_dir, bool quiet,
                 const launcher::Placement& placement);

}  // namespace

config::RegionRuleReport check_regions(const config::CaseSpec& cs, const config::OutletScan& outlets) {
  auto report = config::check_region_rules(cs, outlets, cs.coupling ? vessel_crossing(cs) : config::WallCrossing{});
  if (cs.coupling)
    for (const auto& o : outlets.outlets) std::printf("mlcg: %s\n", config::outlet_text(o).c_str());
  for (const auto& n : report.notes) std::printf("mlcg: %s\n", n.c_str());
  std::fflush(stdout);
  for (const auto& w : report.warnings) std::fprintf(stderr, "warning: %s\n", w.c_str());
  if (report.errors.empty()) return report;
  std::string all;
  for (const auto& e : report.errors) all += (all.empty() ? "" : "\nerror: ") + e;
  throw std::runtime_error(all);
}

config::RegionRuleReport check_regions(const config::CaseSpec& cs) { return check_regions(cs, find_outlets(cs)); }

PreparedCase prepare_case(const std::string& case_file, const std::string& hosts, bool curve) {
  PreparedCase p;
  p.cs = config::load_case(case_file);
  p.outlets = find_outlets(p.cs);
  p.regions = check_regions(p.cs, p.outlets);
  if (!hosts.empty() && p.cs.levels.size() < 2)
    throw std::runtime_error("--hosts places the coupler and the levels of a multi-level case; " + case_file +
                             " has one level (start it with mpirun --hostfile)");
  if (!hosts.empty()) {
    p.placement = launcher::Placement(launcher::read_hostfile(hosts), p.cs);
  } else if (p.cs.levels.size() > 1) {
    // Inside a Slurm allocation: the allocation's nodes and tasks are the hosts (the same placement as a
    // hostfile's); Open MPI's mpirun starts the remote processes through Slurm (srun).
    if (const auto hf = launcher::slurm_hosts()) {
      std::string list;
      for (const auto& h : hf->hosts) list += fmt::format("{}{} (slots={})", list.empty() ? "" : ", ", h.name, h.slots);
      std::printf("mlcg: inside %s: hosts %s\n", hf->path.c_str(), list.c_str());
      p.placement = launcher::Placement(*hf, p.cs);
    }
  }
  if (curve) p.placement.enable_curve();
  p.placement.check(p.cs);
  // Each level of a hierarchy would refuse its time step on its own, and which one spoke before the
  // launcher stopped the others was a race: refuse here, naming every level, before anything starts.
  if (p.cs.levels.size() > 1) {
    std::string refused;
    for (const auto& l : p.cs.levels) try {
        preview_level(p.cs, l);
      } catch (const StabilityError& e) {
        refused += (refused.empty() ? "" : "\nerror: ") + std::string(e.what());
      }
    if (!refused.empty()) throw std::runtime_error(refused);
  }
  return p;
}

int run_case(const std::string& case_file, std::string out_dir, bool quiet, const std::string& hosts, bool curve) {
  config::CaseSpec cs;
  launcher::Placement placement;
  std::unique_ptr<RunLock> lock;  // held until the run ends
  try {
    auto prepared = prepare_case(case_file, hosts, curve);  // the checks `mlcg check` makes too
    cs = std::move(prepared.cs);
    placement = std::move(prepared.placement);
    if (out_dir.empty()) out_dir = default_run_dir(case_file);
    lock = claim_new_run_folder(out_dir);  // before anything is written there
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 2;
  }
  const double cpu0 = children_cpu_seconds();
  const int rc = run_launched(cs, case_file, out_dir, quiet, placement);
  const double cpu = children_cpu_seconds() - cpu0;
  record_cpu_seconds(out_dir, cpu);
  std::printf("CPU time of all processes: %.1f s\n", cpu);
  return rc;
}

namespace {

int run_launched(const config::CaseSpec& cs, const std::string& case_file, const std::string& out_dir, bool quiet,
                 const launcher::Placement& placement) {
  if (cs.levels.size() > 1) {
    try {
      return launcher::run_hierarchy(cs, case_file, out_dir, quiet, placement);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "mlcg: error: %s\n", e.what());
      return 1;
    }
  }
  const auto& lvl = cs.levels.front();
  std::vector<std::string> argv;
  if (lvl.ranks > 1) argv = launcher::mpirun_prefix(lvl.ranks);
  argv.push_back((fs::path(launcher::own_directory()) / "dem_level").string());
  argv.insert(argv.end(), {case_file, "--out", out_dir});
  if (quiet) argv.push_back("--quiet");
  std::printf("mlcg: case %s, level '%s' (alpha %g, %d rank(s)), no coupler needed; run folder %s\n",
              case_file.c_str(), lvl.name.c_str(), lvl.alpha, lvl.ranks, out_dir.c_str());
  std::fflush(stdout);
  const pid_t child = launcher::spawn(argv);
  const auto r = launcher::wait_group({{"dem_level", child}});
  print_summary(out_dir, r.exit_code);
  if (r.exit_code != 0) std::fprintf(stderr, "mlcg: dem_level exited with code %d\n", r.exit_code);
  return r.exit_code;
}

}  // namespace


}  // namespace mlcg::launcher
