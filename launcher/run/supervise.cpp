#include "run/supervise.hpp"

#include <chrono>
#include <csignal>
#include <cstdio>
#include <sys/wait.h>
#include <thread>

#include "process/process.hpp"

namespace mlcg::launcher {

namespace {

using Clock = std::chrono::steady_clock;

Clock::time_point after(double s) { return Clock::now() + std::chrono::milliseconds(static_cast<int64_t>(s * 1000)); }

// One attempt's state while it runs: who is done, whether the run is stopping (interrupt, swap) or failing,
// and the deadlines of both.
class Attempt {
 public:
  Attempt(std::vector<Member>& members, const SuperviseOptions& opt) : members_(members), opt_(opt) {}

  void start() {
    for (size_t i = 0; i < members_.size(); ++i) {
      if (i == 1 && opt_.coupler_started) opt_.coupler_started(members_);
      Member& m = members_[i];
      m.pid = spawn(m.argv);
      m.done = false;
      m.state = "running";
    }
  }

  // Reaps the members that ended; the first failure stops every other one. The members still running.
  size_t reap() {
    size_t running = 0;
    for (auto& m : members_) {
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
      if (&m == &members_[0]) coupler_code_ = code;
      if (code != 0 && !out_.interrupted && !out_.stopped_for_swap && !aborting_) {
        out_.failed = m.name + " (pid " + std::to_string(m.pid) + ") " + m.state;
        out_.failed_name = m.name;
        out_.exit_code = code;
        std::fprintf(stderr, "\nmlcg: %s; stopping every other process\n", out_.failed.c_str());
        abort_all();
      }
    }
    return running;
  }

  // A swap the launcher was asked for, and the user's interrupts (a second one stops at once).
  void handle_requests() {
    const bool quiet_stop = !out_.interrupted && !out_.stopped_for_swap && !aborting_;
    if (quiet_stop && opt_.want_stop && opt_.want_stop()) {
      out_.stopped_for_swap = true;
      stop_at_checkpoint();
    }
    if (take_signal() == 0) return;
    if (!out_.interrupted && !aborting_) {
      out_.stopped_for_swap = false;  // the user's stop wins: no swap
      out_.interrupted = true;
      std::fprintf(stderr, "\nmlcg: interrupted: every level writes a consistent checkpoint at the next coupling "
                           "interval, then stops (interrupt again to stop at once)\n");
      stop_at_checkpoint();
    } else if (!aborting_) {
      std::fprintf(stderr, "\nmlcg: stopping every process now\n");
      abort_all();
    }
  }

  void enforce_deadlines() {
    // The coupler is gone (it stopped the levels or failed): whoever is left gets a few seconds.
    if ((out_.interrupted || out_.stopped_for_swap) && !aborting_ && members_[0].done && give_up_ > after(10.0))
      give_up_ = after(10.0);
    if (!aborting_ && Clock::now() > give_up_) {
      std::fprintf(stderr, "\nmlcg: the stop with a consistent checkpoint did not finish; stopping every process\n");
      abort_all();
    }
    if (Clock::now() > kill_at_) {
      stop_all(SIGKILL);
      kill_at_ = Clock::time_point::max();
    }
  }

  const char* phase() const {
    return out_.interrupted ? "stopping" : aborting_ ? "failing" : out_.stopped_for_swap ? "swapping" : "running";
  }

  Outcome finish() {
    for (const auto& m : members_) kill(-m.pid, SIGKILL);  // no process of the attempt outlives it
    end_strays(opt_.kill_grace);
    // The run reached its end before the stop: nothing to swap.
    if (out_.stopped_for_swap && coupler_code_ == 0 && out_.failed.empty()) out_.stopped_for_swap = false;
    if (out_.interrupted && out_.exit_code == 0) out_.exit_code = 130;
    return out_;
  }

 private:
  // The coupler stops the hierarchy at the next consistent checkpoint.
  void stop_at_checkpoint() {
    if (!members_[0].done) kill(-members_[0].pid, SIGINT);
    give_up_ = after(opt_.interrupt_grace);
  }
  void stop_all(int sig) {
    for (auto& m : members_)
      if (!m.done) {
        kill(-m.pid, sig);
        if (sig != SIGKILL) kill(-m.pid, SIGCONT);  // a stopped (hung) process handles the signal only when woken
        m.state = "stopping";
      }
  }
  void abort_all() {
    aborting_ = true;
    stop_all(SIGTERM);
    kill_at_ = after(opt_.kill_grace);
  }

  std::vector<Member>& members_;
  const SuperviseOptions& opt_;
  Outcome out_;
  bool aborting_ = false;
  int coupler_code_ = -1;
  Clock::time_point give_up_ = Clock::time_point::max(), kill_at_ = Clock::time_point::max();
};

}  // namespace

Outcome supervise(std::vector<Member>& members, const SuperviseOptions& opt) {
  catch_signals();
  take_signal();
  become_subreaper();
  Attempt a(members, opt);
  a.start();
  while (a.reap() > 0) {
    a.handle_requests();
    a.enforce_deadlines();
    if (opt.tick) opt.tick(members, a.phase());
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  return a.finish();
}

}  // namespace mlcg::launcher
