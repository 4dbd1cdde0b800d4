#include "study/study_report.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

#include <fmt/format.h>

#include "config/case_parser.hpp"
#include "io/atomic_file.hpp"
#include "stats/series_stats.hpp"

namespace fs = std::filesystem;

namespace mlcg::launcher {

nlohmann::json read_json_file(const fs::path& p) {
  auto j = nlohmann::json::parse(read_text(p), nullptr, /*allow_exceptions=*/false);
  return j.is_discarded() ? nlohmann::json::object() : j;  // missing or half-written: no summary
}

StudyRow measure_run(const Variant& v, const std::string& probe) {
  const auto s = read_json_file(v.run / "summary.json");
  if (s.value("status", "") != "completed")
    throw StudyError(fmt::format("{}: variant '{}': {} is not a completed run", v.where, v.name, v.run.string()));
  StudyRow r;
  r.v = &v;
  const auto& levels = s.value("levels", nlohmann::json::array());
  r.hierarchy = levels.size() > 1;
  // A hierarchy's levels carry their own wall time; a single level's is the run's.
  for (const auto& l : levels) {
    const auto n = l.value("particles_max", 0LL);
    r.particles += n;
    r.particle_steps += l.value("particle_steps", 0.0);
    r.cpu += l.value("wall_seconds", s.value("wall_seconds", 0.0)) * l.value("ranks", 1);
    r.levels += fmt::format("{}{} α {:g}: {}", r.levels.empty() ? "" : " + ", l.value("name", "?"),
                            l.value("alpha", 0.0), n);
  }
  if (s.contains("coupling")) r.cpu += s["coupling"].value("coupler_busy_seconds", 0.0);
  // Measured by the launcher (user + system of every process); the sum above for older runs.
  r.cpu_measured = s.contains("cpu_seconds");
  if (r.cpu_measured) r.cpu = s["cpu_seconds"].get<double>();
  r.wall = s.value("wall_seconds", 0.0);
  const auto& probes = s.value("probes", nlohmann::json::array());
  auto p = std::find_if(probes.begin(), probes.end(),
                        [&](const nlohmann::json& q) { return probe.empty() || q.value("name", "") == probe; });
  if (p == probes.end())
    throw StudyError(fmt::format("{}: variant '{}': its run {} has no probe{}; the study compares a [[probes]] "
                                 "entry's discharge (study key `probe`)",
                                 v.where, v.name, v.run.string(), probe.empty() ? "" : " named '" + probe + "'"));
  // The level that resolves the probe (runs before per-probe levels: the finest level's).
  if (r.hierarchy) {
    r.probe_level = p->value("level", s.value("probes_from_level", ""));
    r.probe_resolved = p->value("resolved", true);
  }
  r.data_dir = r.hierarchy ? v.run / "levels" / r.probe_level : v.run;
  r.probe = p->value("name", "");
  r.mdot = p->value("mean_kg_per_s", 0.0);
  r.sigma = p->value("std_kg_per_s", 0.0);
  if (const auto ci = p->find("ci95_kg_per_s"); ci != p->end() && ci->is_number()) {
    r.ci95 = ci->get<double>();
    r.ci_method = p->value("ci_method", "");
  } else {  // a run written before the interval was recorded: from its probe series, else n/a (NaN)
    probe_series_ci(r, *p);
  }
  r.runs = {{v.run, v.seed, r.mdot, r.ci95}};
  return r;
}

void probe_series_ci(StudyRow& r, const nlohmann::json& probe) {
  const auto& win = probe.value("window", nlohmann::json());
  std::ifstream in(r.data_dir / probe.value("file", ""));
  if (!win.is_array() || win.size() != 2 || !in) return;
  std::vector<std::pair<double, double>> tr;  // sample end time, rate
  std::string line;
  std::getline(in, line);  // header
  double t = 0.0, rate = 0.0;
  char comma = 0;
  while (std::getline(in, line)) {
    std::istringstream ls(line);
    if (ls >> t >> comma >> rate) tr.emplace_back(t, rate);
  }
  if (tr.size() < 2) return;
  // The level's own rule (MassFlowProbe::window_stats): samples wholly inside the window.
  const double dt = tr[1].first - tr[0].first, t0 = win[0].get<double>(), t1 = win[1].get<double>();
  std::vector<double> x;
  for (const auto& [te, q] : tr)
    if (te - dt >= t0 - 1e-6 && te <= t1 + 1e-6) x.push_back(q);
  const stats::MeanCI ci = stats::batch_means_ci(x);
  if (std::isnan(ci.ci95) || std::fabs(ci.mean - r.mdot) > 1e-6 * std::fabs(r.mdot)) return;  // not the run's window
  r.ci95 = ci.ci95;
  r.ci_method = ci.method() + ", from " + probe.value("file", "") + " (the run predates the interval)";
}

namespace {

StudyRow combine(const std::vector<StudyRow>& runs, size_t first, size_t last) {
  StudyRow r = runs[first];  // label, levels, probe, data_dir: the first replica's
  const size_t n = last - first;
  double mdot = 0.0, sigma = 0.0, wall = 0.0, cpu = 0.0, steps = 0.0, particles = 0.0;
  r.runs.clear();
  for (size_t k = first; k < last; ++k) {
    const StudyRow& q = runs[k];
    mdot += q.mdot;
    sigma += q.sigma;
    wall += q.wall;
    cpu += q.cpu;
    steps += q.particle_steps;
    particles += static_cast<double>(q.particles);
    r.reused = r.reused && q.reused;
    r.cpu_measured = r.cpu_measured && q.cpu_measured;
    r.runs.push_back(q.runs.front());
  }
  const double nd = static_cast<double>(n);
  r.replicas = static_cast<int>(n);
  r.mdot = mdot / nd;
  r.sigma = sigma / nd;
  r.wall = wall / nd;
  r.cpu = cpu / nd;
  r.particle_steps = steps / nd;
  r.particles = std::llround(particles / nd);
  double ss = 0.0;
  for (const auto& q : r.runs) ss += (q.mdot - r.mdot) * (q.mdot - r.mdot);
  r.spread = std::sqrt(ss / (nd - 1.0));
  // The replica means are independent: a plain t interval (the runs' own intervals are not needed).
  r.ci95 = stats::student_t_quantile(0.975, static_cast<long>(n) - 1) * r.spread / std::sqrt(nd);
  r.ci_method = fmt::format("t interval of {} replica means", n);
  return r;
}

}  // namespace

std::vector<StudyRow> combine_replicas(std::vector<StudyRow> runs) {
  std::vector<StudyRow> rows;
  for (size_t i = 0; i < runs.size();) {
    size_t j = i + 1;
    if (runs[i].v->replica > 0)
      while (j < runs.size() && runs[j].v->replica > 0 && runs[j].v->name == runs[i].v->name) ++j;
    rows.push_back(j - i > 1 ? combine(runs, i, j) : runs[i]);
    i = j;
  }
  return rows;
}

namespace {
// "n/a" for an interval a run did not record.
std::string fixed(double x, int digits) { return std::isfinite(x) ? fmt::format("{:.{}f}", x, digits) : "n/a"; }
// Significant digits, for flows from grams to tonnes per second ("n/a" as above).
std::string sig(double x, int digits) { return std::isfinite(x) ? fmt::format("{:.{}g}", x, digits) : "n/a"; }
// An empty csv cell for it.
std::string csv_number(double x) { return std::isfinite(x) ? fmt::format("{:.9g}", x) : ""; }
nlohmann::json json_number(double x) { return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(); }
}  // namespace

std::string console_line(const StudyRow& r) {
  return fmt::format("{:<16} {:>9} +- {} kg/s (95 % CI)  error {:+6.1f} +- {} %  wall {:8.1f} s  speedup {:.2f}{}{}",
                     r.v->name, sig(r.mdot, 4), sig(r.ci95, 2), r.error_pct, fixed(r.error_ci_pct, 1), r.wall,
                     r.speedup_wall,
                     r.replicas > 1 ? fmt::format("  ({} replicas, spread {:.2g})", r.replicas, r.spread) : "",
                     r.reused ? "  (reused)" : "");
}

namespace {

std::string csv_cell(const std::string& s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string q = "\"";
  for (char c : s) q += c == '"' ? std::string("\"\"") : std::string(1, c);
  return q + "\"";
}

// The transition layer whose pressure the paper plots: the top cell layer of the finest fine region,
// in the central cells, from a [[grids]] entry covering it. null when no variant has a fine region
// or no grid covers the layer.
nlohmann::json pressure_layer(const StudySpec& s, const std::vector<StudyRow>& rows) {
  for (const auto& r : rows) {
    if (!r.hierarchy || r.v->case_text.empty() || !r.v->sweep.empty()) continue;
    const auto cs = config::parse_case(r.v->case_text, r.v->case_file);
    if (!cs.coupling) continue;
    const auto& finest = *std::min_element(cs.levels.begin(), cs.levels.end(),
                                           [](const auto& a, const auto& b) { return a.alpha < b.alpha; });
    for (const auto& reg : cs.coupling->regions) {
      if (reg.fine != finest.name) continue;
      const double z = reg.max.z - 0.5 * reg.cell_size;
      const double cx = 0.5 * (reg.min.x + reg.max.x), cy = 0.5 * (reg.min.y + reg.max.y);
      for (const auto& g : cs.grids) {
        if (!(g.min.z <= z && z < g.max.z)) continue;
        nlohmann::json p{{"grid", g.name},
                         {"z", z},
                         {"layer", {reg.max.z - reg.cell_size, reg.max.z}},
                         {"window", {cx - reg.cell_size, cx + reg.cell_size, cy - reg.cell_size, cy + reg.cell_size}},
                         {"runs", nlohmann::json::array()}};
        for (const auto& q : rows) {
          const fs::path d = q.data_dir / "grids" / g.name;
          if ((q.v->name == s.reference || (q.hierarchy && q.v->sweep.empty())) && fs::exists(d / "index.json"))
            p["runs"].push_back({{"label", q.v->label}, {"grid_dir", fs::absolute(d).string()}});
        }
        return p;
      }
    }
  }
  return nullptr;
}

void write_csv(const StudySpec& s, const std::vector<StudyRow>& rows) {
  std::string out =
      "name,label,sweep_key,sweep_value,run,reused,levels,particles,probe,mdot_kg_per_s,ci95_kg_per_s,sigma_kg_per_s,"
      "replicas,spread_kg_per_s,error_pct,error_ci_pct,wall_s,cpu_s,particle_steps,particle_steps_per_s,speedup_wall,"
      "speedup_cpu,particle_step_ratio\n";
  for (const auto& r : rows)
    out += fmt::format("{},{},{},{},{},{},{},{},{},{:.9g},{},{:.9g},{},{},{:.9g},{},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},"
                       "{:.9g},{:.9g}\n",
                       csv_cell(r.v->name), csv_cell(r.v->label), csv_cell(r.v->sweep_key),
                       csv_cell(r.v->sweep_value), csv_cell(r.v->run.string()), r.reused ? 1 : 0,
                       csv_cell(r.levels), r.particles, csv_cell(r.probe), r.mdot, csv_number(r.ci95), r.sigma,
                       r.replicas, csv_number(r.spread), r.error_pct, csv_number(r.error_ci_pct), r.wall, r.cpu,
                       r.particle_steps, r.wall > 0.0 ? r.particle_steps / r.wall : 0.0, r.speedup_wall,
                       r.speedup_cpu, r.step_ratio);
  io::write_file_atomic(s.folder / "study.csv", out);
}

// One table line of study.md.
std::string md_row(const StudyRow& r, bool swept) {
  const std::string value = r.v->sweep.empty() ? "—" : fmt::format("{} = {}", r.v->sweep_key, r.v->sweep_value);
  const std::string reps = r.replicas > 1 ? fmt::format("{} (spread {:.2g})", r.replicas, r.spread) : "1";
  return fmt::format("| {}{} |{} {} | {} ± {} | {:.2g} | {} | {:+.1f} ± {} % | {:.1f} | {:.1f}{} | {:.3g} | {:.3g} "
                     "| {:.2f} / {:.2f} | {:.2f} |\n",
                     r.v->label, r.reused ? " (reused)" : "", swept ? fmt::format(" {} |", value) : std::string(),
                     r.levels, sig(r.mdot, 4), sig(r.ci95, 2), r.sigma, reps, r.error_pct, fixed(r.error_ci_pct, 1), r.wall,
                     r.cpu, r.cpu_measured ? "" : " *", r.particle_steps, r.wall > 0.0 ? r.particle_steps / r.wall : 0.0,
                     r.speedup_wall, r.speedup_cpu, r.step_ratio);
}

std::string probe_from(const StudyRow& r) {
  if (r.probe_level.empty()) return "";
  return fmt::format(" (probe from level '{}'{})", r.probe_level,
                     r.probe_resolved ? "" : ", a coarse level: no fine region holds the probe");
}

// Each probe of the reference, every variant: the per-outlet table of a scene with several outlets.
std::string every_probe_md(const std::vector<std::vector<StudyRow>>& every_probe) {
  if (every_probe.size() < 2) return "";
  std::string out = "\n## Every probe\n\nEach probe of the reference in every variant, against the reference's same "
                    "probe (a hierarchy's probe read from the finest level whose region holds it).\n\n"
                    "| probe | variant | ⟨ṁ⟩ ± 95 % CI [kg/s] | read from | error ± 95 % CI |\n"
                    "| --- | --- | --- | --- | --- |\n";
  for (const auto& rows : every_probe)
    for (const auto& r : rows)
      out += fmt::format("| {} | {} | {} ± {} | {} | {:+.1f} ± {} % |\n", r.probe, r.v->label, sig(r.mdot, 4),
                         sig(r.ci95, 2),
                         r.probe_level.empty() ? "the run" : r.probe_level + (r.probe_resolved ? "" : " (coarse)"),
                         r.error_pct, fixed(r.error_ci_pct, 1));
  return out;
}

// What the coupling costs each hierarchy's run (summary.json's overhead_share and its parts), as shares of its
// wall time: the overhead's parts beside the error and speedup above.
nlohmann::json coupling_cost(const fs::path& run) {
  const auto c = read_json_file(run / "summary.json").value("coupling", nlohmann::json::object());
  if (!c.contains("overhead_share")) return nullptr;
  const auto o = c.value("overhead_parts", nlohmann::json::object());
  return {{"overhead_share", c.value("overhead_share", 0.0)},
          {"level_coupling_share", o.value("level_coupling_share", 0.0)},
          {"coupler_busy_share", o.value("coupler_busy_share", 0.0)},
          {"pacing_level", o.value("pacing_level", "")},
          {"pacing_level_wait_share", o.value("pacing_level_wait_share", 0.0)},
          {"level_coupling_parts", o.value("level_coupling_parts", nlohmann::json::object())}};
}

std::string coupling_cost_md(const std::vector<StudyRow>& rows) {
  std::string body;
  for (const auto& r : rows)
    for (const auto& q : r.runs) {
      const auto c = coupling_cost(q.run);
      if (c.is_null()) continue;
      const auto& lp = c["level_coupling_parts"];
      const auto pct = [](double x) { return fmt::format("{:.1f}", 100.0 * x); };
      body += fmt::format("| {}{} | **{}** | {} ({}) | {} | {} ({}) | {} | {} | {} | {} | {} | {} | {} |\n", r.v->label,
                          r.replicas > 1 ? fmt::format(" (seed {})", q.seed) : "",
                          pct(c.value("overhead_share", 0.0)), pct(c.value("level_coupling_share", 0.0)),
                          lp.value("level", "?"), pct(c.value("coupler_busy_share", 0.0)),
                          pct(c.value("pacing_level_wait_share", 0.0)), c.value("pacing_level", "?"),
                          pct(lp.value("samples", 0.0)), pct(lp.value("controller", 0.0)),
                          pct(lp.value("statistics", 0.0)), pct(lp.value("send", 0.0)), pct(lp.value("insert", 0.0)),
                          pct(lp.value("stress_kernel_extra", 0.0)), pct(lp.value("insertion_rebuild_seconds", 0.0)));
    }
  if (body.empty()) return "";
  return "\n## Coupling cost\n\nPer hierarchy run, % of its wall time: the overhead (the largest level's coupling work "
         "plus the coupler's busy time), its parts, and the pacing level's wait for the coupler's commands (not "
         "in the overhead). The level's work in parts: cell samples, controller forces, building the statistics, "
         "sending them, inserting the coupler's particles; the stress kernel's extra on sample steps is counted in "
         "its force time and the neighbour rebuilds at the insertions in its neighbour time, not in the "
         "overhead.\n\n"
         "| variant | overhead | level work (level) | coupler busy | wait (pacing level) | samples | controller | "
         "statistics | send | insertion | stress kernel extra | insertion rebuilds |\n"
         "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |\n" +
         body;
}

void write_md(const StudySpec& s, const std::vector<StudyRow>& rows,
              const std::vector<std::vector<StudyRow>>& every_probe) {
  const bool swept = std::any_of(rows.begin(), rows.end(), [](const StudyRow& r) { return !r.v->sweep.empty(); });
  std::string out = fmt::format("# {}\n\n", s.title.empty() ? "Error against run time" : s.title);
  out += fmt::format("Study file: `{}`. Reference: `{}`. Discharge: probe `{}` (⟨ṁ⟩ and σ(ṁ) over its window; a "
                     "hierarchy's from the finest level whose region holds the probe, named below).\n\n",
                     s.file.empty() ? "(default variants)" : s.file, s.reference, rows.front().probe);
  out += fmt::format("| variant |{} particles (largest per level) | ⟨ṁ⟩ ± 95 % CI [kg/s] | σ(ṁ) [kg/s] | replicas | "
                     "error ± 95 % CI | wall [s] | CPU [s] | particle-steps | particle-steps/s | speedup wall / CPU | "
                     "particle-step ratio |\n",
                     swept ? " swept value |" : "");
  out += fmt::format("| --- |{} --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |\n",
                     swept ? " --- |" : "");
  for (const auto& r : rows) out += md_row(r, swept);
  out += "\nerror = (⟨ṁ⟩ − ⟨ṁ⟩_ref) / ⟨ṁ⟩_ref. 95 % CI of ⟨ṁ⟩: batch means over the probe's window (the samples "
         "are autocorrelated; summary.json's ci_method says how many batches); with replicas, the t interval of the "
         "replica means, and ⟨ṁ⟩, σ(ṁ) and the costs are means over the replicas. The error's interval combines both "
         "runs' intervals as independent: δe = |m / m_ref| √((δm / m)² + (δm_ref / m_ref)²); n/a = a run written "
         "before intervals were recorded. CPU seconds = user + system time of every process of the run, "
         "measured by the launcher (a level waiting for the coupler uses none); * = a run without that measurement: "
         "Σ over levels of wall seconds × ranks plus the coupler's busy seconds. Speedup = reference / variant "
         "(wall and CPU seconds); particle-step ratio = reference's particle-steps / the variant's.\n\n";
  for (const auto& r : rows)
    for (const auto& q : r.runs)
      out += fmt::format("- `{}`{}: `{}`{}\n", r.v->name, r.replicas > 1 ? fmt::format(" (seed {})", q.seed) : "",
                         q.run.string(), probe_from(r));
  out += every_probe_md(every_probe);
  out += coupling_cost_md(rows);
  io::write_file_atomic(s.folder / "study.md", out);
}

nlohmann::json runs_json(const StudyRow& r) {
  auto a = nlohmann::json::array();
  for (const auto& q : r.runs)
    a.push_back({{"run", fs::absolute(q.run).string()}, {"seed", q.seed}, {"mdot_kg_per_s", q.mdot},
                 {"ci95_kg_per_s", json_number(q.ci95)}});
  return a;
}

nlohmann::json every_probe_json(const std::vector<std::vector<StudyRow>>& every_probe) {
  auto a = nlohmann::json::array();
  for (const auto& rows : every_probe) {
    auto variants = nlohmann::json::array();
    for (const auto& r : rows)
      variants.push_back({{"name", r.v->name}, {"level", r.probe_level}, {"resolved", r.probe_resolved},
                          {"mdot_kg_per_s", r.mdot}, {"ci95_kg_per_s", json_number(r.ci95)},
                          {"error_pct", r.error_pct}, {"error_ci_pct", json_number(r.error_ci_pct)}});
    a.push_back({{"probe", rows.front().probe}, {"variants", variants}});
  }
  return a;
}

void write_json(const StudySpec& s, const std::vector<StudyRow>& rows,
                const std::vector<std::vector<StudyRow>>& every_probe) {
  nlohmann::json j;
  j["title"] = s.title;
  j["reference"] = s.reference;
  j["variants"] = nlohmann::json::array();
  for (const auto& r : rows)
    j["variants"].push_back({{"name", r.v->name},
                             {"label", r.v->label},
                             {"sweep", r.v->sweep},
                             {"sweep_key", r.v->sweep_key},
                             {"sweep_value", r.v->sweep_value},
                             {"run", fs::absolute(r.v->run).string()},
                             {"hierarchy", r.hierarchy},
                             {"probe", r.probe},
                             {"probe_csv", fs::absolute(r.data_dir / "probes" / (r.probe + ".csv")).string()},
                             {"mdot_kg_per_s", r.mdot},
                             {"ci95_kg_per_s", json_number(r.ci95)},
                             {"ci_method", r.ci_method},
                             {"sigma_kg_per_s", r.sigma},
                             {"replicas", r.replicas},
                             {"spread_kg_per_s", json_number(r.spread)},
                             {"runs", runs_json(r)},
                             {"error_pct", r.error_pct},
                             {"error_ci_pct", json_number(r.error_ci_pct)},
                             {"wall_s", r.wall},
                             {"cpu_s", r.cpu},
                             {"particle_steps", r.particle_steps},
                             {"coupling_cost", r.runs.empty() ? nullptr : coupling_cost(r.runs.front().run)}});
  j["pressure"] = pressure_layer(s, rows);
  j["probes"] = every_probe_json(every_probe);
  io::write_file_atomic(s.folder / "study.json", j.dump(2) + "\n");
}

}  // namespace

std::vector<std::string> probe_names(const StudyRow& reference) {
  std::vector<std::string> out;
  for (const auto& p : read_json_file(reference.v->run / "summary.json").value("probes", nlohmann::json::array()))
    out.push_back(p.value("name", ""));
  return out;
}

void compare_with_reference(std::vector<StudyRow>& rows) {
  const StudyRow& ref = rows.front();
  if (ref.mdot == 0.0)
    throw StudyError(fmt::format("{}: the reference '{}' has ⟨ṁ⟩ = 0 on probe '{}' in {}: no error can be measured "
                                 "against it", ref.v->where, ref.v->name, ref.probe, ref.v->run.string()));
  auto ratio = [](double a, double b) { return b > 0.0 ? a / b : 0.0; };
  for (auto& r : rows) {
    r.error_pct = 100.0 * (r.mdot - ref.mdot) / ref.mdot;
    // Independent runs: δe = |m/m_ref| √((δm/m)² + (δm_ref/m_ref)²), written without dividing by m (m may be 0).
    // The reference's own error is 0 exactly. NaN (n/a) when either run has no interval.
    r.error_ci_pct = &r == &ref ? 0.0
                                : 100.0 * std::hypot(r.ci95, r.mdot * ref.ci95 / ref.mdot) / std::abs(ref.mdot);
    r.speedup_wall = ratio(ref.wall, r.wall);
    r.speedup_cpu = ratio(ref.cpu, r.cpu);
    r.step_ratio = ratio(ref.particle_steps, r.particle_steps);
  }
}

void write_study_report(const StudySpec& s, const std::vector<StudyRow>& rows,
                        const std::vector<std::vector<StudyRow>>& every_probe) {
  fs::create_directories(s.folder);
  write_csv(s, rows);
  write_md(s, rows, every_probe);
  write_json(s, rows, every_probe);
}

}  // namespace mlcg::launcher
