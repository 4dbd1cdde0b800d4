#pragma once
// What `mlcg study` writes once every variant has a completed run: per variant
// the discharge, its error against the reference and the cost, read from each
// run's summary.json, as study.csv (machines), study.md (people) and study.json
// (scripts/plot_study.py: run folders, probe series, the pressure layer).
#include <cstdint>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "study/study_file.hpp"

namespace mlcg::launcher {

struct StudyRow {
  const Variant* v = nullptr;
  bool reused = false;
  bool hierarchy = false;
  std::string levels;           // "coarse α 2: 313 + fine α 1: 2140"
  long long particles = 0;      // sum of every level's largest particle count
  double mdot = 0.0, sigma = 0.0;  // probe's ⟨ṁ⟩ and σ(ṁ) over its window [kg/s]
  // Half-width of ⟨ṁ⟩'s 95 % interval [kg/s]: the run's (batch means, summary.json), or with replicas
  // the t interval of the replica means; NaN when the run did not record one (written before it was).
  double ci95 = std::numeric_limits<double>::quiet_NaN();
  std::string ci_method;
  int replicas = 1;
  double spread = std::numeric_limits<double>::quiet_NaN();  // sample std of the replica means [kg/s]
  struct Run {
    std::filesystem::path run;
    uint64_t seed = 0;
    double mdot = 0.0, ci95 = 0.0;
  };
  std::vector<Run> runs;        // the row's runs: one, or one per replica
  std::string probe;            // the probe's name
  std::string probe_level;      // a hierarchy's level the probe is read from ("" for one level)
  bool probe_resolved = true;   // that level is a finest one (false: no fine region holds the probe)
  double error_pct = 0.0;       // 100 (⟨ṁ⟩ - ⟨ṁ⟩_ref) / ⟨ṁ⟩_ref
  double error_ci_pct = std::numeric_limits<double>::quiet_NaN();  // its 95 % half-width, from both ci95
  double wall = 0.0;            // run's wall seconds
  double cpu = 0.0;             // measured CPU seconds of the run's processes (else Σ levels wall × ranks + coupler busy)
  bool cpu_measured = false;
  double particle_steps = 0.0;  // Σ levels
  double speedup_wall = 0.0, speedup_cpu = 0.0, step_ratio = 0.0;  // reference / this
  std::filesystem::path data_dir;  // the run folder of the level the probe is read from (probes/, grids/)
};

// Reads a completed run's summary.json; `probe` "" = the first probe. Throws StudyError.
StudyRow measure_run(const Variant& v, const std::string& probe);
// For a run whose summary.json predates the recorded interval: r.ci95 from the probe's series
// (its probes/NAME.csv, the summary's window, the level's batch-means rule); stays NaN when the series
// is missing or does not reproduce the summary's mean.
void probe_series_ci(StudyRow& r, const nlohmann::json& probe);

// The runs of a variant with replicas (consecutive, same name) become one row: the mean of the
// replica means, their spread and a t interval with N - 1 degrees of freedom; costs per run (means).
std::vector<StudyRow> combine_replicas(std::vector<StudyRow> runs);

// The probes of the reference's run (rows[0]'s), in the order its summary lists them.
std::vector<std::string> probe_names(const StudyRow& reference);

// Fills the error, its interval and the ratios against rows[0] (the reference).
void compare_with_reference(std::vector<StudyRow>& rows);

// Writes study.csv, study.md and study.json into the study folder: `rows` (compared with the reference) on the
// study's probe, and `every_probe` (one row set per probe of the reference, each compared with the reference's
// same probe) as the per-outlet table of a scene with several outlets.
void write_study_report(const StudySpec& s, const std::vector<StudyRow>& rows,
                        const std::vector<std::vector<StudyRow>>& every_probe);

nlohmann::json read_json_file(const std::filesystem::path& p);

// One row as `mlcg study` prints it at the end ("n/a" for an interval a run did not record).
std::string console_line(const StudyRow& r);

}  // namespace mlcg::launcher
