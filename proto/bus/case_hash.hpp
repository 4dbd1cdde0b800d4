#pragma once
// The case identity every level and the coupler compare at registration:
// FNV-1a 64 of the case file's bytes, as 16 hex digits.
#include <filesystem>
#include <string>
#include <string_view>

namespace mlcg::bus {

std::string case_hash_of_bytes(std::string_view bytes);
// Throws std::runtime_error naming the file when it cannot be read.
std::string case_hash(const std::filesystem::path& case_file);

}  // namespace mlcg::bus
