// mlcg_bench: single-level speed of dem_level on a settled dense silo bed and a discharging silo
// (paper material, dt = 1e-6 s, STL walls), and of LIGGGHTS on the identical scene when it is
// installed; the pour, our own speed while the empty silo fills (pour.hpp: rebuilds and insertion
// cost more there); then a size sweep of our own speed on box beds of about 30 k, 300 k and 1 M
// particles (sweep.hpp). Prints a table per scene and rank count, the pour's and the sweep's tables;
// the last lines are machine-readable:
//   pour rank1=<p> rank2=<q> rebuild_share1=<s> rebuild_share2=<t>
//   ratio_vs_liggghts rank1=<x> rank2=<y>     (or: liggghts=absent)
//   scaling rank1=<a> rank2=<b>
// p, q = our particle-steps/s per core in the pour, s, t = its share of the loop time in neighbour
// rebuilds (one pair per --ranks entry); x, y = our particle-steps/s per core / LIGGGHTS's, medians, bed
// scene; a, b = our per-core rate on the largest sweep bed / on the smallest; "na" when not measured
// (also with --skip-liggghts). A line is left out when its scene was not run (--scene).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <sstream>
#include <thread>

#include <unistd.h>

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "bed.hpp"
#include "core/huge_pages.hpp"
#include "geometry.hpp"
#include "parse.hpp"
#include "pour.hpp"
#include "process.hpp"
#include "scenes.hpp"
#include "silo.hpp"
#include "snapshot.hpp"
#include "sweep.hpp"

namespace fs = std::filesystem;
using namespace mlcg::bench;

