// dem_level: runs one coarse-grain level of a case. Normally started by
// `mlcg run`; can be run by hand for a single-level case. In a multi-level
// case, --level names the level and --coupler the coupler's endpoint.
#include <mpi.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <exception>

#include <CLI/CLI.hpp>

#include "bus/curve.hpp"
#include "config/case_parser.hpp"
#include "core/heap.hpp"
#include "core/huge_pages.hpp"
#include "level/level.hpp"

int main(int argc, char** argv) {
  mlcg::keep_freed_memory();
  mlcg::enable_huge_pages();
  CLI::App app{"dem_level: one DEM level of an MLCG case"};
  std::string case_file, out_dir, restart, level_name, coupler;
  int64_t max_steps = -1;
  bool quiet = false;
  app.add_option("case", case_file, "case file (TOML)")->required();
  app.add_option("--out", out_dir, "run folder")->required();
  app.add_option("--restart", restart, "continue from this checkpoint");
  app.add_option("--max-steps", max_steps, "stop after this many steps (writes a checkpoint)");
  app.add_flag("--quiet", quiet, "no progress lines on the console");
  app.add_option("--level", level_name, "the [[levels]] entry to run (name; default: the first)");
  app.add_option("--coupler", coupler, "coupler endpoint (tcp://HOST:PORT or ipc://PATH): run coupled");
  std::string curve_server, curve_client;  // CURVE on the bus (bus/curve.hpp)
  app.add_option("--curve-server-public", curve_server, "CURVE: the coupler's public key file (with --curve-client-key)");
  app.add_option("--curve-client-key", curve_client, "CURVE: this level's keypair file, issued by mlcg");
  CLI11_PARSE(app, argc, argv);

  // No X display probing at MPI start (hwloc's OpenGL component; see launcher/main.cpp): for a dem_level
  // started by hand or by a test, and its Open MPI singleton daemon. A user's own HWLOC_COMPONENTS is kept.
  setenv("HWLOC_COMPONENTS", "-gl", 0);
  MPI_Init(&argc, &argv);
  int ranks = 1;
  MPI_Comm_size(MPI_COMM_WORLD, &ranks);
  int code = 0;
  try {
    const auto cs = mlcg::config::load_case(case_file);
    auto lvl = cs.levels.begin();
    if (!level_name.empty())
      lvl = std::find_if(cs.levels.begin(), cs.levels.end(), [&](const auto& l) { return l.name == level_name; });
    if (lvl == cs.levels.end())
      throw std::runtime_error("--level " + level_name + ": the case has no [[levels]] entry of that name");
    if (cs.levels.size() > 1 && (level_name.empty() || coupler.empty()))
      throw std::runtime_error("the case has " + std::to_string(cs.levels.size()) +
                               " levels; a level of a multi-level case runs coupled: give --level NAME and "
                               "--coupler ENDPOINT (`mlcg run` does)");
    if (ranks != lvl->ranks)
      throw std::runtime_error("dem_level was started on " + std::to_string(ranks) + " MPI ranks but level '" +
                               lvl->name + "' of the case asks for " + std::to_string(lvl->ranks));
    if (auto keys = mlcg::bus::curve::client_from_files(curve_server, curve_client))
      mlcg::bus::curve::set_process_keys(*keys);
    mlcg::install_signal_handlers();
    mlcg::LevelOptions opt;
    opt.out_dir = out_dir;
    opt.restart = restart;
    opt.max_steps = max_steps;
    opt.quiet = quiet;
    opt.level = level_name;
    opt.coupler = coupler;
    mlcg::Level level(cs, opt);
    switch (level.run()) {
      case mlcg::RunStatus::Completed:
      case mlcg::RunStatus::StepLimit: code = 0; break;
      case mlcg::RunStatus::Interrupted: code = 130; break;
      case mlcg::RunStatus::Failed: code = 3; break;
    }
  } catch (const mlcg::config::CaseError& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    code = 2;
  } catch (const mlcg::StabilityError& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    code = 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    code = 1;
  }
  MPI_Finalize();
  return code;
}
