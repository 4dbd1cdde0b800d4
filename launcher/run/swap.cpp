#include "run/swap.hpp"

#include <algorithm>
#include <cstdio>
#include <fstream>

#include "run/checkpoints.hpp"

namespace fs = std::filesystem;

namespace mlcg::launcher {

Swapper::Swapper(const config::CaseSpec& cs, fs::path run_dir, const std::string& default_binary)
    : run_dir_(std::move(run_dir)), planned_(cs.swaps) {
  for (const auto& l : cs.levels) binary_[l.name] = default_binary;
  std::stable_sort(planned_.begin(), planned_.end(), [](const auto& a, const auto& b) { return a.at < b.at; });
}

void Swapper::poll(double sim_time) {
  if (trial_ && ++polls_ % 10 == 0) {
    try {
      const auto m = read_manifest(run_dir_);
      if (m && m->interval > trial_->interval) confirm();
    } catch (const std::exception&) {  // being replaced: next time
    }
  }
  if (wanted_) return;
  if (auto r = take_swap_request(run_dir_)) {
    if (!binary_.count(r->level) || r->binary.empty()) {
      write_swap_result(run_dir_, *r, false, "refused: no level '" + r->level + "' in this run, or no binary");
      return;
    }
    wanted_ = std::move(r);
  } else if (next_planned_ < planned_.size() && sim_time >= planned_[next_planned_].at) {
    const auto& p = planned_[next_planned_++];
    wanted_ = SwapRequest{"", p.level, p.binary};
  }
  if (wanted_)
    std::fprintf(stderr, "\nmlcg: swapping level '%s' to %s: stopping at the next consistent checkpoint\n",
                 wanted_->level.c_str(), wanted_->binary.c_str());
}

void Swapper::begin(uint64_t interval) {
  trial_ = Trial{*wanted_, binary_[wanted_->level], interval};
  binary_[wanted_->level] = wanted_->binary;
  wanted_.reset();
  polls_ = 0;
  std::fprintf(stderr, "mlcg: level '%s' continues from interval %llu with %s\n", trial_->req.level.c_str(),
               static_cast<unsigned long long>(interval), trial_->req.binary.c_str());
}

void Swapper::confirm() {
  const std::string msg = "level '" + trial_->req.level + "' runs " + trial_->req.binary + " since interval " +
                          std::to_string(trial_->interval);
  std::fprintf(stderr, "\nmlcg: swapped: %s\n", msg.c_str());
  write_swap_result(run_dir_, trial_->req, true, "swapped: " + msg);
  trial_.reset();
}

void Swapper::finish(bool completed) {
  if (trial_ && completed) confirm();
  if (wanted_) write_swap_result(run_dir_, *wanted_, false, "not swapped: the run ended before the next checkpoint");
  while (auto r = take_swap_request(run_dir_))
    write_swap_result(run_dir_, *r, false, "not swapped: the run ended");
}

std::string Swapper::refusal_in_coupler_log(const std::string& level) const {
  std::ifstream in(run_dir_ / "coupler.log");
  std::string line, found;
  const std::string key = "refused a message from '" + level + "': ";
  while (std::getline(in, line))
    if (const auto at = line.find(key); at != std::string::npos) found = line.substr(at + key.size());
  return found;
}

bool Swapper::revert(const Outcome& r) {
  if (!trial_ || r.failed_name != "level '" + trial_->req.level + "'") return false;
  const std::string why = refusal_in_coupler_log(trial_->req.level);
  const std::string msg = "refused: " + trial_->req.binary + " for level '" + trial_->req.level + "': " + r.failed +
                          (why.empty() ? "" : "; the coupler: " + why) + "; level '" + trial_->req.level +
                          "' continues with " + trial_->previous;
  std::fprintf(stderr, "mlcg: swap %s\n", msg.c_str());
  write_swap_result(run_dir_, trial_->req, false, msg);
  binary_[trial_->req.level] = trial_->previous;
  trial_.reset();
  return true;
}

}  // namespace mlcg::launcher
