#pragma once
// `mlcg run` on a multi-level case: the coupler first, then every level (its
// own mpirun when it has several ranks), all on one bus endpoint; one run
// folder with levels/<name>/ per level, coupling/ and coupler.log from the
// coupler, and a summary.json over the whole hierarchy.
#include <string>

#include "config/case_spec.hpp"
#include "hosts/hosts.hpp"

namespace mlcg::launcher {

// Returns the exit code of the run (0 when every process completed). `placement`: where each
// process runs and the bus security (hosts/hosts.hpp); the default is this machine over ipc.
int run_hierarchy(const config::CaseSpec& cs, const std::string& case_file, const std::string& out_dir, bool quiet,
                  Placement placement = {});
// `mlcg resume RUN_DIR`: the same case, coupler and levels from checkpoints/manifest.json; with
// `previous`, from the consistent set before it (kept for when the last one is damaged). Refused (2)
// while another launcher holds the run folder (run_folder.hpp).
int resume_hierarchy(const std::string& run_dir, bool quiet, bool previous = false);

}  // namespace mlcg::launcher
