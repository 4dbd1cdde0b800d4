// mlcg: the user's entry point. `mlcg run CASE` reads the case, starts exactly
// the processes it needs (a single-level case: one dem_level, no coupler; a
// hierarchy: the coupler and every level),
// forwards Ctrl-C to them and prints the run's summary.
#include <chrono>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "config/case_parser.hpp"
#include "hierarchy.hpp"
#include "process.hpp"
#include "control.hpp"
#include "status.hpp"

namespace fs = std::filesystem;
using namespace mlcg;

namespace {

std::string default_run_dir(const std::string& case_file) {
  const std::time_t now = std::time(nullptr);
  char stamp[32];
  std::strftime(stamp, sizeof stamp, "%Y%m%d-%H%M%S", std::localtime(&now));
  const fs::path p(case_file);
  return (fs::path("runs") / fmt::format("{}-{}-{}", p.parent_path().filename().string(), p.stem().string(), stamp))
      .string();
}

void print_summary(const fs::path& run_dir) {
  std::ifstream in(run_dir / "summary.json");
  if (!in) {
    std::printf("no summary.json in %s\n", run_dir.c_str());
    return;
  }
  const auto j = nlohmann::json::parse(in);
  std::printf("\n== %s: %s ==\n", run_dir.c_str(), j.value("status", "?").c_str());
  if (!j.value("reason", "").empty()) std::printf("reason: %s\n", j["reason"].get<std::string>().c_str());
  std::printf("simulated %.4f s in %.1f s wall\n", j.value("simulated_time", 0.0), j.value("wall_seconds", 0.0));
  for (const auto& l : j["levels"])
    std::printf("level %s: alpha %g, dt %.3g s, %d rank(s), up to %d particles, %.3g particle-steps/s\n",
                l.value("name", "?").c_str(), l.value("alpha", 0.0), l.value("dt", 0.0), l.value("ranks", 1),
                l.value("particles_max", 0), l.value("particle_steps_per_second", 0.0));
  for (const auto& p : j["probes"])
    std::printf("probe %s: mass flow %.4f +- %.4f kg/s (%d samples in window)\n", p.value("name", "?").c_str(),
                p.value("mean_kg_per_s", 0.0), p.value("std_kg_per_s", 0.0), p.value("samples_in_window", 0));
  const auto& b = j["mass_balance"];
  std::printf("particles: %lld inserted = %lld present + %lld removed; %lld failed to place\n",
              b.value("inserted", 0LL), b.value("present", 0LL), b.value("removed", 0LL),
              b.value("failed_to_place", 0LL));
  std::printf("files: %s/{summary.json, series.csv, probes/, particles.xmf, grids/, log.txt, checkpoint.h5}\n",
              run_dir.c_str());
}

int run_case(const std::string& case_file, std::string out_dir, bool quiet) {
  config::CaseSpec cs;
  try {
    cs = config::load_case(case_file);
  } catch (const config::CaseError& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 2;
  }
  if (out_dir.empty()) out_dir = default_run_dir(case_file);
  fs::create_directories(out_dir);
  if (cs.levels.size() > 1) return launcher::run_hierarchy(cs, case_file, out_dir, quiet);
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
  print_summary(out_dir);
  if (r.exit_code != 0) std::fprintf(stderr, "mlcg: dem_level exited with code %d\n", r.exit_code);
  return r.exit_code;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"mlcg: multi-level coarse-grain DEM"};
  app.require_subcommand(1);
  auto* run = app.add_subcommand("run", "run a case");
  std::string case_file, out_dir;
  bool quiet = false;
  run->add_option("case", case_file, "case file (TOML)")->required()->check(CLI::ExistingFile);
  run->add_option("--out", out_dir, "run folder (default runs/<case>-<date>)");
  run->add_flag("--quiet", quiet, "no progress lines");
  auto* resume = app.add_subcommand("resume", "continue an interrupted or failed multi-level run from its last "
                                              "consistent checkpoint");
  std::string run_dir;
  resume->add_option("run_dir", run_dir, "run folder")->required()->check(CLI::ExistingDirectory);
  resume->add_flag("--quiet", quiet, "no progress line");
  auto* ps = app.add_subcommand("ps", "processes and progress of a multi-level run");
  ps->add_option("run_dir", run_dir, "run folder")->required()->check(CLI::ExistingDirectory);
  auto* status = app.add_subcommand("status", "the multi-level runs under ./runs and their state");
  std::string runs_dir = "runs";
  status->add_option("--runs", runs_dir, "folder holding the run folders (default ./runs)");
  auto* swap = app.add_subcommand("swap", "replace a level's binary in a running multi-level run (at its next "
                                          "consistent checkpoint)");
  std::string swap_level, swap_binary;
  swap->add_option("run_dir", run_dir, "run folder")->required()->check(CLI::ExistingDirectory);
  swap->add_option("--level", swap_level, "the level to swap")->required();
  swap->add_option("--binary", swap_binary, "the new solver binary (same protocol)")->required();
  CLI11_PARSE(app, argc, argv);
  if (swap->parsed()) return launcher::swap_command(run_dir, swap_level, swap_binary);
  if (run->parsed()) return run_case(case_file, out_dir, quiet);
  if (resume->parsed()) return launcher::resume_hierarchy(run_dir, quiet);
  if (ps->parsed()) return launcher::print_ps(run_dir);
  if (status->parsed()) return launcher::print_status_all(runs_dir);
  return 0;
}
