#pragma once
// `mlcg submit CASE [--out RUN] [sbatch options]`: writes RUN/mlcg_submit.sh, a batch script sized from the
// case (--ntasks = the levels' ranks + 1 for the coupler of a hierarchy) that runs `mlcg run CASE --out RUN`
// inside the allocation, and submits it with sbatch. README: Runs across hosts.
#include <string>
#include <vector>

namespace mlcg::launcher {

// The batch script's text: `mlcg` the launcher to run, `case_file` and `run_dir` absolute.
std::string submit_script(const std::string& mlcg, const std::string& case_file, const std::string& run_dir,
                          const std::string& job_name, int ntasks, int levels, int level_ranks, bool quiet);

// Returns 0 with the job submitted (its id printed), 2 when the case or the folder was refused, else
// sbatch's exit code (the script is then removed again).
int submit_case(const std::string& case_file, std::string out_dir, bool quiet,
                const std::vector<std::string>& sbatch_args);

}  // namespace mlcg::launcher