namespace {

struct Options {
  long steps = 5000;
  int repeat = 3;
  std::string work;
  std::string ranks = "1,2";
  bool skip_liggghts = false;
  std::string scene = "all";
  std::string sizes = "30000,300000,1000000";
  std::string dem_level;
  std::string liggghts = "liggghts";
  std::string mpirun = "mpirun";
  int particles = 29451;
  int segments = 96;
  bool rebuild_bed = false;
};

// One /proc/cpuinfo field of the first processor ("?" when absent).
std::string cpuinfo_field(const std::string& key) {
  std::ifstream cpu("/proc/cpuinfo");
  for (std::string l; std::getline(cpu, l);)
    if (l.rfind(key, 0) == 0 && l.find(':') != std::string::npos && l.substr(0, l.find(':')).find_last_not_of(" \t") + 1 == key.size())
      return l.substr(l.find(':') + 2);
  return "?";
}

std::string cache_kib(int name) {
  const long b = sysconf(name);
  return b > 0 ? fmt::format("{} KiB", b / 1024) : "?";
}

// The SIMD extensions this binary was built for (the project's targets share the flags, -march=native).
std::string simd_built() {
  std::string s;
  auto add = [&](bool on, const char* what) { s += on ? (s.empty() ? "" : ", ") + std::string(what) : ""; };
#ifdef __AVX512F__
  add(true, "AVX-512F");
#endif
#ifdef __AVX512VL__
  add(true, "AVX-512VL");
#endif
#ifdef __AVX2__
  add(true, "AVX2");
#endif
#ifdef __FMA__
  add(true, "FMA");
#endif
  return s.empty() ? "SSE2 only" : s;
}

// The host's signature beside every figure: the same model name covers CPUs of different speed (issue 37:
// two "Intel(R) Xeon(R) Processor" hosts 17 % apart), so family, model, stepping, caches and the build.
std::string machine_line() {
  const std::string thp = mlcg::transparent_huge_pages_setting();
  return fmt::format("{} ({} family {} model {} stepping {}), {} cores; L1d {}, L2 {}, L3 {}; transparent huge pages: {}; "
                     "built for {} by GCC {}",
                     cpuinfo_field("model name"), cpuinfo_field("vendor_id"), cpuinfo_field("cpu family"),
                     cpuinfo_field("model"), cpuinfo_field("stepping"), std::thread::hardware_concurrency(),
                     cache_kib(_SC_LEVEL1_DCACHE_SIZE), cache_kib(_SC_LEVEL2_CACHE_SIZE), cache_kib(_SC_LEVEL3_CACHE_SIZE),
                     thp.empty() ? "none" : thp, simd_built(), __VERSION__);
}

void add_options(CLI::App& app, Options& o) {
  app.add_option("--steps", o.steps, "time steps per measured run of the silo scenes and the sweep (the pour has its "
                                     "own duration)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--repeat", o.repeat, "runs per configuration (medians are reported)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--work", o.work, "work folder: geometry, cached bed, runs (default: <build>/bench)");
  app.add_option("--ranks", o.ranks, "comma-separated rank counts")->capture_default_str();
  app.add_flag("--skip-liggghts", o.skip_liggghts, "do not run LIGGGHTS");
  app.add_option("--scene", o.scene,
                 "bed, discharge, both (bed and discharge), pour (the empty silo filling, ours only), sweep (the "
                 "size sweep) or all")
      ->check(CLI::IsMember({"bed", "discharge", "both", "pour", "sweep", "all"}))
      ->capture_default_str();
  app.add_option("--dem-level", o.dem_level, "dem_level executable (default: next to mlcg_bench)");
  app.add_option("--liggghts", o.liggghts, "LIGGGHTS executable")->capture_default_str();
  app.add_option("--mpirun", o.mpirun, "mpirun executable")->capture_default_str();
  app.add_option("--particles", o.particles, "particles in the bed (changing it prepares a new bed)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--segments", o.segments, "polygon sides of the STL silo (changing it prepares a new bed)")
      ->check(CLI::Range(8, 4096))
      ->capture_default_str();
  app.add_option("--sizes", o.sizes, "particle counts of the size sweep (comma-separated)")->capture_default_str();
  app.add_flag("--rebuild-bed", o.rebuild_bed, "prepare the settled bed again even if a cached one fits");
}

// A comma-separated list of positive numbers, each once, in the order given.
std::vector<long> positive_list(const std::string& text, const char* option) {
  std::vector<long> out;
  std::stringstream ss(text);
  for (std::string t; std::getline(ss, t, ',');) {
    long v = 0;
    try {
      v = std::stol(t);
    } catch (const std::exception&) {
      throw std::runtime_error(fmt::format("{}: '{}' is not a number", option, t));
    }
    if (v < 1) throw std::runtime_error(fmt::format("{}: every value must be >= 1, not {}", option, v));
    if (std::find(out.begin(), out.end(), v) == out.end()) out.push_back(v);
  }
  if (out.empty()) throw std::runtime_error(fmt::format("{}: give at least one value", option));
  return out;
}

void say_setup(const Options& o, const BenchParams& p, const fs::path& dem_level, const fs::path& work,
               const std::optional<fs::path>& mpirun, const std::optional<fs::path>& liggghts,
               bool liggghts_installed) {
  say(fmt::format("mlcg_bench: {} particles of r = {} mm, paper material (E = {:g} Pa, nu = {}, rho = {} kg/m3, "
                  "e = {}, mu particle-particle = {}, particle-wall = {}), dt = {:g} s, skin = {} mm, {} steps, "
                  "{} repeat(s)",
                  p.particles, p.radius * 1e3, p.material.youngs_modulus, p.material.poisson_ratio,
                  p.material.density, p.material.restitution, p.material.friction_pp, p.material.friction_pw, p.dt,
                  p.skin * 1e3, p.steps, o.repeat));
  say(fmt::format("machine: {}; load average at start: {} (other processes share these cores; the numbers "
                  "include their interference)",
                  machine_line(), load_average()));
  say(fmt::format("dem_level: {}; LIGGGHTS: {}; mpirun: {}; work folder: {}", dem_level.string(),
                  liggghts ? liggghts->string() : (liggghts_installed ? "skipped (--skip-liggghts)" : "not installed"),
                  mpirun ? mpirun->string() : "not found", work.string()));
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  CLI::App app{"mlcg_bench: dem_level speed on a settled silo bed and a discharging silo (paper material, dt = 1e-6 s), "
               "and LIGGGHTS on the identical scene when installed; the pour (the empty silo filling, ours only); the "
               "size sweep. Last lines: pour rank1=<p> rank2=<q> rebuild_share1=<s> rebuild_share2=<t>, "
               "ratio_vs_liggghts rank1=<x> rank2=<y> (or liggghts=absent), scaling rank1=<a> rank2=<b>; each only "
               "when its scene ran."};
  add_options(app, o);
  CLI11_PARSE(app, argc, argv);

  try {
    BenchParams p;
    p.steps = o.steps;
    p.particles = o.particles;
    p.geometry.segments = o.segments;
    std::vector<int> ranks;
    for (long r : positive_list(o.ranks, "--ranks")) ranks.push_back(static_cast<int>(r));
    std::vector<Scene> scenes;
    if (o.scene == "bed" || o.scene == "both" || o.scene == "all") scenes.push_back(Scene::Bed);
    if (o.scene == "discharge" || o.scene == "both" || o.scene == "all") scenes.push_back(Scene::Discharge);
    const bool pour = o.scene == "pour" || o.scene == "all";
    const bool sweep = o.scene == "sweep" || o.scene == "all";

    const fs::path self = own_directory();
    const fs::path dem_level = o.dem_level.empty() ? self / "dem_level" : fs::absolute(o.dem_level);
    if (!fs::exists(dem_level)) throw std::runtime_error("dem_level not found at " + dem_level.string() + " (--dem-level)");
    const fs::path work = fs::absolute(o.work.empty() ? self.parent_path() / "bench" : fs::path(o.work));
    const auto mpirun = find_in_path(o.mpirun);
    const auto liggghts = o.skip_liggghts ? std::nullopt : find_in_path(o.liggghts);
    const bool liggghts_installed = find_in_path(o.liggghts).has_value();
    fs::create_directories(work / "geometry");
    fs::create_directories(work / "bed");
    fs::create_directories(work / "runs");
    say_setup(o, p, dem_level, work, mpirun, liggghts, liggghts_installed);

    std::optional<Files> files;
    if (!scenes.empty() || pour) files = write_silo_files(p, work);
    std::string ratio_line, pour_summary, scaling;
    if (!scenes.empty())
      ratio_line = run_silo_scenes(
          p, *files, SiloOptions{scenes, ranks, o.repeat, o.rebuild_bed, dem_level, work, mpirun, liggghts,
                                 liggghts_installed});
    if (pour) {
      PourOptions po{ranks, o.repeat, *files, work, dem_level, mpirun.value_or(fs::path())};
      pour_summary = pour_line(run_pour(p, po), ranks);
    }
    if (sweep) {
      SweepOptions so;
      so.sizes = positive_list(o.sizes, "--sizes");
      so.ranks = ranks;
      so.steps = o.steps;
      so.repeat = o.repeat;
      so.rebuild = o.rebuild_bed;
      so.work = work;
      so.dem_level = dem_level;
      if (mpirun) so.mpirun = *mpirun;
      scaling = "scaling " + scaling_line(run_sweep(p, so), ranks);
    }
    // The pour's line before the two that scripts read as the last ones.
    say("");
    for (const auto& line : {pour_summary, ratio_line, scaling})
      if (!line.empty()) say(line);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "mlcg_bench: error: %s\n", e.what());
    return 1;
  }
  return 0;
}
