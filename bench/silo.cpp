#include "silo.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <tuple>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "bed.hpp"
#include "geometry.hpp"
#include "parse.hpp"
#include "process.hpp"

namespace mlcg::bench {

namespace fs = std::filesystem;

namespace {

enum class Code { Mlcg, Liggghts };
const char* code_name(Code c) { return c == Code::Mlcg ? "MLCG" : "LIGGGHTS"; }

struct Config {
  Scene scene;
  int ranks;
  Code code;
};
bool operator<(const Config& a, const Config& b) {
  return std::tie(a.scene, a.ranks, a.code) < std::tie(b.scene, b.ranks, b.code);
}

// What the runs gave: per configuration its successful runs, or why it could not run.
struct Results {
  std::map<Config, std::vector<RunMetrics>> runs;
  std::map<Config, std::string> unavailable;
};

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

// Both codes' inputs for every scene and rank count, next to their runs.
void write_scene_files(const BenchParams& p, const Files& files, const SiloOptions& o, const fs::path& bed_h5,
                       const fs::path& bed_data) {
  for (Scene sc : o.scenes)
    for (int r : o.ranks) {
      const fs::path d = o.work / "runs" / scene_name(sc);
      fs::create_directories(d);
      write_text(d / fmt::format("mlcg_r{}.toml", r), mlcg_case(p, files, sc, r, bed_h5));
      if (o.liggghts)
        write_text(d / fmt::format("liggghts_r{}.in", r), liggghts_input(p, files, sc, r, bed_data));
    }
}

// One run of configuration c (repeat rep) in its own folder; its metrics, or an error in m.error.
RunMetrics run_config(const SiloOptions& o, const Config& c, int rep) {
  const fs::path scene_dir = o.work / "runs" / scene_name(c.scene);
  const std::string tag = fmt::format("{}_r{}_{}", c.code == Code::Mlcg ? "mlcg" : "liggghts", c.ranks, rep);
  const fs::path run_dir = scene_dir / tag;
  if (c.code == Code::Mlcg)
    return run_mlcg(o.dem_level, o.mpirun.value_or(fs::path()), c.ranks,
                    scene_dir / fmt::format("mlcg_r{}.toml", c.ranks), run_dir);
  fs::remove_all(run_dir);
  fs::create_directories(run_dir);
  const fs::path console = run_dir / "console.txt";
  std::vector<std::string> cmd;
  if (c.ranks > 1) cmd = mpirun_prefix(*o.mpirun, c.ranks);
  for (const auto& a : std::vector<std::string>{
           o.liggghts->string(), "-in", (scene_dir / fmt::format("liggghts_r{}.in", c.ranks)).string(), "-log",
           (run_dir / "log.liggghts").string(), "-echo", "none"})
    cmd.push_back(a);
  const auto r = run_process(cmd, run_dir, console);
  RunMetrics m = parse_liggghts(run_dir / "log.liggghts", console, r.exit_code);
  if (r.background_cores() >= 0) m.background_cores = r.background_cores();
  return m;
}

// Every configuration `repeat` times; repeats outermost, so slow drift of the machine's load spreads over
// all configurations.
Results run_plan(const BenchParams& p, const SiloOptions& o) {
  std::vector<Config> plan;
  for (Scene sc : o.scenes)
    for (int r : o.ranks) {
      plan.push_back({sc, r, Code::Mlcg});
      if (o.liggghts) plan.push_back({sc, r, Code::Liggghts});
    }
  Results res;
  const size_t total = plan.size() * static_cast<size_t>(o.repeat);
  size_t done = 0;
  for (int rep = 1; rep <= o.repeat; ++rep)
    for (const Config& c : plan) {
      ++done;
      const std::string label = fmt::format("[{}/{}] {:<9} {:<8} {} rank{} repeat {}/{}", done, total,
                                            scene_name(c.scene), code_name(c.code), c.ranks, c.ranks > 1 ? "s" : "",
                                            rep, o.repeat);
      if (res.unavailable.count(c)) {
        say(label + ": skipped (unavailable)");
        continue;
      }
      if (c.ranks > 1 && !o.mpirun) {
        res.unavailable[c] = "mpirun not found";
        say(label + ": unavailable (mpirun not found)");
        continue;
      }
      std::fputs((label + " ... ").c_str(), stdout);
      std::fflush(stdout);
      RunMetrics m = run_config(o, c, rep);
      if (!m.ok) {
        say("unavailable: " + m.error);
        res.unavailable[c] = m.error;
        continue;
      }
      if (m.steps != p.steps) m.warnings.push_back(fmt::format("ran {} steps, not {}", m.steps, p.steps));
      say(fmt::format("{:.1f} s, {:.3g} particle-steps/s ({:.3g} per core); other processes kept {} core(s) busy",
                      m.loop_seconds, m.rate, m.rate / m.ranks, fmt_num(m.background_cores, "{:.2f}")));
      res.runs[c].push_back(std::move(m));
    }
  return res;
}

// What looks wrong in configuration c's runs, each message once.
void add_suspicious(const Config& c, const std::vector<RunMetrics>& runs, size_t bed_particles,
                    std::vector<std::string>& out) {
  const char* sc = scene_name(c.scene);
  const char* code = code_name(c.code);
  for (const auto& m : runs) {
    if (m.particles != static_cast<long>(bed_particles))
      out.push_back(fmt::format("{} {} {} rank(s): started with {} particles, the bed has {}", sc, code, c.ranks,
                                m.particles, bed_particles));
    if (c.scene == Scene::Bed && m.particles_end != m.particles)
      out.push_back(fmt::format("bed {} {} rank(s): {} particles at the start, {} at the end", code, c.ranks,
                                m.particles, m.particles_end));
    if (m.dangerous_builds > 0)
      out.push_back(fmt::format("{} LIGGGHTS {} rank(s): {} dangerous neighbour builds", sc, c.ranks,
                                m.dangerous_builds));
    for (const auto& w : m.warnings) {
      const std::string s = fmt::format("{} {} {} rank(s): {}", sc, code, c.ranks, w);
      if (std::find(out.begin(), out.end(), s) == out.end()) out.push_back(s);
    }
  }
}

// Configuration c's table row (medians) and the details of its median-rate run; its per-core rate.
double table_row(const Config& c, const std::vector<RunMetrics>& runs, std::string& row, std::string& detail) {
  auto med = [&](auto f) { return median_of(runs, f); };
  const int r = c.ranks;
  const double rate = med([](const RunMetrics& m) { return m.rate; });
  double share[5];
  for (int q = 0; q < 5; ++q) share[q] = med([q](const RunMetrics& m) { return m.share[q]; });
  row = fmt::format("{:<9}{:>6}{:>18}{:>12}{:>8}{:>8}{:>10}{:>10}{:>10}{:>8}{:>8}{:>8}{:>8}{:>8}", code_name(c.code), r,
                    fmt_num(rate), fmt_num(rate / r), fmt_pct(rate_spread(runs)),
                    fmt_num(med([](const RunMetrics& m) { return m.background_cores; }), "{:.2f}"),
                    fmt_num(med([](const RunMetrics& m) { return m.neighbours; }), "{:.2f}"),
                    fmt_num(med([](const RunMetrics& m) { return m.rebuilds_per_1000; }), "{:.2f}"),
                    fmt_num(med([](const RunMetrics& m) { return m.bytes_per_particle; }), "{:.0f}"), fmt_pct(share[0]),
                    fmt_pct(share[1]), fmt_pct(share[2]), fmt_pct(share[3]), fmt_pct(share[4]));
  const RunMetrics* mid = &median_run(runs);
  detail = fmt::format("  {} {} rank{}: {}; particles {} -> {}; final kinetic energy {:.3g} J{}", code_name(c.code), r,
                       r > 1 ? "s" : "", mid->breakdown, mid->particles, mid->particles_end,
                       mid->final_kinetic_energy,
                       mid->dangerous_builds > 0 ? fmt::format("; {} DANGEROUS neighbour builds", mid->dangerous_builds)
                                                 : "");
  return rate / r;
}

// Scene sc's table; its ours/LIGGGHTS ratios (medians per core) per rank count.
std::map<int, double> report_scene(const BenchParams& p, const SiloOptions& o, Scene sc, size_t bed_particles,
                                   const Results& res, std::vector<std::string>& suspicious) {
  say("");
  say(fmt::format("== {}: {} | {} particles, {} steps of {:g} s, skin {} mm | median of {} ==", scene_name(sc),
                  scene_title(sc), bed_particles, p.steps, p.dt, p.skin * 1e3, o.repeat));
  const std::string head = fmt::format("{:<9}{:>6}{:>18}{:>12}{:>8}{:>8}{:>10}{:>10}{:>10}{:>8}{:>8}{:>8}{:>8}{:>8}{:>16}",
                                       "code", "ranks", "particle-steps/s", "per core", "spread", "busy", "neigh/p",
                                       "rebuild/k", "bytes/p", "force", "neigh", "comm", "meas.", "other",
                                       "ours/LIGGGHTS");
  say(head);
  say(std::string(head.size(), '-'));
  std::map<int, double> ratio;
  std::vector<std::string> details;
  for (int r : o.ranks) {
    double per_core[2] = {kNaN, kNaN};
    std::string rows[2];
    for (Code code : {Code::Mlcg, Code::Liggghts}) {
      if (code == Code::Liggghts && !o.liggghts) continue;
      const Config c{sc, r, code};
      const int k = code == Code::Mlcg ? 0 : 1;
      const auto it = res.runs.find(c);
      if (it == res.runs.end() || it->second.empty()) {
        const auto u = res.unavailable.find(c);
        rows[k] = fmt::format("{:<9}{:>6}  unavailable: {}", code_name(code), r,
                              u != res.unavailable.end() ? u->second : "not run");
        continue;
      }
      std::string detail;
      per_core[k] = table_row(c, it->second, rows[k], detail);
      details.push_back(detail);
      add_suspicious(c, it->second, bed_particles, suspicious);
    }
    if (!std::isnan(per_core[0]) && !std::isnan(per_core[1])) {
      ratio[r] = per_core[0] / per_core[1];
      rows[0] += fmt::format("{:>16}", fmt::format("{:.2f}", per_core[0] / per_core[1]));
    }
    for (const auto& row : rows)
      if (!row.empty()) say(row);
  }
  say("time breakdown of the median run:");
  for (const auto& d : details) say(d);
  return ratio;
}

void say_columns() {
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
}

void say_checks(const Results& res, size_t bed_particles, const std::vector<std::string>& suspicious) {
  size_t runs = 0;
  bool counts_ok = true;
  for (const auto& [c, v] : res.runs)
    for (const auto& m : v) {
      ++runs;
      counts_ok = counts_ok && m.particles == static_cast<long>(bed_particles);
    }
  say("");
  say(fmt::format("Checks: {} of {} measured run(s) started with the bed's {} particles{}.", counts_ok ? runs : 0,
                  runs, bed_particles,
                  counts_ok ? " (MLCG and LIGGGHTS read the same particles)" : "; see the warnings below"));
  if (!suspicious.empty()) {
    say("Warnings:");
    for (const auto& s : suspicious) say("  " + s);
  }
}

}  // namespace

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

std::string run_silo_scenes(const BenchParams& p, const Files& files, const SiloOptions& o) {
  const Bed bed = prepare_bed(silo_bed_recipe(p, files), o.work / "bed", o.dem_level, o.rebuild_bed);
  const fs::path bed_h5 = o.work / "bed" / "bed.h5";
  const fs::path bed_data = o.work / "bed" / "bed.data";
  if (o.liggghts) write_liggghts_data(bed_data, p, bed.snap);
  write_scene_files(p, files, o, bed_h5, bed_data);
  const Results res = run_plan(p, o);

  say("");
  say(fmt::format("load average at the end: {}", load_average()));
  std::map<int, double> bed_ratio;  // ours/LIGGGHTS per core, medians, bed scene
  std::vector<std::string> suspicious;
  for (Scene sc : o.scenes) {
    const auto ratio = report_scene(p, o, sc, bed.snap.size(), res, suspicious);
    if (sc == Scene::Bed) bed_ratio = ratio;
  }
  say_columns();
  say_checks(res, bed.snap.size(), suspicious);
  auto ratio_str = [&](int r) {
    const auto it = bed_ratio.find(r);
    return it == bed_ratio.end() ? std::string("na") : fmt::format("{:.3f}", it->second);
  };
  if (!o.liggghts_installed) return "liggghts=absent";
  return fmt::format("ratio_vs_liggghts rank1={} rank2={}", ratio_str(1), ratio_str(2));
}

}  // namespace mlcg::bench
