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

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "bed.hpp"
#include "geometry.hpp"
#include "parse.hpp"
#include "pour.hpp"
#include "process.hpp"
#include "scenes.hpp"
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

enum class Code { Mlcg, Liggghts };
const char* code_name(Code c) { return c == Code::Mlcg ? "MLCG" : "LIGGGHTS"; }

std::string machine_line() {
  std::string model = "?";
  std::ifstream cpu("/proc/cpuinfo");
  for (std::string l; std::getline(cpu, l);)
    if (l.rfind("model name", 0) == 0) {
      model = l.substr(l.find(':') + 2);
      break;
    }
  return fmt::format("{}, {} cores", model, std::thread::hardware_concurrency());
}

std::string load_average() {
  std::ifstream in("/proc/loadavg");
  std::string a, b, c;
  in >> a >> b >> c;
  return a + " " + b + " " + c;
}

// ---- the settled silo bed ----------------------------------------------------------------------

nlohmann::json bed_fingerprint(const BenchParams& p) {
  const auto& g = p.geometry;
  const auto& m = p.material;
  return {{"particles", p.particles},
          {"radius", p.radius},
          {"material", {m.youngs_modulus, m.poisson_ratio, m.density, m.restitution, m.friction_pp, m.friction_pw}},
          {"geometry", {g.orifice_radius, g.radius, g.cone_height, g.top, g.lid_radius, g.segments, g.max_aspect}},
          {"box", {g.box_min, g.box_max}},
          {"prepare", {p.prepare_dt, p.skin, p.settle_speed, p.settle_extra, p.settle_latest, p.seed}},
          {"version", 1}};
}

BedRecipe silo_bed_recipe(const BenchParams& p, const Files& files) {
  BedRecipe r;
  r.what = fmt::format("{} particles of r = {} m in the silo (pouring close above the heap, dt = {} s, until the mean "
                       "speed < {} m/s, + {} s)",
                       p.particles, p.radius, p.prepare_dt, p.settle_speed, p.settle_extra);
  r.case_text = prepare_case(p, files);
  r.fingerprint = bed_fingerprint(p);
  r.particles = p.particles;
  r.settle_speed = p.settle_speed;
  r.settle_latest = p.settle_latest;
  return r;
}

// ---- measured runs ----------------------------------------------------------------------------

struct Config {
  Scene scene;
  int ranks;
  Code code;
};
bool operator<(const Config& a, const Config& b) {
  return std::tie(a.scene, a.ranks, a.code) < std::tie(b.scene, b.ranks, b.code);
}

std::string fmt_num(double x, const char* spec = "{:.3g}") {
  return std::isnan(x) ? "-" : fmt::format(fmt::runtime(spec), x);
}
std::string fmt_pct(double x) { return std::isnan(x) ? "-" : fmt::format("{:.1f}%", 100.0 * x); }

// The silo and lid as STL in DIR/geometry: both codes read these files, the silo scenes and the pour.
Files write_silo_files(const BenchParams& p, const fs::path& work) {
  Files files{work / "geometry" / "silo.stl", work / "geometry" / "lid.stl"};
  const auto silo_tris = silo_wall_triangles(p.geometry);
  const auto lid_tris = lid_triangles(p.geometry);
  write_stl(files.silo_stl, "silo", silo_tris);
  write_stl(files.lid_stl, "lid", lid_tris);
  say(fmt::format("geometry: {} ({} triangles: cone r {} -> {} m over z 0 -> {} m, cylinder to z = {} m, {} "
                  "sides), {} ({} triangles: disk r = {} m at z = 0)",
                  files.silo_stl.string(), silo_tris.size(), p.geometry.orifice_radius, p.geometry.radius,
                  p.geometry.cone_height, p.geometry.top, p.geometry.segments, files.lid_stl.string(),
                  lid_tris.size(), p.geometry.lid_radius));
  return files;
}

}  // namespace

