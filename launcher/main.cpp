// mlcg: the user's entry point. `mlcg run CASE` reads the case, starts exactly
// the processes it needs (a single-level case: one dem_level, no coupler; a
// hierarchy: the coupler and every level),
// forwards Ctrl-C to them and prints the run's summary. `mlcg check CASE` makes
// the same checks without starting anything and estimates the run's cost.
// `mlcg study CASE_DIR` runs a case folder's variants and compares their error and cost.
// `mlcg submit CASE` writes a Slurm batch script for the case and submits it.
// `mlcg plan CASE --out VARIANT` writes the MLCG variant of a single-level case.
#include <CLI/CLI.hpp>

#include <cstdlib>
#include <cstring>

#include "plan/check.hpp"
#include "plan/plan.hpp"
#include "run/control.hpp"
#include "run/hierarchy.hpp"
#include "run/run_case.hpp"
#include "run/status.hpp"
#include "run/submit.hpp"
#include "study/study.hpp"

using namespace mlcg;

namespace {

// Every option of every subcommand; CLI11 writes into it.
struct Args {
  std::string case_file, out_dir, hosts, run_dir, runs_dir = "runs", swap_level, swap_binary;
  bool quiet = false, curve = false, calibrate = false, no_calibrate = false, no_plots = false, previous = false;
  launcher::CheckOptions check;
  launcher::StudyOptions study;
  launcher::PlanOptions plan;
};

CLI::App* declare_plan(CLI::App& app, Args& a) {
  auto* plan = app.add_subcommand("plan", "write the MLCG variant of a single-level case: levels, one fine region "
                                          "per outlet, cells, from the region rules' evidence");
  plan->add_option("case", a.plan.case_file, "the single-level case (the fully resolved reference)")
      ->required()
      ->check(CLI::ExistingFile);
  plan->add_option("--out", a.plan.out, "the variant file to write (must not exist)")->required();
  plan->add_option("--error", a.plan.error, "target error of each outlet's discharge in % (default 3; >= 1)");
  plan->add_option("--levels", a.plan.levels, "levels of the hierarchy: 2 (default) or 3");
  plan->add_option("--reference-run", a.plan.reference_run,
                   "a completed run of the case: its events' firing times become the variant's")
      ->check(CLI::ExistingDirectory);
  return plan;
}

CLI::App* declare_run(CLI::App& app, Args& a) {
  auto* run = app.add_subcommand("run", "run a case");
  run->add_option("case", a.case_file, "case file (TOML)")->required()->check(CLI::ExistingFile);
  run->add_option("--out", a.out_dir, "run folder (default runs/<case>-<date>)");
  run->add_flag("--quiet", a.quiet, "no progress lines");
  run->add_option("--hosts", a.hosts, "place the coupler and the levels on these hosts (README: Runs across hosts); "
                                     "turns CURVE on. Inside a Slurm allocation the allocation's nodes are the hosts "
                                     "without it")->check(CLI::ExistingFile);
  run->add_flag("--curve", a.curve, "secure the bus with CURVE keys issued for this run (in <run>/keys)");
  return run;
}

CLI::App* declare_check(CLI::App& app, Args& a) {
  auto* check = app.add_subcommand("check", "check a case as `run` would and estimate its cost (particles, "
                                            "particle-steps, wall time on this machine); start nothing");
  check->add_option("case", a.check.case_file, "case file (TOML)")->required()->check(CLI::ExistingFile);
  check->add_option("--out", a.check.out_dir, "check this run folder as `run --out` would (nothing is created)");
  check->add_option("--hosts", a.check.hosts, "check this hostfile as `run --hosts` would")->check(CLI::ExistingFile);
  check->add_flag("--curve", a.check.curve, "check as `run --curve` would");
  check->add_flag("--calibrate", a.calibrate, "measure this machine's throughput again (a few seconds)");
  check->add_flag("--no-calibrate", a.no_calibrate, "never measure: use the cached throughput or give no wall time "
                                                    "(also MLCG_NO_CALIBRATE=1)");
  return check;
}

CLI::App* declare_submit(CLI::App& app, Args& a) {
  auto* submit = app.add_subcommand("submit", "write a Slurm batch script for a case (--ntasks: the levels' ranks + "
                                              "the coupler) into its run folder and submit it with sbatch; other "
                                              "options (e.g. --partition=P --time=1:00:00) go to sbatch");
  submit->add_option("case", a.case_file, "case file (TOML)")->required()->check(CLI::ExistingFile);
  submit->add_option("--out", a.out_dir, "run folder (default runs/<case>-<date>); holds mlcg_submit.sh and the "
                                         "job's output slurm-<job id>.out");
  submit->add_flag("--quiet", a.quiet, "the run prints no progress lines into the job's output");
  submit->allow_extras();
  submit->footer("Arguments after the case other than --out and --quiet go to sbatch unchanged, e.g.\n"
                 "  mlcg submit cases/quickstart/mlcg.toml --partition=debug --time=0:30:00\n"
                 "Inside the job, `mlcg run` places the coupler and the levels on the allocation's nodes.");
  return submit;
}

CLI::App* declare_study(CLI::App& app, Args& a) {
  auto* study = app.add_subcommand("study", "error against run time: run a case folder's variants and compare them");
  launcher::StudyOptions& so = a.study;
  study->add_option("case_dir", so.case_dir, "case folder")->required()->check(CLI::ExistingDirectory);
  study->add_option("--study", so.study_file, "study file (default CASE_DIR/study.toml)");
  study->add_option("--out", so.out, "study folder (default: the study file's `folder`, else runs/study-<case dir>)");
  study->add_flag("--rerun", so.rerun, "run every variant again instead of reusing its completed run");
  study->add_flag("--dry-run", so.dry_run, "check the study, list the variants and what would run; run nothing");
  study->add_flag("--quiet", so.quiet, "no progress lines from the runs");
  study->add_flag("--no-plots", a.no_plots, "write study.csv and study.md only");
  return study;
}

CLI::App* declare_resume(CLI::App& app, Args& a) {
  auto* resume = app.add_subcommand("resume", "continue an interrupted or failed multi-level run from its last "
                                              "consistent checkpoint");
  resume->add_option("run_dir", a.run_dir, "run folder")->required()->check(CLI::ExistingDirectory);
  resume->add_flag("--quiet", a.quiet, "no progress line");
  resume->add_flag("--previous", a.previous, "continue from the consistent set before the last one (when the last "
                                             "one is damaged)");
  return resume;
}

CLI::App* declare_swap(CLI::App& app, Args& a) {
  auto* swap = app.add_subcommand("swap", "replace a level's binary in a running multi-level run (at its next "
                                          "consistent checkpoint)");
  swap->add_option("run_dir", a.run_dir, "run folder")->required()->check(CLI::ExistingDirectory);
  swap->add_option("--level", a.swap_level, "the level to swap")->required();
  swap->add_option("--binary", a.swap_binary, "the new solver binary (same protocol)")->required();
  return swap;
}

int check_command(Args& a) {
  const char* env = std::getenv("MLCG_NO_CALIBRATE");
  const bool skip = a.no_calibrate || (env && *env && std::strcmp(env, "0") != 0);
  a.check.calibration = a.calibrate ? launcher::Calibration::Force
                        : skip      ? launcher::Calibration::Skip
                                    : launcher::Calibration::Cached;
  return launcher::check_case(a.check);
}

}  // namespace

