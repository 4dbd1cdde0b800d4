#pragma once
// Watching the processes of one attempt at a hierarchy (the coupler first, then
// every level). The launcher learns of a death at once (waitpid), names the
// process and how it ended, and stops the others:
//   a process fails      -> SIGTERM to the others (the coupler stops without a checkpoint, the levels write
//                           their own checkpoint.h5), SIGKILL after a grace period;
//   SIGINT/SIGTERM to us or want_stop() -> SIGINT to the coupler, which has every level write a consistent checkpoint at
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
  bool stopped_for_swap = false;  // stopped at a consistent checkpoint because want_stop() asked
  std::string failed;        // the first process that failed, and how ("level 'fine' (pid 12) was killed by signal 9")
  std::string failed_name;   // its Member::name
};

struct SuperviseOptions {
  double interrupt_grace = 90.0;  // [wall s] for the consistent checkpoint after an interrupt
  double kill_grace = 15.0;       // [wall s] between SIGTERM and SIGKILL
  std::function<void(const std::vector<Member>&, const char* phase)> tick;  // about every 50 ms
  std::function<bool()> want_stop;  // true: stop with a consistent checkpoint (as an interrupt does), for a swap
  // After members[0] (the coupler) started, before the others: may rewrite their argv (the port
  // a remote coupler bound). Throwing stops the coupler's start-up and leaves supervise().
  std::function<void(std::vector<Member>&)> coupler_started;
};

// Starts every member (members[0] = the coupler) and supervises them.
Outcome supervise(std::vector<Member>& members, const SuperviseOptions& opt);

}  // namespace mlcg::launcher
