// cases/README.md and the parser agree on the keys (issue 15): every key a table of a case or a study
// file allows (config/case_keys.hpp, the lists the reader's unknown-key check uses) appears in the key
// tables of that table's section of the document, and every key those tables list is allowed; each key
// row's type and default cells are the text of the key's declaration (config/case_schema*.hpp), from which the
// reader takes its default; and its allowed cell states the bounds the reader enforces (the declaration's
// Bounds, read back from the cell as numbers) and, for a string key, exactly the choices the reader accepts.
#include <gtest/gtest.h>

#include <map>
#include <optional>
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

// One table of the document (outside code blocks): the section heading (## or ###) above it, its header
// cells, and its rows as column name -> cell.
struct DocTable {
  std::string section;
  std::vector<std::string> header;
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

std::vector<DocTable> doc_tables() {
  const std::string readme = mlcg::test::slurp(std::string(MLCG_SOURCE_DIR) + "/cases/README.md");
  static const std::regex heading(R"(^#{2,3} (.*)$)");
  std::vector<DocTable> out;
  std::string section, line;
  bool in_table = false, in_code = false;
  std::istringstream in(readme);
  while (std::getline(in, line)) {
    if (line.rfind("```", 0) == 0) in_code = !in_code;
    std::smatch m;
    if (in_code) continue;
    if (std::regex_match(line, m, heading)) section = m[1];
    if (line.rfind("|", 0) != 0 || section.empty()) {
      in_table = false;
      continue;
    }
    const auto cells = cells_of(line);
    if (!in_table) {
      out.push_back({section, cells, {}});
      in_table = true;
    } else if (!cells.empty() && cells[0].rfind("---", 0) != 0) {
      std::map<std::string, std::string> row;
      for (size_t c = 0; c < out.back().header.size() && c < cells.size(); ++c) row[out.back().header[c]] = cells[c];
      out.back().rows.push_back(row);
    }
  }
  return out;
}

// Section -> the keys its tables list in their first column.
std::map<std::string, Keys> documented() {
  std::map<std::string, Keys> out;
  for (const DocTable& t : doc_tables())
    for (const auto& row : t.rows) {
      const auto first = row.find(t.header.empty() ? std::string() : t.header[0]);
      if (first == row.end()) continue;
      const Keys k = keys_in_cell(first->second);
      if (!k.empty()) out[t.section].insert(k.begin(), k.end());
    }
  return out;
}

// Where the document describes each declared table: its section, and which of that section's key tables
// (those whose first header cell is `key`; -1: only named in the first column of another table, as the
// radius forms are).
struct Documented {
  std::string section;
  int key_table;
  std::vector<schema::Keys> keys;
};

const std::vector<Documented>& documents() {
  using namespace schema;
  static const std::vector<Documented> d{
      {"Top level", 0, {kTop}},
      {"`[[materials]]`", 0, {kMaterial}},
      {"`[[interactions]]`", 0, {kInteraction}},
      {"`[contact]`", 0, {kContact}},
      {"`[[levels]]`", 0, {kLevel}},
      {"`[domain]`", 0, {kDomain}},
      {"`[[walls]]`", 0, {kWall}},
      {"`[[walls]]`", 1, {kPlane}},
      {"`[[walls]]`", 2, {kCylinder, kCone, kDisk}},
      {"`[[walls]]`", 3, {kMesh}},
      {"`[[insertion]]`", 0, {kInsertion}},
      {"`[[insertion]]`", 1, {kBoxRegion, kCylinderRegion}},
      {"`[[insertion]]`", -1, {kRadiusDistribution}},
      {"`[[particles]]`", 0, {kParticle}},
      {"`[initial]`", 0, {kInitial}},
      {"`[orifice]`", 0, {kOrifice}},
      {"`[[events]]`", 0, {kEvent}},
      {"`[[probes]]`", 0, {kProbe}},
      {"`[[grids]]`", 0, {kGrid}},
      {"`[output]`", 0, {kOutput}},
      {"`[stability]`", 0, {kStability}},
      {"`[limits]`", 0, {kLimits}},
      {"`[time]`", 0, {kTime}},
      {"`[time]`", 1, {kEndAfterEvent}},
      {"`[coupling]`", 0, {kCoupling}},
      {"`[launcher]`", 0, {kLauncher}},
      {"`[[swap]]`", 0, {kSwap}},
      {"`[[coupling.regions]]`", 0, {kCouplingRegion}},
      {"Study files (`mlcg study`)", 0, {kStudy}},
      {"Study files (`mlcg study`)", 1, {kStudyVariant}},
      {"Study files (`mlcg study`)", 2, {kStudySweep}},
  };
  return d;
}

// The document's section of each table, and what the parser allows there.
std::map<std::string, Keys> allowed() {
  std::map<std::string, Keys> out;
  for (const Documented& d : documents())
    for (schema::Keys keys : d.keys)
      for (const schema::KeySpec& k : keys) out[d.section].insert(std::string(k.name));
  return out;
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

// The declarations each key table documents: (section, index among its key tables) -> lists.
std::map<std::pair<std::string, int>, std::vector<schema::Keys>> declarations() {
  std::map<std::pair<std::string, int>, std::vector<schema::Keys>> out;
  for (const Documented& d : documents())
    if (d.key_table >= 0) out[{d.section, d.key_table}] = d.keys;
  return out;
}

// The tables whose first header cell is `key`, with their index among their section's key tables.
std::vector<std::pair<DocTable, int>> key_tables() {
  std::vector<std::pair<DocTable, int>> out;
  std::map<std::string, int> count;
  for (DocTable& t : doc_tables())
    if (!t.header.empty() && t.header[0] == "key") {
      const int index = count[t.section]++;
      out.emplace_back(std::move(t), index);
    }
  return out;
}

std::string normalised(std::string_view text) {
  return std::regex_replace(std::string(text), std::regex(R"(\s+)"), " ");
}

// The bounds an allowed cell states at its start ("> 0", "number ≥ 1", "≤ 5", "[0, 1]", "(0, 1]", "0 to 100",
// "1..20", the rest of the cell after them free); nullopt when it states none.
std::optional<schema::Bounds> stated_bounds(const std::string& cell) {
  static const std::string num = R"((-?(?:[0-9]*\.)?[0-9]+(?:e[-+]?[0-9]+)?|inf))";
  static const std::regex one("^(?:number )?(>|≥|<|≤) ?" + num + R"((?:$|[;,. ]))"),
      interval(R"(^([\[(]))" + num + ", ?" + num + R"(([\])]))"), range("^" + num + R"((?: to |\.\.))" + num + R"((?:$|[;,. ]))");
  std::smatch m;
  schema::Bounds b;
  if (std::regex_search(cell, m, one)) {
    const double v = std::stod(m[2]);
    const std::string op = m[1];
    if (op == ">" || op == "≥") b = {v, schema::kInf, op == ">", true};
    else b = {-schema::kInf, v, true, op == "<"};
  } else if (std::regex_search(cell, m, interval)) {
    b = {std::stod(m[2]), std::stod(m[3]), m[1] == "(", m[4] == ")"};
  } else if (std::regex_search(cell, m, range)) {
    b = schema::closed(std::stod(m[1]), std::stod(m[2]));
  } else {
    return std::nullopt;
  }
  return b;
}

// The string choices an allowed cell lists: every `"word"`.
std::set<std::string> stated_choices(const std::string& cell) {
  static const std::regex quoted(R"re(`"([^"`]*)"`)re");
  std::set<std::string> out;
  for (std::sregex_iterator it(cell.begin(), cell.end(), quoted), end; it != end; ++it) out.insert((*it)[1]);
  return out;
}

std::string text_of(const schema::Bounds& b) {
  if (b.lo == -schema::kInf && b.hi == schema::kInf) return "none";
  return b.text();
}

bool same(const schema::Bounds& a, const schema::Bounds& b) {
  return a.lo == b.lo && a.hi == b.hi && (a.lo_open == b.lo_open || a.lo == -schema::kInf) &&
         (a.hi_open == b.hi_open || a.hi == schema::kInf);
}

// The allowed cell of key `k` against what the reader enforces for it: its bounds (none stated for a key
// without), and for a string key with choices those choices.
void expect_allowed_is_enforced(const std::string& cell, const schema::KeySpec& k, const std::string& where) {
  const auto stated = stated_bounds(cell);
  const schema::Bounds none{};
  EXPECT_TRUE(same(stated.value_or(none), k.bounds))
      << where << ": `" << k.name << "` allowed \"" << cell << "\" states the bounds "
      << (stated ? text_of(*stated) : "none") << ", the reader enforces " << text_of(k.bounds);
  const auto choices = schema::choices(k);
  if (!choices.empty() && k.type.find("string") != std::string_view::npos) {
    EXPECT_EQ(stated_choices(cell), std::set<std::string>(choices.begin(), choices.end()))
        << where << ": `" << k.name << "` allowed \"" << cell << "\" lists other choices than the reader accepts";
  }
}

TEST(CaseKeys, TheDocumentsTypeDefaultAndAllowedCellsAreTheDeclarations) {
  const auto decl = declarations();
  size_t checked = 0;
  for (const auto& [table, index] : key_tables()) {
    const std::string where = table.section + " (key table " + std::to_string(index) + ")";
    const auto it = decl.find({table.section, index});
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
          if (row.count("allowed")) expect_allowed_is_enforced(cell("allowed"), *k, where);
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
