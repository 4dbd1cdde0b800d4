#pragma once
// `mlcg study CASE_DIR`: runs the variants a study file lists (or the case
// folder's usual ones) on the same scene, each the way `mlcg run` does,
// reusing the runs already made, and writes the error of each variant's
// discharge against the reference beside its cost (study.csv, study.md) and
// the plots of scripts/plot_study.py.
#include <string>

namespace mlcg::launcher {

struct StudyOptions {
  std::string case_dir;
  std::string study_file;  // "" = CASE_DIR/study.toml
  std::string out;         // "" = the study file's `folder`, else runs/study-<case dir name>
  bool rerun = false;      // run every variant again (pointed runs excepted)
  bool dry_run = false;    // list the variants and what would run; run nothing
  bool quiet = false;
  bool plots = true;
};

// Returns 0 when every variant has a completed run and the report is written, 2 for a
// refused study or case, else the exit code of the run that failed.
int run_study(const StudyOptions& o);

}  // namespace mlcg::launcher
