// Variants: a case file that starts from another one. `base = "reference.toml"` at the top level reads
// that file first and lays this file's keys over it:
//   - a [table] of the variant merges into the base's table of that name, key by key, at any depth;
//   - every other value replaces the base's whole: a number, a string, an array, an inline table
//     { ... } and an array of tables [[...]] (so a variant's [[levels]] are all its levels).
// A base may itself be a variant; the chain ends at a file without `base` and may not return to a file
// already in it. The values keep the file and line they were read from, so a message about a key of the
// base names the base file, and a relative `file` in the base resolves against the base's folder.
#include <fmt/format.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "config/case_parser_detail.hpp"

namespace fs = std::filesystem;

namespace mlcg::config::detail {

namespace {

constexpr int kMaxChain = 16;  // a deeper chain is a mistake, not a design

bool section(const toml::node* n) { return n && n->is_table() && !n->as_table()->is_inline(); }

// Lays `over` onto `into`, moving the nodes so they keep their source (file and line).
void merge_over(toml::table& into, toml::table& over) {
  for (auto&& [k, v] : over) {
    toml::node* mine = into.get(k);
    if (section(mine) && section(&v))
      merge_over(*mine->as_table(), *v.as_table());
    else
      into.insert_or_assign(k, std::move(v));
  }
}

toml::table parse_tree(std::string_view text, const Doc& doc) {
  scan_text(doc, text);
  try {
    return toml::parse(text, std::string_view(doc.file));
  } catch (const toml::parse_error& e) {
    fail(doc, static_cast<int>(e.source().begin.line), "TOML syntax error", std::string(e.description()));
  }
}

toml::table read_tree(std::string_view text, const Doc& doc, std::vector<std::string>& chain) {
  toml::table tree = parse_tree(text, doc);
  const toml::node* base = tree.get("base");
  if (!base) return tree;
  const int line = line_of(*base);
  const std::string how = "give the case file this one varies, relative to its folder, e.g. base = \"reference.toml\"";
  const auto name = base->value<std::string>();
  if (!name) fail(doc, line, "base", std::string("expected a string, found ") + type_name(*base) + "; " + how);
  if (name->empty()) fail(doc, line, "base", "empty string; " + how);
  const fs::path rel(*name);
  const std::string path = rel.is_absolute() ? rel.lexically_normal().string()
                                             : (fs::path(doc.file).parent_path() / rel).lexically_normal().string();
  std::error_code ec;
  if (!fs::is_regular_file(path, ec))
    fail(doc, line, "base", fmt::format("'{}' is not a file ({} resolves against the folder of {}); {}", *name, path,
                                        doc.file, how));
  const std::string key = fs::weakly_canonical(path, ec).string();
  for (const std::string& seen : chain)
    if (seen == key) fail(doc, line, "base", fmt::format("{} is already in this chain of bases; a case cannot vary itself", path));
  if (static_cast<int>(chain.size()) >= kMaxChain)
    fail(doc, line, "base", fmt::format("a chain of more than {} bases; join some of them into one file", kMaxChain));
  chain.push_back(key);
  const Doc base_doc{path, folder_of(path)};
  toml::table merged = read_tree(case_file_text(path), base_doc, chain);
  tree.erase("base");
  merge_over(merged, tree);
  return merged;
}

}  // namespace

CaseTree read_case_tree(std::string_view text, const Doc& doc) {
  std::vector<std::string> chain;
  std::error_code ec;
  chain.push_back(fs::weakly_canonical(doc.file, ec).string());
  CaseTree t{read_tree(text, doc, chain), chain.size() > 1, {}};
  t.bases.assign(chain.begin() + 1, chain.end());
  return t;
}

std::string case_file_text(const std::string& path) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec))
    throw CaseError(path + ": cannot read the case file (" +
                    (fs::exists(path, ec) ? std::string("not a regular file") : std::string("no such file")) +
                    "); give the path of a .toml case file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw CaseError(path + ": cannot read the case file (" + std::strerror(errno) + ")");
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

}  // namespace mlcg::config::detail

namespace mlcg::config {

namespace {

// A relative path (a mesh wall's or [initial]'s file, a swap's binary) made absolute against the folder of
// the file it was read from.
void absolutize(toml::table& out, const toml::table& in, const std::string& case_file, const char* key = "file") {
  const toml::node* f = in.get(key);
  const auto value = f ? f->value<std::string>() : std::nullopt;
  if (!value || fs::path(*value).is_absolute()) return;
  const auto& src = f->source().path;
  const fs::path from = detail::folder_of(src ? *src : case_file);
  out.insert_or_assign(key, (from / *value).lexically_normal().string());
}

}  // namespace

std::string resolved_case_text(const std::string& path) {
  std::string text = detail::case_file_text(path);
  const detail::Doc doc{path, detail::folder_of(path)};
  const auto [tree, variant, bases] = detail::read_case_tree(text, doc);
  if (!variant) return text;
  toml::table out = tree;  // a copy drops the sources; the files are made absolute from the original
  if (const auto* walls = tree["walls"].as_array())
    for (size_t i = 0; i < walls->size(); ++i)
      if (const auto* w = walls->get(i)->as_table()) absolutize(*out["walls"][i].as_table(), *w, path);
  if (const auto* init = tree["initial"].as_table()) absolutize(*out["initial"].as_table(), *init, path);
  if (const auto* swaps = tree["swap"].as_array())
    for (size_t i = 0; i < swaps->size(); ++i)
      if (const auto* w = swaps->get(i)->as_table()) absolutize(*out["swap"][i].as_table(), *w, path, "binary");
  std::ostringstream s;
  s << "# " << fs::absolute(path).lexically_normal().string()
    << " resolved over its base by mlcg (README: cases/README.md, \"Variants\")\n\n"
    << out << "\n";
  return s.str();
}

}  // namespace mlcg::config
