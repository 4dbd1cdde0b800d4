#pragma once
// Runs a program as a subprocess with stdout and stderr going to a log file (and optionally echoed).
#include <algorithm>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace mlcg::bench {

struct ProcessResult {
  int exit_code = 0;   // 128 + signal when killed by a signal; 127 when it could not be started
  double wall_seconds = 0.0;
  double cpu_seconds = 0.0;           // user + system time of the process and its waited-for descendants
  double machine_busy_seconds = -1.0; // all cores' busy time meanwhile (/proc/stat), -1 if unknown
  // Cores kept busy by other processes during the run (machine busy - ours) / wall, or -1.
  double background_cores() const {
    return machine_busy_seconds < 0 || wall_seconds <= 0 ? -1.0
                                                          : std::max(0.0, machine_busy_seconds - cpu_seconds) / wall_seconds;
  }
};

// Runs argv in `cwd`, appending everything it prints to `log`. Every output line containing one of
// `echo_if` (all lines when it holds an empty string) is also printed as `echo_prefix` + line.
ProcessResult run_process(const std::vector<std::string>& argv, const std::filesystem::path& cwd,
                          const std::filesystem::path& log, const std::string& echo_prefix = "",
                          const std::vector<std::string>& echo_if = {});

// The full path of `name` found in PATH, or nothing.
std::optional<std::filesystem::path> find_in_path(const std::string& name);
// The folder of this executable.
std::filesystem::path own_directory();
// `mpirun -np N` with the flags needed here (root, more ranks than cores).
std::vector<std::string> mpirun_prefix(const std::filesystem::path& mpirun, int ranks);

// /proc/loadavg's 1, 5 and 15 minute figures, as text ("? ? ?" where unreadable).
std::string load_average();

}  // namespace mlcg::bench
