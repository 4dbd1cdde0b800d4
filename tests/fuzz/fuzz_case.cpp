// Fuzz target: the case parser, as `mlcg run` and dem_level read a case file (config::parse_case).
// Seeds: every shipped case. Bad input must come back as a CaseError naming file, line and key;
// any other exception, crash or sanitizer report is a finding.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "config/case_parser.hpp"
#include "fuzz_support.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  // Beside the shipped meshes, so that a case naming meshes/plate.stl finds it.
  static const std::string path = mlcg::fuzz::source("cases/collision/fuzz.toml").string();
  try {
    mlcg::config::parse_case(std::string_view(reinterpret_cast<const char*>(data), size), path);
  } catch (const mlcg::config::CaseError&) {
  }
  return 0;
}
