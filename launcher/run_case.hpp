#pragma once
// `mlcg run CASE`: reads the case, starts exactly the processes it needs and
// prints the run's summary. Shared by `mlcg run` and `mlcg study`.
#include <string>

namespace mlcg::launcher {

// Runs the case into out_dir (default runs/<case>-<date>). Returns the run's exit code:
// 0 completed, 2 the case was refused, else the code of the process that failed.
int run_case(const std::string& case_file, std::string out_dir, bool quiet);

}  // namespace mlcg::launcher
