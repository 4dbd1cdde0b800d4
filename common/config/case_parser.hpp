#pragma once
// Reading a case file (TOML) into a CaseSpec, and refusing impossible input
// before anything is simulated. The keys each table allows are declared in config/case_keys.hpp,
// and tests/test_case_keys.cpp holds cases/README.md to exactly those.
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
// by the case (mesh walls) resolve against the folder of the file naming them.
// A variant (`base = "other.toml"` at the top level) is its base with the
// variant's keys laid over it (case_variant.cpp; cases/README.md, "Variants");
// a message about a key names the file and line it is written in.
CaseSpec load_case(const std::string& path);

// The same from text already in memory. `path_for_messages` is the file name
// used in messages and CaseSpec::path; its folder becomes CaseSpec::dir, and a
// `base` resolves against it.
CaseSpec parse_case(std::string_view toml_text, const std::string& path_for_messages);

// The case at `path` as one self-contained TOML text: the file's own bytes when it
// names no base; for a variant, the resolved tree written out (comments dropped,
// relative `file` paths made absolute). What a run folder keeps as case.toml and
// what the case hash is taken of, so a change to a base counts as a change.
std::string resolved_case_text(const std::string& path);

// Refuses TOML text the TOML reader cannot take safely, before it reads it (every TOML file MLCG reads
// goes through here): a line of more than 65,536 characters, a dotted key or table header of more than
// 64 parts (toml++ nests them without a depth limit and overflows the stack). Throws CaseError
// "FILE:LINE: what is wrong; what is allowed".
void check_toml_text(std::string_view toml_text, const std::string& path_for_messages);

}  // namespace mlcg::config
