#pragma once
// Whether run()'s steps leave a step's second half-kick to the next step's first half: one pass over the
// particle arrays per step instead of two. Both give the same numbers to the bit (ctest
// Driving.RunEqualsStepOnceBitForBit...); which is faster depends on the host's caches and the level's size
// (docs/performance.md: on the AMD hosts the fused pass paid only above about 100,000 particles per rank, on
// an Intel host with 2 MiB of L2 per core it cut the integration of 30,000 particles by 39 %). A level above
// `fuse_above` particles per rank fuses; one between `calibrate_above` and `fuse_above` times both ways on its
// first steps and keeps the faster; a smaller one (its arrays in the caches) keeps two passes.
#include <cstdint>

namespace mlcg {

class KickChoice {
 public:
  enum class Mode { Split, Fused };
  static constexpr int kBlock = 20;  // steps per timed block
  static constexpr int kRounds = 3;  // blocks of each way, alternating

  // particles: per rank; integrate_seconds: the level's integration time so far. Called once, before the
  // first step that may owe its kick.
  void start(double particles, int64_t calibrate_above, int64_t fuse_above, double integrate_seconds);
  bool started() const { return started_; }
  bool calibrating() const { return started_ && block_ < 2 * kRounds; }
  Mode mode() const;  // of the next step
  // After a calibrating step, with the level's integration seconds so far: books the step's share to its
  // block's way. True when the last block has ended: the caller then agrees on decide() over the ranks.
  bool after_step(double integrate_seconds);
  double split_seconds() const { return split_s_; }
  double fused_seconds() const { return fused_s_; }
  void decide(bool fused);
  const char* name() const { return mode() == Mode::Fused ? "fused" : "split"; }
  const char* chosen_by() const { return calibrating() ? "calibration, not finished when the run ended" : by_; }

 private:
  bool started_ = false;
  Mode mode_ = Mode::Split;
  const char* by_ = "size";
  int block_ = 2 * kRounds;  // blocks done; below 2 kRounds while calibrating
  int in_block_ = 0;
  double block_start_ = 0.0, split_s_ = 0.0, fused_s_ = 0.0;
};

inline void KickChoice::start(double particles, int64_t calibrate_above, int64_t fuse_above,
                              double integrate_seconds) {
  started_ = true;
  block_start_ = integrate_seconds;
  if (particles > static_cast<double>(fuse_above)) {
    mode_ = Mode::Fused;
  } else if (particles > static_cast<double>(calibrate_above)) {
    block_ = 0;
    by_ = "calibration";
  }
}

inline KickChoice::Mode KickChoice::mode() const {
  if (!calibrating()) return mode_;
  return block_ % 2 == 0 ? Mode::Split : Mode::Fused;
}

inline bool KickChoice::after_step(double integrate_seconds) {
  if (++in_block_ < kBlock) return false;
  (block_ % 2 == 0 ? split_s_ : fused_s_) += integrate_seconds - block_start_;
  block_start_ = integrate_seconds;
  in_block_ = 0;
  return ++block_ == 2 * kRounds;
}

inline void KickChoice::decide(bool fused) { mode_ = fused ? Mode::Fused : Mode::Split; }

}  // namespace mlcg
