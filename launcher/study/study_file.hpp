#pragma once
// The study file of `mlcg study` (keys in cases/README.md, "Study files"): the
// variants to compare and the sweeps that derive more of them from one case by
// setting one key. Everything is checked before anything runs; every error is
// a StudyError reading "FILE:LINE: KEY: what is wrong; what is allowed".
#include <cstdint>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include "config/case_schema_coupling.hpp"

namespace mlcg::launcher {

struct StudyError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct Variant {
  std::string name;         // unique; the run folder's name inside the study folder
  std::string label;        // shown in tables and plots
  std::string case_file;    // the case to run ("" only for a pointed run without a case)
  std::string case_text;    // its content: a run is reused only when its copied case equals it
  std::filesystem::path run;  // its run folder
  bool pointed = false;     // `run` given by the user: reused as it is, never run or removed
  bool derived = false;     // written by a sweep into the study folder
  std::string sweep;        // sweep name ("" for a listed variant)
  std::string sweep_key;    // the swept key and this variant's value, as written in the study file
  std::string sweep_value;
  std::string where;        // "FILE:LINE" of its entry, for messages
  uint64_t seed = 0;        // the case's seed
  // `replicas = N` (N >= 2) runs the variant N times with seeds seed, seed + 1, ...: one Variant per
  // run, all with the entry's name (one row of the table), replica 1..N; a derived case each.
  int replica = 0;          // 0 = not a replica
  int replicas = 1;
};

// The bound of [[variants]] replicas, as declared (config/case_schema_coupling.hpp).
inline constexpr int kMaxReplicas = static_cast<int>(config::schema::at(config::schema::kStudyVariant, "replicas").bounds.hi);

struct StudySpec {
  std::string file;                 // the study file ("" = the default variants of the case folder)
  std::string title;
  std::filesystem::path folder;     // the study folder
  std::string reference;            // name of the reference variant
  std::string probe;                // probe compared ("" = each run's first probe)
  std::vector<Variant> variants;    // one per run; the reference's first
};

// Reads `study_file` (when it exists or was given explicitly) or falls back to
// the default variants of `case_dir`: reference.toml (or case.toml), cg2.toml,
// mlcg.toml, mlcg_no_pi.toml, those present. `out` (when not empty) overrides
// the study folder. Sweep cases are derived in memory and every case is checked
// by the case parser; nothing is written.
// The whole content of a file ("" when it cannot be read).
std::string read_text(const std::filesystem::path& p);

StudySpec load_study(const std::filesystem::path& case_dir, const std::string& study_file, bool explicit_file,
                     const std::string& out);

}  // namespace mlcg::launcher
