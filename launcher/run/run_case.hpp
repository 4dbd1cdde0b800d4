#pragma once
// `mlcg run CASE`: reads the case, starts exactly the processes it needs and
// prints the run's summary. Shared by `mlcg run` and `mlcg study`.
#include <string>

#include "config/case_spec.hpp"
#include "config/region_rules.hpp"
#include "hosts/hosts.hpp"

namespace mlcg::launcher {

// The coupling-region rules of a hierarchy (config/region_rules.hpp) against the scene's outlets
// (scene/outlets.hpp), before anything starts: prints the outlets and notes (stdout) and warnings
// (stderr); throws std::runtime_error with every refusal. Returns the report (for `mlcg check`'s verdict).
config::RegionRuleReport check_regions(const config::CaseSpec& cs, const config::OutletScan& outlets);
config::RegionRuleReport check_regions(const config::CaseSpec& cs);  // finds the outlets itself

// Everything `mlcg run` checks before it starts anything, in one place for `mlcg run` and `mlcg check`:
// the case (parser), the region rules, the hostfile and the bus security. Throws with the message
// `mlcg run` prints after "error: ".
struct PreparedCase {
  config::CaseSpec cs;
  Placement placement;
  config::OutletScan outlets;  // the scene's outlets, found once (scene/outlets.hpp)
  config::RegionRuleReport regions;
};
PreparedCase prepare_case(const std::string& case_file, const std::string& hosts, bool curve);

// runs/<case folder>-<case stem>-<local date and time>: a run's folder when --out is not given.
std::string default_run_dir(const std::string& case_file);

// Runs the case into out_dir (default runs/<case>-<date>). Returns the run's exit code:
// 0 completed, 2 the case or the hostfile was refused, else the code of the process that failed.
// hosts: an Open MPI style hostfile placing the coupler and the levels (README: Runs across
// hosts; turns CURVE on); curve: secure the bus with keys issued for this run.
int run_case(const std::string& case_file, std::string out_dir, bool quiet, const std::string& hosts = "",
             bool curve = false);

}  // namespace mlcg::launcher
