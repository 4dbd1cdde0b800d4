#pragma once
// Reports made of message lines (the region rules' errors, warnings and notes; the outlets' notes):
// whether one contains a phrase, and all of them joined for a failing test's output.
#include <algorithm>
#include <string>
#include <vector>

namespace mlcg::test {

inline bool has(const std::vector<std::string>& lines, const std::string& phrase) {
  return std::any_of(lines.begin(), lines.end(), [&](const std::string& s) { return s.find(phrase) != std::string::npos; });
}

inline std::string all(const std::vector<std::string>& lines) {
  std::string s;
  for (const auto& m : lines) s += m + "\n";
  return s;
}

}  // namespace mlcg::test
