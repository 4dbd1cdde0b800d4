#pragma once
// Requests to a running launcher: `mlcg swap` drops a small JSON file into
// RUN_DIR/control/ (atomically); the launcher picks the oldest up about every
// 50 ms and reports the outcome in RUN_DIR/control/<id>.result.json.
//
// A swap: at the next consistent checkpoint boundary every process stops; the
// hierarchy continues from that checkpoint with level L started from the new
// binary (the other levels and the coupler from theirs, at the same state).
// When the new binary fails (another protocol version: the coupler refuses its
// registration) level L is started from its previous binary instead and the
// run continues from the same checkpoint.
#include <filesystem>
#include <optional>
#include <string>

namespace mlcg::launcher {

struct SwapRequest {
  std::string id;      // file stem, for the result
  std::string level;   // level name
  std::string binary;  // absolute path
};

// `mlcg swap RUN_DIR --level L --binary PATH`: checks the request, hands it to the launcher and waits
// for the outcome. 0 when swapped, 1 when refused or the launcher is not running.
int swap_command(const std::filesystem::path& run_dir, const std::string& level, const std::string& binary);

// The launcher's side.
std::optional<SwapRequest> take_swap_request(const std::filesystem::path& run_dir);
void write_swap_result(const std::filesystem::path& run_dir, const SwapRequest& r, bool done,
                       const std::string& message);

}  // namespace mlcg::launcher
