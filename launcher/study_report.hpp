#pragma once
// What `mlcg study` writes once every variant has a completed run: per variant
// the discharge, its error against the reference and the cost, read from each
// run's summary.json, as study.csv (machines), study.md (people) and study.json
// (scripts/plot_study.py: run folders, probe series, the pressure layer).
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "study_file.hpp"

namespace mlcg::launcher {

struct StudyRow {
  const Variant* v = nullptr;
  bool reused = false;
  bool hierarchy = false;
  std::string levels;           // "coarse α 2: 313 + fine α 1: 2140"
  long long particles = 0;      // sum of every level's largest particle count
  double mdot = 0.0, sigma = 0.0;  // probe's ⟨ṁ⟩ and σ(ṁ) over its window [kg/s]
  std::string probe;            // the probe's name
  double error_pct = 0.0;       // 100 (⟨ṁ⟩ - ⟨ṁ⟩_ref) / ⟨ṁ⟩_ref
  double wall = 0.0;            // run's wall seconds
  double cpu = 0.0;             // measured CPU seconds of the run's processes (else Σ levels wall × ranks + coupler busy)
  bool cpu_measured = false;
  double particle_steps = 0.0;  // Σ levels
  double speedup_wall = 0.0, speedup_cpu = 0.0, step_ratio = 0.0;  // reference / this
  std::filesystem::path data_dir;  // the finest level's run folder (probes/, grids/)
};

// Reads a completed run's summary.json; `probe` "" = the first probe. Throws StudyError.
StudyRow measure_run(const Variant& v, const std::string& probe);

// Fills the error and the ratios against rows[0] (the reference) and writes
// study.csv, study.md and study.json into the study folder.
void write_study_report(const StudySpec& s, std::vector<StudyRow>& rows);

nlohmann::json read_json_file(const std::filesystem::path& p);

}  // namespace mlcg::launcher