// The silo scenes: the bed prepared (or reused), every scene x rank count x code run, the tables
// printed. Returns the machine-readable line (ratio_vs_liggghts ... or liggghts=absent).
std::string run_silo_scenes(const Options& o, const BenchParams& p, const Files& files,
                            const std::vector<Scene>& scenes, const std::vector<int>& ranks,
                            const fs::path& dem_level, const fs::path& work, const std::optional<fs::path>& mpirun,
                            const std::optional<fs::path>& liggghts, bool liggghts_installed) {
  const Bed bed = prepare_bed(silo_bed_recipe(p, files), work / "bed", dem_level, o.rebuild_bed);
  const fs::path bed_h5 = work / "bed" / "bed.h5";
  const fs::path bed_data = work / "bed" / "bed.data";
  if (liggghts) write_liggghts_data(bed_data, p, bed.snap);

  // Scene files.
  for (Scene sc : scenes)
    for (int r : ranks) {
      const fs::path d = work / "runs" / scene_name(sc);
      fs::create_directories(d);
      write_text(d / fmt::format("mlcg_r{}.toml", r), mlcg_case(p, files, sc, r, bed_h5));
      if (liggghts) write_text(d / fmt::format("liggghts_r{}.in", r), liggghts_input(p, files, sc, r, bed_data));
    }

  // The runs: repeats outermost, so slow drift of the machine's load spreads over all configurations.
  std::vector<Config> plan;
  for (Scene sc : scenes)
    for (int r : ranks) {
      plan.push_back({sc, r, Code::Mlcg});
      if (liggghts) plan.push_back({sc, r, Code::Liggghts});
    }
  std::map<Config, std::vector<RunMetrics>> results;
  std::map<Config, std::string> unavailable;
  const size_t total = plan.size() * static_cast<size_t>(o.repeat);
  size_t done = 0;
  for (int rep = 1; rep <= o.repeat; ++rep)
    for (const Config& c : plan) {
      ++done;
      const std::string label = fmt::format("[{}/{}] {:<9} {:<8} {} rank{} repeat {}/{}", done, total,
                                            scene_name(c.scene), code_name(c.code), c.ranks, c.ranks > 1 ? "s" : "",
                                            rep, o.repeat);
      if (unavailable.count(c)) {
        say(label + ": skipped (unavailable)");
        continue;
      }
      if (c.ranks > 1 && !mpirun) {
        unavailable[c] = "mpirun not found";
        say(label + ": unavailable (mpirun not found)");
        continue;
      }
      const fs::path scene_dir = work / "runs" / scene_name(c.scene);
      const std::string tag = fmt::format("{}_r{}_{}", c.code == Code::Mlcg ? "mlcg" : "liggghts", c.ranks, rep);
      const fs::path run_dir = scene_dir / tag;
      fs::remove_all(run_dir);
      fs::create_directories(run_dir);
      const fs::path console = run_dir / "console.txt";
      std::vector<std::string> cmd;
      if (c.ranks > 1) cmd = mpirun_prefix(*mpirun, c.ranks);
      RunMetrics m;
      std::fputs((label + " ... ").c_str(), stdout);
      std::fflush(stdout);
      if (c.code == Code::Mlcg) {
        for (const auto& a : std::vector<std::string>{dem_level.string(),
                                                      (scene_dir / fmt::format("mlcg_r{}.toml", c.ranks)).string(),
                                                      "--out", run_dir.string(), "--quiet"})
          cmd.push_back(a);
        const auto r = run_process(cmd, run_dir, console);
        m = parse_mlcg(run_dir, console, r.exit_code);
        if (r.background_cores() >= 0) m.background_cores = r.background_cores();
      } else {
        for (const auto& a : std::vector<std::string>{
                 liggghts->string(), "-in", (scene_dir / fmt::format("liggghts_r{}.in", c.ranks)).string(), "-log",
                 (run_dir / "log.liggghts").string(), "-echo", "none"})
          cmd.push_back(a);
        const auto r = run_process(cmd, run_dir, console);
        m = parse_liggghts(run_dir / "log.liggghts", console, r.exit_code);
        if (r.background_cores() >= 0) m.background_cores = r.background_cores();
      }
      if (!m.ok) {
        say("unavailable: " + m.error);
        unavailable[c] = m.error;
        continue;
      }
      if (m.steps != p.steps) m.warnings.push_back(fmt::format("ran {} steps, not {}", m.steps, p.steps));
      say(fmt::format("{:.1f} s, {:.3g} particle-steps/s ({:.3g} per core); other processes kept {} core(s) busy",
                      m.loop_seconds, m.rate, m.rate / m.ranks, fmt_num(m.background_cores, "{:.2f}")));
      results[c].push_back(std::move(m));
    }

  // ---- report ----------------------------------------------------------------------------------
  say("");
  say(fmt::format("load average at the end: {}", load_average()));
  std::map<std::pair<Scene, int>, double> ratio;  // ours/LIGGGHTS per core, medians
  std::vector<std::string> suspicious;
  for (Scene sc : scenes) {
    say("");
    say(fmt::format("== {}: {} | {} particles, {} steps of {:g} s, skin {} mm | median of {} ==", scene_name(sc),
                    scene_title(sc), bed.snap.size(), p.steps, p.dt, p.skin * 1e3, o.repeat));
    const std::string head = fmt::format("{:<9}{:>6}{:>18}{:>12}{:>8}{:>8}{:>10}{:>10}{:>10}{:>8}{:>8}{:>8}{:>8}{:>8}{:>16}",
                                         "code", "ranks", "particle-steps/s", "per core", "spread", "busy", "neigh/p",
                                         "rebuild/k", "bytes/p", "force", "neigh", "comm", "meas.", "other",
                                         "ours/LIGGGHTS");
    say(head);
    say(std::string(head.size(), '-'));
    std::vector<std::string> details;
    for (int r : ranks) {
      double per_core[2] = {kNaN, kNaN};
      std::string rows[2];
      for (Code code : {Code::Mlcg, Code::Liggghts}) {
        if (code == Code::Liggghts && !liggghts) continue;
        const Config c{sc, r, code};
        const int k = code == Code::Mlcg ? 0 : 1;
        const auto it = results.find(c);
        if (it == results.end() || it->second.empty()) {
          const auto u = unavailable.find(c);
          rows[k] = fmt::format("{:<9}{:>6}  unavailable: {}", code_name(code), r,
                                u != unavailable.end() ? u->second : "not run");
          continue;
        }
        const auto& runs = it->second;
        auto med = [&](auto f) {
          std::vector<double> v;
          for (const auto& m : runs) v.push_back(f(m));
          return median(v);
        };
        const double rate = med([](const RunMetrics& m) { return m.rate; });
        double lo = 1e300, hi = -1e300;
        for (const auto& m : runs) lo = std::min(lo, m.rate), hi = std::max(hi, m.rate);
        per_core[k] = rate / r;
        double share[5];
        for (int q = 0; q < 5; ++q) share[q] = med([q](const RunMetrics& m) { return m.share[q]; });
        rows[k] = fmt::format("{:<9}{:>6}{:>18}{:>12}{:>8}{:>8}{:>10}{:>10}{:>10}{:>8}{:>8}{:>8}{:>8}{:>8}",
                              code_name(code), r, fmt_num(rate), fmt_num(rate / r),
                              fmt_pct(runs.size() > 1 ? (hi - lo) / rate : kNaN),
                              fmt_num(med([](const RunMetrics& m) { return m.background_cores; }), "{:.2f}"),
                              fmt_num(med([](const RunMetrics& m) { return m.neighbours; }), "{:.2f}"),
                              fmt_num(med([](const RunMetrics& m) { return m.rebuilds_per_1000; }), "{:.2f}"),
                              fmt_num(med([](const RunMetrics& m) { return m.bytes_per_particle; }), "{:.0f}"),
                              fmt_pct(share[0]), fmt_pct(share[1]), fmt_pct(share[2]), fmt_pct(share[3]),
                              fmt_pct(share[4]));
        // Details of the median-rate run.
        const RunMetrics* mid = &runs.front();
        for (const auto& m : runs)
          if (std::abs(m.rate - rate) < std::abs(mid->rate - rate)) mid = &m;
        details.push_back(fmt::format("  {} {} rank{}: {}; particles {} -> {}; final kinetic energy {:.3g} J{}",
                                      code_name(code), r, r > 1 ? "s" : "", mid->breakdown, mid->particles,
                                      mid->particles_end, mid->final_kinetic_energy,
                                      mid->dangerous_builds > 0 ? fmt::format("; {} DANGEROUS neighbour builds",
                                                                              mid->dangerous_builds)
                                                                : ""));
        for (const auto& m : runs) {
          if (m.particles != static_cast<long>(bed.snap.size()))
            suspicious.push_back(fmt::format("{} {} {} rank(s): started with {} particles, the bed has {}",
                                             scene_name(sc), code_name(code), r, m.particles, bed.snap.size()));
          if (sc == Scene::Bed && m.particles_end != m.particles)
            suspicious.push_back(fmt::format("bed {} {} rank(s): {} particles at the start, {} at the end",
                                             code_name(code), r, m.particles, m.particles_end));
          if (m.dangerous_builds > 0)
            suspicious.push_back(fmt::format("{} LIGGGHTS {} rank(s): {} dangerous neighbour builds", scene_name(sc),
                                             r, m.dangerous_builds));
          for (const auto& w : m.warnings) {
            const std::string s = fmt::format("{} {} {} rank(s): {}", scene_name(sc), code_name(code), r, w);
            if (std::find(suspicious.begin(), suspicious.end(), s) == suspicious.end()) suspicious.push_back(s);
          }
        }
      }
      if (!std::isnan(per_core[0]) && !std::isnan(per_core[1])) {
        ratio[{sc, r}] = per_core[0] / per_core[1];
        rows[0] += fmt::format("{:>16}", fmt::format("{:.2f}", per_core[0] / per_core[1]));
      }
      for (const auto& row : rows)
        if (!row.empty()) say(row);
    }
    say("time breakdown of the median run:");
    for (const auto& d : details) say(d);
  }

  say("");
  say("Columns: particle-steps/s = particles x steps / time-stepping wall time (MLCG: summary.json wall_seconds "
      "minus its final snapshot/checkpoint output; LIGGGHTS: \"Loop time\"); per core = / ranks; spread = (max - "
      "min) / median over the repeats; busy = cores that other processes kept busy during the run (/proc/stat busy "
      "time minus the run's own CPU time, / wall time; median): above ~0.1 the run shared its cores and is slower "
      "than on a quiet machine.");
  say("  neigh/p = neighbour-list entries per particle, half list, skin included: MLCG = pairs stored once / "
      "particles (summary.json, at the end, as dem_level reports it for 2 ranks); LIGGGHTS = \"Ave neighs/atom\" (newton off: on one "
      "rank each pair once; at 2 ranks pairs across the subdomain boundary are stored on both ranks).");
  say("  rebuild/k = neighbour-list builds per 1000 steps, the first build included (LIGGGHTS: \"Neighbor list "
      "builds\" + 1 for its setup build). bytes/p = MLCG's own memory accounting; LIGGGHTS = "
      "\"Memory usage per processor\" x ranks / atoms (LAMMPS's estimate, includes meshes and fix storage).");
  say("  Shares of the time-stepping time: MLCG force = pair + wall contacts, neigh = binning + list build, comm = "
      "MPI, meas. = probes/grids, other = integration and the rest. LIGGGHTS force = \"Pair\" only (the STL wall "
      "contacts are computed in fix wall/gran and counted in \"Other\" with the integration), neigh = \"Neigh\", "
      "comm = \"Comm\", other = \"Outpt\" + \"Other\" (+ \"Modify\"); LIGGGHTS has no measurement phase here (-).");
  say("  ours/LIGGGHTS = MLCG particle-steps/s per core / LIGGGHTS's, medians, same scene and rank count.");
  {
    size_t runs = 0;
    bool counts_ok = true;
    for (const auto& [c, v] : results)
      for (const auto& m : v) {
        ++runs;
        counts_ok = counts_ok && m.particles == static_cast<long>(bed.snap.size());
      }
    say("");
    say(fmt::format("Checks: {} of {} measured run(s) started with the bed's {} particles{}.",
                    counts_ok ? runs : 0, runs, bed.snap.size(),
                    counts_ok ? " (MLCG and LIGGGHTS read the same particles)" : "; see the warnings below"));
    if (!suspicious.empty()) {
      say("Warnings:");
      for (const auto& s : suspicious) say("  " + s);
    }
  }
  auto ratio_str = [&](int r) {
    const auto it = ratio.find({Scene::Bed, r});
    return it == ratio.end() ? std::string("na") : fmt::format("{:.3f}", it->second);
  };
  if (!liggghts_installed) return "liggghts=absent";
  return fmt::format("ratio_vs_liggghts rank1={} rank2={}", ratio_str(1), ratio_str(2));
}

namespace {

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
      ratio_line = run_silo_scenes(o, p, *files, scenes, ranks, dem_level, work, mpirun, liggghts, liggghts_installed);
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
