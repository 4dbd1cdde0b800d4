#include "supervise.hpp"

#include <chrono>
#include <csignal>
#include <cstdio>
#include <sys/wait.h>
#include <thread>

#include "process.hpp"

namespace mlcg::launcher {

Outcome supervise(std::vector<Member>& members, const SuperviseOptions& opt) {
  using Clock = std::chrono::steady_clock;
  const auto after = [](double s) { return Clock::now() + std::chrono::milliseconds(static_cast<int64_t>(s * 1000)); };
  catch_signals();
  take_signal();
  become_subreaper();
  Outcome out;
  for (size_t i = 0; i < members.size(); ++i) {
    if (i == 1 && opt.coupler_started) opt.coupler_started(members);
    Member& m = members[i];
    m.pid = spawn(m.argv);
    m.done = false;
    m.state = "running";
  }
  bool aborting = false;
  int coupler_code = -1;
  auto give_up = Clock::time_point::max(), kill_at = Clock::time_point::max();
  const auto stop_all = [&](int sig) {
    for (auto& m : members)
      if (!m.done) {
        kill(-m.pid, sig);
        if (sig != SIGKILL) kill(-m.pid, SIGCONT);  // a stopped (hung) process handles the signal only when woken
        m.state = "stopping";
      }
  };
  const auto abort_all = [&] {
    aborting = true;
    stop_all(SIGTERM);
    kill_at = after(opt.kill_grace);
  };
  for (;;) {
    size_t running = 0;
    for (auto& m : members) {
      if (m.done) continue;
      int status = 0;
      if (waitpid(m.pid, &status, WNOHANG) != m.pid) {
        ++running;
        continue;
      }
      m.done = true;
      m.state = describe_exit(status);
      kill(-m.pid, SIGTERM);  // what it leaves behind in its group (the ranks of a killed mpirun)
      const int code = exit_code_of(status);
      if (&m == &members[0]) coupler_code = code;
      if (code != 0 && !out.interrupted && !out.stopped_for_swap && !aborting) {
        out.failed = m.name + " (pid " + std::to_string(m.pid) + ") " + m.state;
        out.failed_name = m.name;
        out.exit_code = code;
        std::fprintf(stderr, "\nmlcg: %s; stopping every other process\n", out.failed.c_str());
        abort_all();
      }
    }
    if (running == 0) break;
    const bool quiet_stop = !out.interrupted && !out.stopped_for_swap && !aborting;
    if (quiet_stop && opt.want_stop && opt.want_stop()) {
      out.stopped_for_swap = true;
      if (!members[0].done) kill(-members[0].pid, SIGINT);
      give_up = after(opt.interrupt_grace);
    }
    if (take_signal() != 0) {
      if (!out.interrupted && !aborting) {
        out.stopped_for_swap = false;  // the user's stop wins: no swap
        out.interrupted = true;
        std::fprintf(stderr, "\nmlcg: interrupted: every level writes a consistent checkpoint at the next coupling "
                             "interval, then stops (interrupt again to stop at once)\n");
        if (!members[0].done) kill(-members[0].pid, SIGINT);
        give_up = after(opt.interrupt_grace);
      } else if (!aborting) {
        std::fprintf(stderr, "\nmlcg: stopping every process now\n");
        abort_all();
      }
    }
    // The coupler is gone (it stopped the levels or failed): whoever is left gets a few seconds.
    if ((out.interrupted || out.stopped_for_swap) && !aborting && members[0].done && give_up > after(10.0))
      give_up = after(10.0);
    if (!aborting && Clock::now() > give_up) {
      std::fprintf(stderr, "\nmlcg: the stop with a consistent checkpoint did not finish; stopping every process\n");
      abort_all();
    }
    if (Clock::now() > kill_at) {
      stop_all(SIGKILL);
      kill_at = Clock::time_point::max();
    }
    if (opt.tick)
      opt.tick(members, out.interrupted ? "stopping" : aborting ? "failing" : out.stopped_for_swap ? "swapping" : "running");
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  for (const auto& m : members) kill(-m.pid, SIGKILL);  // no process of the attempt outlives it
  end_strays(opt.kill_grace);
  // The run reached its end before the stop: nothing to swap.
  if (out.stopped_for_swap && coupler_code == 0 && out.failed.empty()) out.stopped_for_swap = false;
  if (out.interrupted && out.exit_code == 0) out.exit_code = 130;
  return out;
}

}  // namespace mlcg::launcher
