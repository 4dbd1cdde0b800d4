// Consistent hierarchy checkpoints on the coupler's side (see service.hpp).
#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "io/atomic_file.hpp"
#include "service.hpp"

namespace fs = std::filesystem;

namespace mlcg::coupling {

namespace {
double wall_seconds_now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}
}  // namespace

Requests& requests() {
  static Requests r;
  return r;
}

void Service::decide_checkpoint(std::vector<bus::IntervalCommands>& cmds) {
  checkpoint_due_ = false;
  if (stopping_ || opt_.out_dir.empty()) return;  // the levels already stop after the interval before
  // Not at the case's end: the levels finish there without running another interval.
  const bool before_end = opt_.end_time < 0.0 || static_cast<double>(k_ + 1.5) * coupler_.config().interval < opt_.end_time;
  const bool periodic = opt_.checkpoint_every > 0 && (k_ + 1) % opt_.checkpoint_every == 0 && before_end;
  // A stop waits for the next periodic boundary: an uninterrupted run checkpoints (and so rebuilds
  // its neighbour lists, as a restarted level does) there too, which keeps the resumed run
  // bit-identical to it. If that boundary is far off in wall time, the next interval's will do.
  const bool stop_asked = requests().stop.load();
  if (stop_asked && stop_since_ < 0.0) stop_since_ = wall_seconds_now();
  const bool stop = stop_asked && (periodic || wall_seconds_now() - stop_since_ > kStopWaitSeconds);
  const bool asked = requests().checkpoint.exchange(false);
  if (!stop && !periodic && !asked) return;
  checkpoint_due_ = true;
  const fs::path dir = fs::absolute(opt_.out_dir) / "checkpoints" / fmt::format("i{}", k_ + 1);  // the levels create it
  for (size_t l = 0; l < cmds.size(); ++l) {
    cmds[l].set_checkpoint(true);
    cmds[l].set_checkpoint_path((dir / (peers_[l].identity + ".h5")).string());
    if (stop) {
      cmds[l].set_stop(true);
      cmds[l].set_stop_reason(fmt::format("interrupted: stopped with a consistent checkpoint at interval {}", k_ + 1));
    }
  }
  if (stop) {
    stopping_ = true;
    log_->info("stop requested: every level checkpoints and stops after interval {}{}", k_,
               periodic ? "" : " (not a periodic checkpoint boundary: the resumed run will not be bit-identical)");
  }
}

namespace {
// Copies the set the manifest names now into m["previous"] (an earlier interval only); returns its
// folder's name, or "" when there is none.
std::string keep_previous(nlohmann::json& m, const fs::path& manifest) {
  std::ifstream in(manifest);
  nlohmann::json old = nlohmann::json::parse(in, nullptr, false);
  if (!old.is_object() || !old.contains("interval") || !old["interval"].is_number_unsigned() ||
      old["interval"].get<uint64_t>() >= m["interval"].get<uint64_t>() || !old["coupler"].is_string())
    return "";
  old.erase("previous");
  old.erase("format");
  const std::string dir = fs::path(old["coupler"].get<std::string>()).parent_path().string();
  m["previous"] = std::move(old);
  return dir;
}
}  // namespace

void Service::write_checkpoint(const std::vector<bus::IntervalStats>& stats,
                               const std::vector<bus::IntervalCommands>& next) {
  checkpoint_due_ = false;
  const fs::path root = fs::absolute(opt_.out_dir) / "checkpoints";
  const std::string set = fmt::format("i{}", k_);
  nlohmann::json m;
  m["format"] = "mlcg-hierarchy-checkpoint";
  m["interval"] = k_;
  m["sim_time"] = static_cast<double>(k_) * coupler_.config().interval;
  m["case_hash"] = opt_.case_hash;
  m["levels"] = nlohmann::json::object();
  for (size_t l = 0; l < stats.size(); ++l) {
    const fs::path want = root / set / (peers_[l].identity + ".h5");
    if (stats[l].checkpoint() != want.string() || !fs::exists(want))
      throw std::runtime_error(fmt::format("level '{}' did not write the checkpoint {} asked for at interval {} "
                                           "(it reported '{}')", peers_[l].identity, want.string(), k_,
                                           stats[l].checkpoint()));
    m["levels"][peers_[l].identity] = set + "/" + want.filename().string();
  }
  bus::CouplerCheckpoint c;
  c.set_interval(k_);
  c.set_sim_time(m["sim_time"].get<double>());
  c.set_case_hash(opt_.case_hash);
  c.set_busy_seconds(busy_);
  coupler_.save(c);
  for (const auto& cmd : next) *c.add_commands() = cmd;
  io::write_file_atomic(root / set / "coupler.pb", c.SerializeAsString());
  m["coupler"] = set + "/coupler.pb";
  // The set before stays on disk, named in the manifest: if this one is damaged later (a disk
  // fault, a file cut short), the run can still continue from that one (`mlcg resume --previous`).
  const std::string previous = keep_previous(m, root / "manifest.json");
  // The log rows up to k belong to the set: on disk before the manifest names it (a coupler killed just after
  // would lose them, and a resume keeps only the rows before k that are there).
  for (size_t r = 0; r < csv_.size(); ++r)
    if (!csv_[r].flush()) {
      const fs::path csv = opt_.out_dir / "coupling" / fmt::format("region{}.csv", r);
      throw std::runtime_error(fmt::format("cannot write {}: {}", csv.string(), std::strerror(errno)));
    }
  // The manifest is renamed last: until then the previous set stays the consistent one.
  io::write_file_atomic(root / "manifest.json", m.dump(2) + "\n");
  ++checkpoints_;
  for (const auto& e : fs::directory_iterator(root)) {
    if (!e.is_directory() || e.path().filename() == set || e.path().filename() == previous) continue;
    std::error_code ec;
    fs::remove_all(e.path(), ec);
  }
  log_->info("consistent checkpoint {} at interval {} (t = {} s)", (root / "manifest.json").string(), k_,
             m["sim_time"].get<double>());
}

void Service::resume_logs() {
  for (size_t r = 0; r < coupler_.config().regions.size(); ++r) {
    const fs::path path = opt_.out_dir / "coupling" / fmt::format("region{}.csv", r);
    std::ifstream in(path);
    std::string line, kept;
    if (!std::getline(in, line)) continue;
    const auto columns = std::count(line.begin(), line.end(), ',');
    kept = line + "\n";
    // Rows of intervals at or past the resumed one are computed again; a row cut short (a full disk) is dropped.
    while (std::getline(in, line))
      if (std::count(line.begin(), line.end(), ',') == columns && std::stoull(line.substr(0, line.find(','))) < k_)
        kept += line + "\n";
    io::write_file_atomic(path, kept);
  }
}

}  // namespace mlcg::coupling
