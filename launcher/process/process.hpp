#pragma once
// Child processes of the launcher. Every process started here is stopped when
// the run ends, fails or is interrupted: SIGINT/SIGTERM received by the
// launcher are forwarded to the children, which checkpoint and exit; when the
// launcher itself is killed, the kernel sends them SIGTERM.
#include <string>
#include <sys/types.h>
#include <vector>

namespace mlcg::launcher {

// Starts argv[0] with the arguments (PATH is searched), in its own process group; it gets SIGTERM when
// the launcher dies, however it dies (PR_SET_PDEATHSIG). Throws on failure to start.
pid_t spawn(const std::vector<std::string>& argv);

// A child with a name for messages ("coupler", "level 'fine'").
struct NamedChild {
  std::string name;
  pid_t pid = -1;
};
struct GroupResult {
  int exit_code = 0;        // 0, or the exit code of the first child that failed
  std::string failed;       // name of that child; empty when all succeeded
  bool interrupted = false; // SIGINT/SIGTERM reached the launcher
};
// Waits for every child, forwarding SIGINT/SIGTERM to all of them. When one
// exits non-zero the others are sent SIGTERM, and SIGKILL after `grace`
// seconds, so no process of the run outlives it.
GroupResult wait_group(const std::vector<NamedChild>& children, double grace = 15.0);

// SIGINT/SIGTERM to the launcher are remembered, not fatal; take_signal() returns the latest (0 = none)
// and forgets it.
void catch_signals();
int take_signal();
// "exited with code 3", "was killed by signal 9 (Killed)"; `status` as waitpid gives it.
std::string describe_exit(int status);
// The exit code the launcher reports for a child's waitpid status: its code, or 128 + signal.
int exit_code_of(int status);

// Orphans of our children (the ranks of a killed mpirun, which Open MPI puts in their own process groups)
// become our children instead of init's, so none outlives the run: end_strays() stops (SIGTERM, SIGKILL
// after `grace` seconds) and reaps every child left once the known ones are reaped.
void become_subreaper();
void end_strays(double grace);

// The folder holding the running executable (to find dem_level beside mlcg).
std::string own_directory();
// `mpirun` arguments for n ranks: adds the flags Open MPI needs as root and when oversubscribing.
std::vector<std::string> mpirun_prefix(int ranks);

}  // namespace mlcg::launcher
