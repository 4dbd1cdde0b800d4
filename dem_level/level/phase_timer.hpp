#pragma once
// Adds the wall time of a scope to an accumulator (seconds).
#include <chrono>

namespace mlcg {

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
