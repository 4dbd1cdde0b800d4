#pragma once
// Swapping a level's binary during a hierarchy run (requests from `mlcg swap`
// through control.hpp, or the case's [[swap]] entries at their simulated time).
// The launcher stops the hierarchy at the next consistent checkpoint and starts
// it again from there with the level's new binary. The swap is confirmed once
// the run writes a later checkpoint (or ends); if the new binary dies first
// (e.g. the coupler refused its protocol version) the level gets its previous
// binary back and the run continues from the same checkpoint.
#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <string>

#include "config/case_spec.hpp"
#include "run/control.hpp"
#include "run/supervise.hpp"

namespace mlcg::launcher {

class Swapper {
 public:
  Swapper(const config::CaseSpec& cs, std::filesystem::path run_dir, const std::string& default_binary);
  const std::string& binary(const std::string& level) const { return binary_.at(level); }
  void poll(double sim_time);  // picks up requests, confirms a swap on trial
  bool want_stop() const { return wanted_.has_value() && !trial_; }
  void begin(uint64_t interval);  // the hierarchy stopped at `interval` for the wanted swap
  // After a failure: true when the failed process was a level on trial (it gets its previous binary back).
  bool revert(const Outcome& r);
  // The run ended: a swap on trial is confirmed when it completed; requests still waiting are answered.
  void finish(bool completed);

 private:
  struct Trial {
    SwapRequest req;
    std::string previous;
    uint64_t interval = 0;
  };
  void confirm();
  std::string refusal_in_coupler_log(const std::string& level) const;

  std::filesystem::path run_dir_;
  std::map<std::string, std::string> binary_;
  std::vector<config::SwapSpec> planned_;  // the case's, by time
  size_t next_planned_ = 0;
  std::optional<SwapRequest> wanted_;
  std::optional<Trial> trial_;
  int polls_ = 0;
};

}  // namespace mlcg::launcher
