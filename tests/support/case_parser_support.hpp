#pragma once
// Shared by the case-parser tests: the fixture, and edits of it that must be
// refused with "FILE:LINE: KEY: what; allowed" (the expected line is found by
// searching the edited text, never hard-coded).
#include <gtest/gtest.h>

#include <algorithm>
#include <string>

#include "config/case_parser.hpp"
#include "files.hpp"

namespace case_parser_test {

using mlcg::Vec3;
using mlcg::test::slurp;
using namespace mlcg::config;

inline const std::string kFixture = std::string(MLCG_TEST_DATA) + "/cases/small_silo.toml";
inline const std::string kFixtureDir = std::string(MLCG_TEST_DATA) + "/cases";

inline const std::string& base() {
  static const std::string text = slurp(kFixture);
  return text;
}

inline int line_at(const std::string& text, size_t pos) {
  return 1 + static_cast<int>(std::count(text.begin(), text.begin() + static_cast<long>(pos), '\n'));
}

// The fixture with its only occurrence of `from` replaced by `to`. The expected
// error line is that of the first `marker` at or after the edit (or from the
// top of the file when `marker_from_top`).
struct Edit {
  std::string from, to, marker;
  bool marker_from_top = false;
};

// Parses the edited `original` and checks the message: it must start with
// "FILE:LINE: KEY: " and contain `phrase` (the explanation).
inline void expect_error_in(const std::string& original, const Edit& e, const std::string& key, const std::string& phrase) {
  std::string text = original;
  const size_t at = text.find(e.from);
  ASSERT_NE(at, std::string::npos) << "fixture lacks: " << e.from;
  ASSERT_EQ(text.find(e.from, at + 1), std::string::npos) << "fixture has more than one: " << e.from;
  text.replace(at, e.from.size(), e.to);
  const size_t m = text.find(e.marker, e.marker_from_top ? 0 : at);
  ASSERT_NE(m, std::string::npos) << "edited text lacks marker: " << e.marker;
  const std::string prefix = kFixture + ":" + std::to_string(line_at(text, m)) + ": " + key + ": ";
  try {
    parse_case(text, kFixture);
    ADD_FAILURE() << "accepted, expected an error about " << key;
  } catch (const CaseError& err) {
    const std::string msg = err.what();
    EXPECT_EQ(msg.substr(0, prefix.size()), prefix) << msg;
    EXPECT_NE(msg.find(phrase), std::string::npos) << "missing '" << phrase << "' in: " << msg;
  }
}

// The same on the fixture itself.
inline void expect_error(const Edit& e, const std::string& key, const std::string& phrase) {
  expect_error_in(base(), e, key, phrase);
}

// Shorthand: replace `from` by `to` in `original`; the error is on the line of `to`'s first line.
inline void expect_error_in(const std::string& original, const std::string& from, const std::string& to,
                     const std::string& key, const std::string& phrase) {
  expect_error_in(original, Edit{from, to, to.substr(0, to.find('\n'))}, key, phrase);
}

// Shorthand: replace `from` by `to`; the error is on the line of `to`'s first line.
inline void expect_error(const std::string& from, const std::string& to, const std::string& key, const std::string& phrase) {
  expect_error(Edit{from, to, to.substr(0, to.find('\n'))}, key, phrase);
}

inline void expect_near(const Vec3& a, const Vec3& b) {
  EXPECT_NEAR(a.x, b.x, 1e-12);
  EXPECT_NEAR(a.y, b.y, 1e-12);
  EXPECT_NEAR(a.z, b.z, 1e-12);
}

inline int fixture_line(const std::string& marker) { return line_at(base(), base().find(marker)); }

// The materials of a minimal case: one material "m", in contact with itself.
inline std::string one_material(const std::string& restitution, const std::string& friction) {
  return R"(
[[materials]]
name = "m"
youngs_modulus = 1e7
poisson_ratio = 0.25
density = 2000

[[interactions]]
between = ["m", "m"]
restitution = )" + restitution + "\nfriction = " + friction + "\n";
}

}  // namespace case_parser_test
