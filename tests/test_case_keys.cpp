// cases/README.md and the parser agree on the keys (issue 15): every key a table of a case or a study
// file allows (config/case_keys.hpp, the lists the reader's unknown-key check uses) appears in the key
// tables of that table's section of the document, and every key those tables list is allowed.
#include <gtest/gtest.h>

#include <map>
#include <regex>
#include <set>
#include <string>
#include <vector>

#include "config/case_keys.hpp"
#include "config/case_parser.hpp"
#include "files.hpp"

namespace {

using namespace mlcg::config;
using Keys = std::set<std::string>;

// The keys in the first cell of a table row: `a`, `b` (plain names), `[[walls]]` (a table: walls),
// `radius = { uniform = [min, max] }` (radius and uniform).
Keys keys_in_cell(const std::string& cell) {
  static const std::regex code("`([^`]+)`"), name(R"(^[a-z_][a-z0-9_]*$)"), table(R"(^\[\[?([a-z_.]+)\]\]?$)"),
      assigned(R"(([a-z_][a-z0-9_]*)\s*=)");
  Keys out;
  for (std::sregex_iterator it(cell.begin(), cell.end(), code), end; it != end; ++it) {
    const std::string c = (*it)[1];
    std::smatch m;
    if (std::regex_match(c, name)) out.insert(c);
    else if (std::regex_match(c, m, table)) out.insert(m[1]);
    else
      for (std::sregex_iterator a(c.begin(), c.end(), assigned); a != end; ++a) out.insert((*a)[1]);
  }
  return out;
}

// Section heading (## or ###) -> the keys its tables list in their first column.
std::map<std::string, Keys> documented() {
  const std::string readme = mlcg::test::slurp(std::string(MLCG_SOURCE_DIR) + "/cases/README.md");
  static const std::regex heading(R"(^#{2,3} (.*)$)"), row(R"(^\| ([^|]*) \|)");
  std::map<std::string, Keys> out;
  std::string section;
  size_t at = 0;
  bool in_code = false;
  while (at < readme.size()) {
    const size_t nl = readme.find('\n', at);
    const std::string line = readme.substr(at, nl == std::string::npos ? std::string::npos : nl - at);
    at = nl == std::string::npos ? readme.size() : nl + 1;
    if (line.rfind("```", 0) == 0) in_code = !in_code;
    std::smatch m;
    if (in_code) continue;
    if (std::regex_match(line, m, heading)) section = m[1];
    else if (!section.empty() && std::regex_search(line, m, row)) {
      const Keys k = keys_in_cell(m[1]);
      if (!k.empty()) out[section].insert(k.begin(), k.end());
    }
  }
  return out;
}

Keys all(std::initializer_list<const keys::List*> lists) {
  Keys out;
  for (const auto* l : lists) out.insert(l->begin(), l->end());
  return out;
}

// The document's section of each table, and what the parser allows there.
std::map<std::string, Keys> allowed() {
  using namespace keys;
  return {
      {"Top level", all({&kTop})},
      {"`[[materials]]`", all({&kMaterial})},
      {"`[[interactions]]`", all({&kInteraction})},
      {"`[contact]`", all({&kContact})},
      {"`[[levels]]`", all({&kLevel})},
      {"`[domain]`", all({&kDomain})},
      {"`[[walls]]`", all({&kWall, &kPlane, &kCylinder, &kCone, &kDisk, &kMesh})},
      {"`[[insertion]]`", all({&kInsertion, &kBoxRegion, &kCylinderRegion, &kRadiusDistribution})},
      {"`[[particles]]`", all({&kParticle})},
      {"`[initial]`", all({&kInitial})},
      {"`[orifice]`", all({&kOrifice})},
      {"`[[events]]`", all({&kEvent})},
      {"`[[probes]]`", all({&kProbe})},
      {"`[[grids]]`", all({&kGrid})},
      {"`[output]`", all({&kOutput})},
      {"`[stability]`", all({&kStability})},
      {"`[limits]`", all({&kLimits})},
      {"`[time]`", all({&kTime, &kEndAfterEvent})},
      {"`[coupling]`", all({&kCoupling})},
      {"`[launcher]`", all({&kLauncher})},
      {"`[[swap]]`", all({&kSwap})},
      {"`[[coupling.regions]]`", all({&kCouplingRegion})},
      {"Study files (`mlcg study`)", all({&kStudy, &kStudyVariant, &kStudySweep})},
  };
}

std::string listed(const Keys& k) {
  std::string s;
  for (const auto& x : k) s += (s.empty() ? "" : ", ") + x;
  return s;
}

TEST(CaseKeys, TheDocumentListsExactlyTheKeysTheParserAllows) {
  const auto doc = documented();
  for (const auto& [section, parser] : allowed()) {
    ASSERT_TRUE(doc.count(section)) << "cases/README.md has no section '" << section << "' with a key table";
    const Keys& written = doc.at(section);
    Keys undocumented, unknown;
    for (const auto& k : parser)
      if (!written.count(k)) undocumented.insert(k);
    for (const auto& k : written)
      if (!parser.count(k)) unknown.insert(k);
    EXPECT_TRUE(undocumented.empty()) << section << ": allowed but not in cases/README.md: " << listed(undocumented);
    EXPECT_TRUE(unknown.empty()) << section << ": in cases/README.md but not allowed: " << listed(unknown);
  }
  for (const auto& [section, written] : doc)
    EXPECT_TRUE(allowed().count(section)) << "cases/README.md section '" << section << "' lists keys ("
                                          << listed(written) << ") that no table of the parser is matched with";
}

// The lists are what the reader uses: a key outside them is refused, naming them.
TEST(CaseKeys, TheReaderRefusesAKeyOutsideItsList) {
  const std::string fixture = std::string(MLCG_TEST_DATA) + "/cases/small_silo.toml";
  std::string text = mlcg::test::slurp(fixture);
  const size_t at = text.find("[[levels]]\n");
  ASSERT_NE(at, std::string::npos);
  text.insert(at + 11, "shape = 1\n");
  std::string list;
  for (const auto& k : keys::kLevel) list += (list.empty() ? "" : ", ") + k;
  try {
    parse_case(text, fixture);
    FAIL() << "an unknown [[levels]] key was accepted";
  } catch (const CaseError& e) {
    EXPECT_NE(std::string(e.what()).find("levels[0].shape: unknown key"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(list), std::string::npos) << e.what();
  }
  // The document's example of this message lists the same keys.
  const std::string readme = mlcg::test::slurp(std::string(MLCG_SOURCE_DIR) + "/cases/README.md");
  EXPECT_NE(readme.find("levels[0].dtt: unknown key (did you mean 'dt'?); allowed keys: " + list), std::string::npos);
}

}  // namespace
