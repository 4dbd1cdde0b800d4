#pragma once
// Every key of every table MLCG reads (case file, study file, hostfile) is declared once, as a KeySpec:
// its name, type, default, allowed values, one-line doc, and for numbers the bounds and unit that the
// reader checks and names in its messages. From these declarations follow
//  - the reader's unknown-key check (config::keys, case_keys.hpp) and its typed reads
//    (Table::value/optional/required/choice, case_parser_detail.hpp): the default a case gets for an
//    absent key is parsed from default_text, the choices of a string key from allowed;
//  - the bounds message ("0 is not > 0; give a positive value in s"), bounds_message() below;
//  - cases/README.md's key tables: tests/test_case_keys.cpp fails when a row's type, default or allowed
//    cell differs from the declaration's text (the texts are the document's markdown, verbatim).
// The declarations themselves: case_schema_tables.hpp (the physics and output tables),
// case_schema_scene.hpp (walls, insertion, measurements), case_schema_coupling.hpp (multi-level keys,
// the study file, the hostfile).
#include <limits>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace mlcg::config::schema {

inline constexpr double kInf = std::numeric_limits<double>::infinity();

// lo..hi with each end open or closed. An infinite value is accepted only at a closed infinite end:
// [0, inf] takes inf, (0, inf) does not. The default accepts every finite number.
struct Bounds {
  double lo = -kInf, hi = kInf;
  bool lo_open = true, hi_open = true;

  bool contains(double v) const { return (lo_open ? v > lo : v >= lo) && (hi_open ? v < hi : v <= hi); }
  bool allows_inf() const { return (lo == -kInf && !lo_open) || (hi == kInf && !hi_open); }
  std::string text() const;  // "(0, 1]", "[0, inf)"
};

inline constexpr Bounds kAny{};
inline constexpr Bounds kPositive{0.0, kInf, true, true};      // > 0
inline constexpr Bounds kNonNegative{0.0, kInf, false, true};  // >= 0
constexpr Bounds at_least(double lo) { return {lo, kInf, false, true}; }
constexpr Bounds closed(double lo, double hi) { return {lo, hi, false, false}; }

struct KeySpec {
  std::string_view name;
  std::string_view type;          // as cases/README.md's type column: "number", "integer", "vector", ...
  std::string_view default_text;  // as its default column: "`0.02`", "*required*", "—" (none), ...
  std::string_view allowed;       // as its allowed column: "> 0", "`\"none\"`, `\"cdt\"`", ...
  std::string_view doc;           // what to give, one line: "the time step in s (> 0)"
  Bounds bounds{};                // checked on every number or integer read through the declaration
  std::string_view unit{};        // as messages name it: "s", "m (0 = automatic)"
  std::string_view why{};         // appended to the bounds message: why the bound is there
};

using Keys = std::span<const KeySpec>;

// The declaration of `name` in `keys`, or nullptr.
constexpr const KeySpec* find(Keys keys, std::string_view name) {
  for (const KeySpec& k : keys)
    if (k.name == name) return &k;
  return nullptr;
}
// The declaration of `name`, which the caller knows is there (a compile error in a constant expression,
// std::logic_error otherwise).
constexpr const KeySpec& at(Keys keys, std::string_view name) {
  if (const KeySpec* k = find(keys, name)) return *k;
  throw std::logic_error("no declaration of key '" + std::string(name) + "'");
}
std::vector<std::string> names(Keys keys);

// "V is not > 0; give a positive value in UNIT", "V is negative; give a value >= 0 in UNIT",
// "V is below L UNIT; give KEY >= L", or "V is outside (lo, hi] UNIT"; then "; WHY".
std::string bounds_message(const KeySpec& k, double v);

// The default a reader gives an absent key, from default_text ("`0.02`", "`\"none\"`", "`[0, 0, 1]`",
// "`true`"); nullopt when the text is no plain value ("*required*", "—", "automatic", a formula).
std::optional<double> default_number(const KeySpec& k);
std::optional<std::string> default_string(const KeySpec& k);
std::optional<bool> default_boolean(const KeySpec& k);
std::optional<std::vector<double>> default_numbers(const KeySpec& k);
// The values a string key allows, from allowed ("`\"none\"`, `\"cdt\"`" -> none, cdt); empty = any.
std::vector<std::string> choices(const KeySpec& k);

}  // namespace mlcg::config::schema
