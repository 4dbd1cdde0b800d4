#pragma once
// Settled beds the measured runs start from, prepared once by dem_level and cached with a
// fingerprint of everything they depend on; plus the small text helpers the bench shares.
#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

#include "snapshot.hpp"

namespace mlcg::bench {

void say(const std::string& s);  // one line on stdout, flushed
// Written under a temporary name and renamed, so a reader never sees half a file.
void write_text(const std::filesystem::path& f, const std::string& text);
std::string read_text(const std::filesystem::path& f);

// How to make a bed: a dem_level case that places the particles and ends when they have settled
// (an event named "settled" may mark the moment), and what identifies the result.
struct BedRecipe {
  std::string what;              // for messages, e.g. "29451 particles of r = 0.0014 m in the silo"
  std::string case_text;
  nlohmann::json fingerprint;    // a cached bed is reused only when this matches
  long particles = 0;            // the run must end with exactly these present
  double settle_speed = 0.0;     // [m/s]: the "settled" event's threshold (for the warning), 0 = none
  double settle_latest = 0.0;    // [s]: the event's latest time
};

struct Bed {
  Snapshot snap;       // the settled positions, velocities and spins set to zero
  nlohmann::json info;
};

// The bed of `recipe`, from DIR/bed.h5 when its DIR/bed.json fingerprint matches, else prepared in
// DIR/prepare (log DIR/prepare.log) and cached.
Bed prepare_bed(const BedRecipe& recipe, const std::filesystem::path& dir, const std::filesystem::path& dem_level,
                bool rebuild);

}  // namespace mlcg::bench
