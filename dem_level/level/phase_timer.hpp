#pragma once
// Wall-clock time for the level's reports: a monotonic clock in seconds, and a
// scope timer that adds its wall time to an accumulator.
#include <chrono>

namespace mlcg {

inline double wall_seconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

class PhaseTimer {
 public:
  explicit PhaseTimer(double& acc) : acc_(acc), t0_(std::chrono::steady_clock::now()) {}
  ~PhaseTimer() { acc_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count(); }
  PhaseTimer(const PhaseTimer&) = delete;
  PhaseTimer& operator=(const PhaseTimer&) = delete;

 private:
  double& acc_;
  std::chrono::steady_clock::time_point t0_;
};

}  // namespace mlcg
