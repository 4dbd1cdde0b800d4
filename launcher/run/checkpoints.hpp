#pragma once
// The run folder's record of a hierarchy: launcher.json (which case, so that
// `mlcg resume RUN_DIR` needs nothing else) and checkpoints/manifest.json,
// which the coupler writes last when every level's checkpoint and its own
// state for one interval boundary are on disk (the consistent set).
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

namespace mlcg::launcher {

struct ResumePoint {
  uint64_t interval = 0;   // the first interval the resumed run runs
  double sim_time = 0.0;
  std::string case_hash;
  std::filesystem::path coupler;                       // coupler.pb
  std::map<std::string, std::filesystem::path> levels; // level name -> checkpoint
  std::shared_ptr<const ResumePoint> previous;         // the consistent set before it, kept on disk; null if none
};

// nullopt when the run has no consistent checkpoint yet. Throws std::runtime_error naming the file and
// what is wrong: unreadable, a field missing or of the wrong type, a file of the set missing or outside
// the run's checkpoints folder.
std::optional<ResumePoint> read_manifest(const std::filesystem::path& run_dir);

// "" when every file of the set reads as what it should be (level checkpoints as HDF5 level
// checkpoints, coupler.pb as the coupler's state of that interval); else what is wrong, naming the file.
std::string damage_of(const ResumePoint& set);

// The message for a damaged set: what is wrong, and the previous consistent set to continue from
// (`mlcg resume RUN --previous`) when it is intact, or that none exists.
std::string damaged_set_advice(const ResumePoint& set, const std::string& damage, const std::filesystem::path& run_dir);

struct RunInfo {
  std::string case_file;  // absolute
};
void write_run_info(const std::filesystem::path& run_dir, const RunInfo& info);
// Throws std::runtime_error when RUN_DIR is not the run folder of a hierarchy.
RunInfo read_run_info(const std::filesystem::path& run_dir);

// A JSON file of the run folder, or null when it is missing or unreadable (being replaced, not yet written).
nlohmann::json read_json_or_null(const std::filesystem::path& p);

// "mass flow M +- S kg/s, mean's 95 % CI +- H kg/s" for a summary.json probe entry; "n/a" for a
// run written before the CI was recorded.
std::string probe_flow_text(const nlohmann::json& probe);

}  // namespace mlcg::launcher
