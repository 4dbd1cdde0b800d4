// cases/README.md and the parser agree on the keys (issue 15): every key a table of a case or a study
// file allows (config/case_keys.hpp, the lists the reader's unknown-key check uses) appears in the key
// tables of that table's section of the document, and every key those tables list is allowed; and each
// key row's type, default and allowed cells are the text of the key's declaration (config/case_schema*.hpp),
// from which the reader takes its default, choices and bounds.
#include <gtest/gtest.h>

#include <map>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "config/case_keys.hpp"
#include "config/case_schema.hpp"
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

// ---- the key tables' type, default and allowed cells ------------------------------------------

// One key table of the document: its section, its place among that section's key tables, and its rows
// as column name -> cell.
struct KeyTable {
  std::string section;
  int index = 0;
  std::vector<std::map<std::string, std::string>> rows;
};

// The cells of a table row, split at the bars that are not escaped (`\|g\|`).
std::vector<std::string> cells_of(const std::string& line) {
  std::vector<std::string> out;
  std::string cur;
  for (size_t i = 1; i < line.size(); ++i) {
    if (line[i] == '|' && line[i - 1] != '\\') {
      out.push_back(cur);
      cur.clear();
    } else {
      cur += line[i];
    }
  }
  for (auto& c : out) c = std::regex_replace(c, std::regex(R"(^\s+|\s+$)"), "");
  return out;
}

// Every table whose header's first cell is `key`, outside code blocks.
std::vector<KeyTable> key_tables() {
  const std::string readme = mlcg::test::slurp(std::string(MLCG_SOURCE_DIR) + "/cases/README.md");
  static const std::regex heading(R"(^#{2,3} (.*)$)");
  std::vector<KeyTable> out;
  std::map<std::string, int> count;
  std::vector<std::string> header;
  std::string section, line;
  bool in_code = false;
  std::istringstream in(readme);
  while (std::getline(in, line)) {
    if (line.rfind("```", 0) == 0) in_code = !in_code;
    std::smatch m;
    if (in_code) continue;
    if (std::regex_match(line, m, heading)) section = m[1];
    if (line.rfind("|", 0) != 0) {
      header.clear();
      continue;
    }
    const auto cells = cells_of(line);
    if (header.empty() && !cells.empty() && cells[0] == "key") {
      header = cells;
      out.push_back({section, count[section]++, {}});
    } else if (!header.empty() && cells[0].rfind("---", 0) != 0) {
      std::map<std::string, std::string> row;
      for (size_t c = 0; c < header.size() && c < cells.size(); ++c) row[header[c]] = cells[c];
      out.back().rows.push_back(row);
    }
  }
  return out;
}

// The declarations each key table documents: (section, index among its key tables) -> lists.
std::map<std::pair<std::string, int>, std::vector<schema::Keys>> declarations() {
  using namespace schema;
  return {
      {{"Top level", 0}, {kTop}},
      {{"`[[materials]]`", 0}, {kMaterial}},
      {{"`[[interactions]]`", 0}, {kInteraction}},
      {{"`[contact]`", 0}, {kContact}},
      {{"`[[levels]]`", 0}, {kLevel}},
      {{"`[domain]`", 0}, {kDomain}},
      {{"`[[walls]]`", 0}, {kWall}},
      {{"`[[walls]]`", 1}, {kPlane}},
      {{"`[[walls]]`", 2}, {kCylinder, kCone, kDisk}},
      {{"`[[walls]]`", 3}, {kMesh}},
      {{"`[[insertion]]`", 0}, {kInsertion}},
      {{"`[[insertion]]`", 1}, {kBoxRegion, kCylinderRegion}},
      {{"`[[particles]]`", 0}, {kParticle}},
      {{"`[initial]`", 0}, {kInitial}},
      {{"`[orifice]`", 0}, {kOrifice}},
      {{"`[[events]]`", 0}, {kEvent}},
      {{"`[[probes]]`", 0}, {kProbe}},
      {{"`[[grids]]`", 0}, {kGrid}},
      {{"`[output]`", 0}, {kOutput}},
      {{"`[stability]`", 0}, {kStability}},
      {{"`[limits]`", 0}, {kLimits}},
      {{"`[time]`", 0}, {kTime}},
      {{"`[time]`", 1}, {kEndAfterEvent}},
      {{"`[coupling]`", 0}, {kCoupling}},
      {{"`[launcher]`", 0}, {kLauncher}},
      {{"`[[swap]]`", 0}, {kSwap}},
      {{"`[[coupling.regions]]`", 0}, {kCouplingRegion}},
      {{"Study files (`mlcg study`)", 0}, {kStudy}},
      {{"Study files (`mlcg study`)", 1}, {kStudyVariant}},
      {{"Study files (`mlcg study`)", 2}, {kStudySweep}},
  };
}

std::string normalised(std::string_view text) {
  return std::regex_replace(std::string(text), std::regex(R"(\s+)"), " ");
}

TEST(CaseKeys, TheDocumentsTypeDefaultAndAllowedCellsAreTheDeclarations) {
  const auto decl = declarations();
  size_t checked = 0;
  for (const KeyTable& table : key_tables()) {
    const std::string where = table.section + " (key table " + std::to_string(table.index) + ")";
    const auto it = decl.find({table.section, table.index});
    ASSERT_NE(it, decl.end()) << "cases/README.md: " << where << " is matched with no declaration";
    for (const auto& row : table.rows)
      for (const std::string& name : keys_in_cell(row.at("key"))) {
        std::vector<const schema::KeySpec*> found;
        for (schema::Keys keys : it->second)
          if (const auto* k = schema::find(keys, name)) found.push_back(k);
        EXPECT_FALSE(found.empty()) << where << ": `" << name << "` is documented but not declared";
        for (const schema::KeySpec* k : found) {
          const auto cell = [&](const char* column) { return normalised(row.count(column) ? row.at(column) : ""); };
          EXPECT_EQ(cell("type"), normalised(k->type)) << where << ": `" << name << "` type";
          EXPECT_EQ(cell("default"), normalised(k->default_text)) << where << ": `" << name << "` default";
          if (row.count("allowed")) {
            EXPECT_EQ(cell("allowed"), normalised(k->allowed)) << where << ": `" << name << "` allowed";
          }
          ++checked;
        }
      }
  }
  EXPECT_GT(checked, 150u) << "the document's key tables were not found";
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
