#pragma once
// Watching the processes of one attempt at a hierarchy (the coupler first, then
// every level). The launcher learns of a death at once (waitpid), names the
// process and how it ended, and stops the others:
//   a process fails      -> SIGTERM to the others (the coupler stops without a checkpoint, the levels write
//                           their own checkpoint.h5), SIGKILL after a grace period;
//   SIGINT/SIGTERM to us -> SIGINT to the coupler, which has every level write a consistent checkpoint at
//                           the next interval boundary and stop; a second signal or a stuck stop -> SIGTERM.
// supervise() returns only when no process of the attempt is left.
#include <functional>
#include <string>
#include <sys/types.h>
#include <vector>

namespace mlcg::launcher {

struct Member {
  std::string name;                // "coupler", "level 'fine'"
  std::vector<std::string> argv;
  pid_t pid = -1;
  bool done = false;
  std::string state = "starting";  // running / stopping / exited with code N / was killed by signal N (...)
};

struct Outcome {
  int exit_code = 0;         // 0; 130 when interrupted; else the exit code of the first process that failed
  bool interrupted = false;
  std::string failed;        // the first process that failed, and how ("level 'fine' was killed by signal 9")
};

struct SuperviseOptions {
  double interrupt_grace = 90.0;  // [wall s] for the consistent checkpoint after an interrupt
  double kill_grace = 15.0;       // [wall s] between SIGTERM and SIGKILL
  std::function<void(const std::vector<Member>&, const char* phase)> tick;  // about every 50 ms
};

// Starts every member (members[0] = the coupler) and supervises them.
Outcome supervise(std::vector<Member>& members, const SuperviseOptions& opt);

}  // namespace mlcg::launcher
