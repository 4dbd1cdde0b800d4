#pragma once
// What a running hierarchy shows: status.json in the run folder (written
// atomically by the launcher about once a second: its processes with name,
// pid, host and state, and the coupler's coupling/progress.json: per level
// simulated time, particles, particle-steps/s, and the ETA), one progress line
// on a terminal, and `mlcg ps RUN_DIR` / `mlcg status` reading it back.
#include <filesystem>
#include <string>
#include <vector>

#include "run/supervise.hpp"

namespace mlcg::launcher {

class StatusBoard {
 public:
  StatusBoard(std::filesystem::path run_dir, std::string case_file, bool show_progress);
  // Writes status.json when `force` or a second has passed; refreshes the progress line. `reason`:
  // why the run failed or restarts (the launcher's message), kept in status.json for `mlcg ps`.
  void update(const std::vector<Member>& members, const std::string& state, int attempt, bool force = false,
              const std::string& reason = {});
  void end_line();  // ends the progress line before other output
  double sim_time() const { return sim_time_; }  // the coupler's latest progress (0 before any)

 private:
  std::filesystem::path run_dir_;
  std::string case_file_;
  bool show_;
  double last_ = -1.0;
  bool line_open_ = false;
  double sim_time_ = 0.0;
  std::string write_error_;  // the last status.json write error shown (a full disk: said once, not every second)
};

// `mlcg ps RUN_DIR`: 0, or 1 when RUN_DIR has no status.json.
int print_ps(const std::filesystem::path& run_dir);
// `mlcg status`: one line per run folder under `runs_dir` holding a status.json.
int print_status_all(const std::filesystem::path& runs_dir);

}  // namespace mlcg::launcher
