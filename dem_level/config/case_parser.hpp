#pragma once
// Reading a case file (TOML) into a CaseSpec, and refusing impossible input
// before anything is simulated. Every key is documented in cases/README.md.
//
// Every error is a CaseError whose message reads
//     FILE:LINE: KEY: what is wrong; what is allowed
// e.g. "silo.toml:14: materials[0].poisson_ratio: 0.7 is outside [0, 0.5)".
#include <stdexcept>
#include <string>
#include <string_view>

#include "config/case_spec.hpp"

namespace mlcg::config {

struct CaseError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// Reads, parses and validates the case file at `path`. Relative files named
// by the case (mesh walls) resolve against the file's folder.
CaseSpec load_case(const std::string& path);

// The same from text already in memory. `path_for_messages` is the file name
// used in messages and CaseSpec::path; its folder becomes CaseSpec::dir.
CaseSpec parse_case(std::string_view toml_text, const std::string& path_for_messages);

// Refuses TOML text the TOML reader cannot take safely, before it reads it (every TOML file MLCG reads
// goes through here): a line of more than 65,536 characters, a dotted key or table header of more than
// 64 parts (toml++ nests them without a depth limit and overflows the stack). Throws CaseError
// "FILE:LINE: what is wrong; what is allowed".
void check_toml_text(std::string_view toml_text, const std::string& path_for_messages);

}  // namespace mlcg::config
