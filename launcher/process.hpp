#pragma once
// Child processes of the launcher. Every process started here is stopped when
// the run ends, fails or is interrupted: SIGINT/SIGTERM received by the
// launcher are forwarded to the children, which checkpoint and exit.
#include <string>
#include <sys/types.h>
#include <vector>

namespace mlcg::launcher {

struct ChildResult {
  int exit_code = -1;   // exit status, or 128 + signal number
  bool signalled = false;
};

// Starts argv[0] with the arguments (PATH is searched). Throws on failure to start.
pid_t spawn(const std::vector<std::string>& argv);
// Waits for the child, forwarding SIGINT/SIGTERM to it meanwhile.
ChildResult wait_forwarding(pid_t child);

// The folder holding the running executable (to find dem_level beside mlcg).
std::string own_directory();
// `mpirun` arguments for n ranks: adds the flags Open MPI needs as root and when oversubscribing.
std::vector<std::string> mpirun_prefix(int ranks);

}  // namespace mlcg::launcher