int main(int argc, char** argv) {
  // Inherited by every process the launcher starts (mpirun, the ranks and a one-rank level's Open MPI
  // singleton daemon): hwloc's OpenGL component, which no level uses, tries X displays :0 to :N at every MPI
  // start, each attempt looking up "localhost"; where that name is not in /etc/hosts (a debootstrap chroot)
  // all 90 lookups of a level and its Open MPI daemon go to DNS, and each reply lost costs glibc's 5 s
  // timeout: levels registered after 5.6 and 10.6 s instead of 0.6 s, past the coupler's registration
  // deadline ([coupling] timeout). A user's own HWLOC_COMPONENTS is kept.
  setenv("HWLOC_COMPONENTS", "-gl", 0);
  CLI::App app{"mlcg: multi-level coarse-grain DEM"};
  app.require_subcommand(1);
  Args a;
  auto* run = declare_run(app, a);
  auto* check = declare_check(app, a);
  auto* submit = declare_submit(app, a);
  auto* study = declare_study(app, a);
  auto* resume = declare_resume(app, a);
  auto* plan = declare_plan(app, a);
  auto* ps = app.add_subcommand("ps", "processes and progress of a multi-level run");
  ps->add_option("run_dir", a.run_dir, "run folder")->required()->check(CLI::ExistingDirectory);
  auto* status = app.add_subcommand("status", "the multi-level runs under ./runs and their state");
  status->add_option("--runs", a.runs_dir, "folder holding the run folders (default ./runs)");
  auto* swap = declare_swap(app, a);
  CLI11_PARSE(app, argc, argv);
  if (run->parsed()) return launcher::run_case(a.case_file, a.out_dir, a.quiet, a.hosts, a.curve);
  if (check->parsed()) return check_command(a);
  if (plan->parsed()) return launcher::plan_case(a.plan);
  if (submit->parsed()) return launcher::submit_case(a.case_file, a.out_dir, a.quiet, submit->remaining());
  a.study.plots = !a.no_plots;
  if (study->parsed()) return launcher::run_study(a.study);
  if (swap->parsed()) return launcher::swap_command(a.run_dir, a.swap_level, a.swap_binary);
  if (resume->parsed()) return launcher::resume_hierarchy(a.run_dir, a.quiet, a.previous);
  if (ps->parsed()) return launcher::print_ps(a.run_dir);
  if (status->parsed()) return launcher::print_status_all(a.runs_dir);
  return 0;
}
