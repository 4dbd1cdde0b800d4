// coupling/progress.json: what `mlcg ps` and the launcher's progress line show
// of a running hierarchy, written (atomically) at most once per wall second.
#include <cmath>

#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "core/time_steps.hpp"
#include "io/atomic_file.hpp"
#include "service.hpp"

namespace mlcg::coupling {
namespace {
double wall_now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}
}  // namespace

void Service::write_progress(const std::vector<bus::IntervalStats>& stats, uint64_t k, bool last) {
  if (opt_.out_dir.empty()) return;
  const auto& cfg = coupler_.config();
  const double t = wall_now(), sim = static_cast<double>(k + 1) * cfg.interval;
  if (progress_wall_ < 0.0) {
    progress_wall_ = start_wall_ = t;
    start_sim_ = static_cast<double>(k) * cfg.interval;
  }
  for (size_t l = 0; l < peers_.size(); ++l) {
    peers_[l].psteps += static_cast<double>(stats[l].particles()) * static_cast<double>(whole_steps(cfg.interval, cfg.levels[l].dt));
    peers_[l].pwall += stats[l].wall_seconds();
  }
  // The levels stop at the first interval boundary at or after the end time (Level::coupling_reached).
  const bool ends = opt_.end_time >= 0.0 && static_cast<double>(k + 1) >= std::ceil(opt_.end_time / cfg.interval - 1e-6);
  if (t - progress_wall_ < 1.0 && !last && !ends) return;
  progress_wall_ = t;
  nlohmann::json j;
  j["interval"] = k;
  j["sim_time"] = sim;
  j["end_time"] = opt_.end_time;
  const double speed = (sim - start_sim_) / std::max(1e-9, t - start_wall_);  // simulated s per wall s
  j["eta_seconds"] = opt_.end_time >= 0.0 && speed > 0.0 ? std::max(0.0, (opt_.end_time - sim) / speed) : -1.0;
  j["checkpoints"] = checkpoints_;
  j["levels"] = nlohmann::json::array();
  for (size_t l = 0; l < peers_.size(); ++l) {
    Peer& p = peers_[l];
    if (p.pwall > 0.0) p.rate = p.psteps / p.pwall;
    p.psteps = p.pwall = 0.0;
    j["levels"].push_back({{"name", p.identity}, {"sim_time", stats[l].sim_time()},
                           {"particles", stats[l].particles()}, {"particle_steps_per_second", p.rate}});
  }
  try {
    io::write_file_atomic(opt_.out_dir / "coupling" / "progress.json", j.dump(1) + "\n");
  } catch (const std::exception& e) {
    log_->warn("cannot write the progress file: {}", e.what());
  }
}

}  // namespace mlcg::coupling
