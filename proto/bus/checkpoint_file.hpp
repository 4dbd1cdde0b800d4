#pragma once
// Reading the coupler's part of a consistent hierarchy checkpoint (coupler.pb)
// for the coupler that resumes from it and for the launcher that checks a set
// before starting anything. Protobuf parses an empty file as an empty message,
// so an empty or cut-short file is told apart here, by name.
#include <filesystem>

#include "mlcg/bus.pb.h"

namespace mlcg::bus {

// Throws std::runtime_error "PATH is empty (0 bytes)", "PATH is truncated or not a coupler
// checkpoint (N bytes)" or "cannot read PATH".
CouplerCheckpoint read_coupler_checkpoint(const std::filesystem::path& path);

}  // namespace mlcg::bus
