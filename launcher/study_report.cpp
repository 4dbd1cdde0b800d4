#include "study_report.hpp"

#include <algorithm>

#include <fmt/format.h>

#include "config/case_parser.hpp"
#include "io/atomic_file.hpp"

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
  r.data_dir = r.hierarchy ? v.run / "levels" / s.value("probes_from_level", "") : v.run;
  const auto& probes = s.value("probes", nlohmann::json::array());
  auto p = std::find_if(probes.begin(), probes.end(),
                        [&](const nlohmann::json& q) { return probe.empty() || q.value("name", "") == probe; });
  if (p == probes.end())
    throw StudyError(fmt::format("{}: variant '{}': its run {} has no probe{}; the study compares a [[probes]] "
                                 "entry's discharge (study key `probe`)",
                                 v.where, v.name, v.run.string(), probe.empty() ? "" : " named '" + probe + "'"));
  r.probe = p->value("name", "");
  r.mdot = p->value("mean_kg_per_s", 0.0);
  r.sigma = p->value("std_kg_per_s", 0.0);
  return r;
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
      "name,label,sweep_key,sweep_value,run,reused,levels,particles,probe,mdot_kg_per_s,sigma_kg_per_s,error_pct,"
      "wall_s,cpu_s,particle_steps,particle_steps_per_s,speedup_wall,speedup_cpu,particle_step_ratio\n";
  for (const auto& r : rows)
    out += fmt::format("{},{},{},{},{},{},{},{},{},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g}\n",
                       csv_cell(r.v->name), csv_cell(r.v->label), csv_cell(r.v->sweep_key),
                       csv_cell(r.v->sweep_value), csv_cell(r.v->run.string()), r.reused ? 1 : 0,
                       csv_cell(r.levels), r.particles, csv_cell(r.probe), r.mdot, r.sigma, r.error_pct, r.wall,
                       r.cpu, r.particle_steps, r.wall > 0.0 ? r.particle_steps / r.wall : 0.0, r.speedup_wall,
                       r.speedup_cpu, r.step_ratio);
  io::write_file_atomic(s.folder / "study.csv", out);
}

void write_md(const StudySpec& s, const std::vector<StudyRow>& rows) {
  const bool swept = std::any_of(rows.begin(), rows.end(), [](const StudyRow& r) { return !r.v->sweep.empty(); });
  std::string out = fmt::format("# {}\n\n", s.title.empty() ? "Error against run time" : s.title);
  out += fmt::format("Study file: `{}`. Reference: `{}`. Discharge: probe `{}` (⟨ṁ⟩ and σ(ṁ) over its window; a "
                     "hierarchy's from its finest level).\n\n",
                     s.file.empty() ? "(default variants)" : s.file, s.reference, rows.front().probe);
  out += fmt::format("| variant |{} particles (largest per level) | ⟨ṁ⟩ ± σ(ṁ) [kg/s] | error | wall [s] | CPU [s] | "
                     "particle-steps | particle-steps/s | speedup wall / CPU | particle-step ratio |\n",
                     swept ? " swept value |" : "");
  out += fmt::format("| --- |{} --- | --- | --- | --- | --- | --- | --- | --- | --- |\n", swept ? " --- |" : "");
  for (const auto& r : rows) {
    const std::string value = r.v->sweep.empty() ? "—" : fmt::format("{} = {}", r.v->sweep_key, r.v->sweep_value);
    out += fmt::format("| {}{} |{} {} | {:.4f} ± {:.4f} | {:+.1f} % | {:.1f} | {:.1f}{} | {:.3g} | {:.3g} | {:.2f} / "
                       "{:.2f} | {:.2f} |\n",
                       r.v->label, r.reused ? " (reused)" : "",
                       swept ? fmt::format(" {} |", value) : std::string(), r.levels, r.mdot, r.sigma, r.error_pct,
                       r.wall, r.cpu, r.cpu_measured ? "" : " *", r.particle_steps, r.wall > 0.0 ? r.particle_steps / r.wall : 0.0, r.speedup_wall,
                       r.speedup_cpu, r.step_ratio);
  }
  out += "\nerror = (⟨ṁ⟩ − ⟨ṁ⟩_ref) / ⟨ṁ⟩_ref. CPU seconds = user + system time of every process of the run, "
         "measured by the launcher (a level waiting for the coupler uses none); * = a run without that measurement: "
         "Σ over levels of wall seconds × ranks plus the coupler's busy seconds. Speedup = reference / variant "
         "(wall and CPU seconds); particle-step ratio = reference's particle-steps / the variant's.\n\n";
  for (const auto& r : rows) out += fmt::format("- `{}`: `{}`\n", r.v->name, r.v->run.string());
  io::write_file_atomic(s.folder / "study.md", out);
}

void write_json(const StudySpec& s, const std::vector<StudyRow>& rows) {
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
                             {"sigma_kg_per_s", r.sigma},
                             {"error_pct", r.error_pct},
                             {"wall_s", r.wall},
                             {"cpu_s", r.cpu},
                             {"particle_steps", r.particle_steps}});
  j["pressure"] = pressure_layer(s, rows);
  io::write_file_atomic(s.folder / "study.json", j.dump(2) + "\n");
}

}  // namespace

void write_study_report(const StudySpec& s, std::vector<StudyRow>& rows) {
  const StudyRow& ref = rows.front();
  if (ref.mdot == 0.0)
    throw StudyError(fmt::format("{}: the reference '{}' has ⟨ṁ⟩ = 0 in {}: no error can be measured against it",
                                 ref.v->where, ref.v->name, ref.v->run.string()));
  auto ratio = [](double a, double b) { return b > 0.0 ? a / b : 0.0; };
  for (auto& r : rows) {
    r.error_pct = 100.0 * (r.mdot - ref.mdot) / ref.mdot;
    r.speedup_wall = ratio(ref.wall, r.wall);
    r.speedup_cpu = ratio(ref.cpu, r.cpu);
    r.step_ratio = ratio(ref.particle_steps, r.particle_steps);
  }
  fs::create_directories(s.folder);
  write_csv(s, rows);
  write_md(s, rows);
  write_json(s, rows);
}

}  // namespace mlcg::launcher
