// Reading typed keys with their file position, and the shared message helpers
// of the case parser. The table readers themselves are in case_parser_tables.cpp.
#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <sstream>
#include <stdexcept>
#include <type_traits>

#include "config/case_parser_detail.hpp"

namespace mlcg::config::detail {

// ---- formatting -----------------------------------------------------------

std::string num(double v) {
  std::ostringstream s;
  s << std::setprecision(12) << v;
  return s.str();
}

std::string vec(const Vec3& v) {
  std::string s = "[";  // built by appending: GCC 12 warns falsely on "[" + std::string
  s.append(num(v.x)).append(", ").append(num(v.y)).append(", ").append(num(v.z)).append("]");
  return s;
}

std::string join(const std::vector<std::string>& words, std::string_view sep) {
  std::string out;
  for (size_t i = 0; i < words.size(); ++i) {
    if (i) out += sep;
    out += words[i];
  }
  return out;
}

namespace {

// Optimal-string-alignment distance (Levenshtein plus adjacent transpositions),
// case-insensitive: "opne" is one edit from "open".
size_t edit_distance(std::string_view a, std::string_view b) {
  auto eq = [](char x, char y) {
    return std::tolower(static_cast<unsigned char>(x)) == std::tolower(static_cast<unsigned char>(y));
  };
  std::vector<std::vector<size_t>> d(a.size() + 1, std::vector<size_t>(b.size() + 1));
  for (size_t i = 0; i <= a.size(); ++i) d[i][0] = i;
  for (size_t j = 0; j <= b.size(); ++j) d[0][j] = j;
  for (size_t i = 1; i <= a.size(); ++i)
    for (size_t j = 1; j <= b.size(); ++j) {
      d[i][j] = std::min({d[i - 1][j] + 1, d[i][j - 1] + 1, d[i - 1][j - 1] + (eq(a[i - 1], b[j - 1]) ? 0 : 1)});
      if (i > 1 && j > 1 && eq(a[i - 1], b[j - 2]) && eq(a[i - 2], b[j - 1]))
        d[i][j] = std::min(d[i][j], d[i - 2][j - 2] + 1);
    }
  return d[a.size()][b.size()];
}

}  // namespace

std::string did_you_mean(std::string_view word, const std::vector<std::string>& options) {
  const size_t limit = word.size() <= 4 ? 1 : (word.size() <= 8 ? 2 : 3);
  const std::string* best = nullptr;
  size_t best_d = limit + 1;
  for (const auto& o : options) {
    size_t d = edit_distance(word, o);
    // A clear prefix ("youngs" for "youngs_modulus") counts as close too.
    if (word.size() >= 4 && (o.rfind(word, 0) == 0 || word.rfind(o, 0) == 0)) d = std::min(d, limit);
    if (d < best_d) {
      best_d = d;
      best = &o;
    }
  }
  return best ? " (did you mean '" + *best + "'?)" : std::string();
}

const char* type_name(const toml::node& n) {
  switch (n.type()) {
    case toml::node_type::table: return "table";
    case toml::node_type::array: return "array";
    case toml::node_type::string: return "string";
    case toml::node_type::integer: return "integer";
    case toml::node_type::floating_point: return "float";
    case toml::node_type::boolean: return "boolean";
    case toml::node_type::date: return "date";
    case toml::node_type::time: return "time";
    case toml::node_type::date_time: return "date-time";
    default: return "nothing";
  }
}

int line_of(const toml::node& n) { return static_cast<int>(n.source().begin.line); }

void fail(const Doc& doc, int line, std::string_view key, const std::string& what) {
  fail(SourceLoc{doc.file, line}, key, what);
}

void fail(const SourceLoc& at, std::string_view key, const std::string& what) {
  std::string msg = at.str() + ": ";
  if (!key.empty()) msg += std::string(key) + ": ";
  throw CaseError(msg + what);
}

SourceLoc loc_of(const Doc& doc, const toml::node& n) {
  const auto& path = n.source().path;
  return {path && !path->empty() ? *path : doc.file, std::max(1, line_of(n))};
}

// ---- one value ------------------------------------------------------------

namespace {

// A number node (integer or float) as double, refusing NaN and (unless allowed) infinity.
double as_number(const Doc& doc, const toml::node& n, const std::string& key, bool allow_inf) {
  double v = 0.0;
  if (auto i = n.as_integer()) v = static_cast<double>(i->get());
  else if (auto f = n.as_floating_point()) v = f->get();
  else fail(loc_of(doc, n), key, std::string("expected a number, found ") + type_name(n));
  if (std::isnan(v)) fail(loc_of(doc, n), key, "nan is not allowed; give a finite number");
  if (std::isinf(v) && !allow_inf) fail(loc_of(doc, n), key, num(v) + " is not allowed; give a finite number");
  return v;
}

std::string as_string(const Doc& doc, const toml::node& n, const std::string& key) {
  if (auto s = n.as_string()) return s->get();
  fail(loc_of(doc, n), key, std::string("expected a string, found ") + type_name(n));
}

const toml::array& as_array(const Doc& doc, const toml::node& n, const std::string& key, size_t exact_size,
                            std::string_view of_what) {
  const std::string expected =
      exact_size ? "an array of " + std::to_string(exact_size) + " " + std::string(of_what)
                 : "an array of " + std::string(of_what);
  const toml::array* a = n.as_array();
  if (!a) fail(loc_of(doc, n), key, "expected " + expected + ", found " + type_name(n));
  if (exact_size && a->size() != exact_size)
    fail(loc_of(doc, n), key,
         "expected " + expected + ", found " + std::to_string(a->size()) + " element" + (a->size() == 1 ? "" : "s"));
  if (!exact_size && a->empty()) fail(loc_of(doc, n), key, "expected " + expected + ", found an empty array");
  return *a;
}

}  // namespace

// ---- Table ----------------------------------------------------------------

Table::Table(const Doc& doc, const toml::table& t, std::string path) : doc_(&doc), t_(&t), path_(std::move(path)) {}

std::string Table::key(std::string_view k) const {
  if (path_.empty()) return std::string(k);
  return path_ + "." + std::string(k);
}

int Table::line() const { return std::max(1, line_of(*t_)); }

SourceLoc Table::loc() const { return loc_of(*doc_, *t_); }

SourceLoc Table::loc(std::string_view k) const {
  const toml::node* n = node(k);
  return n ? loc_of(*doc_, *n) : loc();
}

std::string Table::folder(std::string_view k) const {
  const SourceLoc at = loc(k);
  return at.file == doc_->file ? doc_->dir : folder_of(at.file);
}

std::string folder_of(const std::string& path) {
  namespace fs = std::filesystem;
  fs::path parent = fs::path(path).parent_path();
  if (parent.empty()) parent = ".";
  std::string dir = fs::absolute(parent).lexically_normal().string();
  while (dir.size() > 1 && dir.back() == '/') dir.pop_back();
  return dir;
}


int Table::line(std::string_view k) const {
  const toml::node* n = node(k);
  return n ? line_of(*n) : line();
}

const toml::node* Table::node(std::string_view k) const { return t_->get(k); }

void Table::fail(std::string_view k, const std::string& what) const { detail::fail(loc(k), key(k), what); }

void Table::fail_table(const std::string& what) const { detail::fail(loc(), path_, what); }

void Table::fail_missing(std::string_view k, const std::string& expected) const {
  detail::fail(loc(), key(k), "missing required key; give " + expected);
}

void Table::allow(const std::vector<std::string>& allowed, std::string_view kind) const {
  // Report the first unknown key in file order (the table itself is sorted by name).
  const toml::key* first = nullptr;
  for (auto&& [k, v] : *t_) {
    (void)v;
    if (std::find(allowed.begin(), allowed.end(), k.str()) != allowed.end()) continue;
    if (!first || k.source().begin < first->source().begin) first = &k;
  }
  if (!first) return;
  const auto& src = first->source();
  detail::fail(SourceLoc{src.path && !src.path->empty() ? *src.path : doc_->file, static_cast<int>(src.begin.line)},
               key(first->str()), unknown_key(first->str(), allowed, kind));
}

std::optional<double> Table::number(std::string_view k, bool allow_inf) const {
  const toml::node* n = node(k);
  if (!n) return std::nullopt;
  return as_number(*doc_, *n, key(k), allow_inf);
}

std::optional<int64_t> Table::integer(std::string_view k) const {
  const toml::node* n = node(k);
  if (!n) return std::nullopt;
  if (auto i = n->as_integer()) return i->get();
  fail(k, std::string("expected an integer, found ") + type_name(*n));
}

std::optional<bool> Table::boolean(std::string_view k) const {
  const toml::node* n = node(k);
  if (!n) return std::nullopt;
  if (auto b = n->as_boolean()) return b->get();
  fail(k, std::string("expected a boolean (true or false), found ") + type_name(*n));
}

std::optional<std::string> Table::string(std::string_view k) const {
  const toml::node* n = node(k);
  if (!n) return std::nullopt;
  return as_string(*doc_, *n, key(k));
}

std::string Table::required_string(std::string_view k, const std::string& expected) const {
  if (!has(k)) fail_missing(k, expected);
  std::string s = *string(k);
  if (s.empty()) fail(k, "empty string; give " + expected);
  return s;
}

std::string Table::choice(std::string_view k, const std::string& def, const std::vector<std::string>& choices) const {
  const auto s = string(k);
  if (!s) return def;
  if (std::find(choices.begin(), choices.end(), *s) == choices.end())
    fail(k, "'" + *s + "' is not allowed" + did_you_mean(*s, choices) + "; allowed: " + join(choices));
  return *s;
}

std::optional<Vec3> Table::vec3(std::string_view k) const {
  auto v = numbers(k, 3);
  if (!v) return std::nullopt;
  return Vec3{(*v)[0], (*v)[1], (*v)[2]};
}

Vec3 Table::required_vec3(std::string_view k, const std::string& expected) const {
  if (!has(k)) fail_missing(k, expected);
  return *vec3(k);
}

std::optional<std::vector<double>> Table::numbers(std::string_view k, size_t exact_size, bool allow_inf) const {
  const toml::node* n = node(k);
  if (!n) return std::nullopt;
  const toml::array& a = as_array(*doc_, *n, key(k), exact_size, "numbers");
  std::vector<double> out;
  for (size_t i = 0; i < a.size(); ++i)
    out.push_back(as_number(*doc_, *a.get(i), key(k) + "[" + std::to_string(i) + "]", allow_inf));
  return out;
}

std::optional<std::vector<std::string>> Table::strings(std::string_view k, size_t exact_size) const {
  const toml::node* n = node(k);
  if (!n) return std::nullopt;
  const toml::array& a = as_array(*doc_, *n, key(k), exact_size, "strings");
  std::vector<std::string> out;
  for (size_t i = 0; i < a.size(); ++i) out.push_back(as_string(*doc_, *a.get(i), key(k) + "[" + std::to_string(i) + "]"));
  return out;
}

std::optional<Table> Table::table(std::string_view k) const {
  const toml::node* n = node(k);
  if (!n) return std::nullopt;
  if (auto t = n->as_table()) return Table(*doc_, *t, key(k));
  fail(k, std::string("expected a table, found ") + type_name(*n));
}

// ---- reading through the declaration ----------------------------------------

Table Table::declared(std::initializer_list<schema::Keys> keys, std::string_view kind) const {
  Table out = *this;
  out.keys_.assign(keys.begin(), keys.end());
  std::vector<std::string> allowed;
  for (schema::Keys list : keys)
    for (const schema::KeySpec& k : list) allowed.emplace_back(k.name);
  allow(allowed, kind);
  return out;
}

const schema::KeySpec& Table::spec(std::string_view k) const {
  for (schema::Keys list : keys_)
    if (const schema::KeySpec* s = schema::find(list, k)) return *s;
  throw std::logic_error("the reader of " + (path_.empty() ? std::string("the top level") : path_) +
                         " asks for key '" + std::string(k) + "', which its declaration lacks");
}

template <>
std::optional<double> Table::optional<double>(std::string_view k) const {
  const schema::KeySpec& s = spec(k);
  const auto v = number(k, s.bounds.allows_inf());
  if (v && !s.bounds.contains(*v)) fail(k, schema::bounds_message(s, *v));
  return v;
}

template <>
std::optional<int64_t> Table::optional<int64_t>(std::string_view k) const {
  const schema::KeySpec& s = spec(k);
  const auto v = integer(k);
  if (v && !s.bounds.contains(static_cast<double>(*v))) fail(k, schema::bounds_message(s, static_cast<double>(*v)));
  return v;
}

template <>
std::optional<bool> Table::optional<bool>(std::string_view k) const {
  spec(k);
  return boolean(k);
}

template <>
std::optional<std::string> Table::optional<std::string>(std::string_view k) const {
  spec(k);
  return string(k);
}

template <>
std::optional<Vec3> Table::optional<Vec3>(std::string_view k) const {
  spec(k);
  return vec3(k);
}

namespace {

// The declared default of k as T; a declaration without one is the reader's mistake, not the case's.
template <class T>
T declared_default(const schema::KeySpec& k) {
  std::optional<T> v;
  if constexpr (std::is_same_v<T, double>) v = schema::default_number(k);
  else if constexpr (std::is_same_v<T, int64_t>) {
    if (const auto d = schema::default_number(k)) v = static_cast<int64_t>(*d);
  } else if constexpr (std::is_same_v<T, bool>) v = schema::default_boolean(k);
  else if constexpr (std::is_same_v<T, std::string>) v = schema::default_string(k);
  else if (const auto n = schema::default_numbers(k); n && n->size() == 3) v = Vec3{(*n)[0], (*n)[1], (*n)[2]};
  if (!v) throw std::logic_error("key '" + std::string(k.name) + "' declares no default value: " +
                                 std::string(k.default_text));
  return *v;
}

}  // namespace

template <class T>
T Table::value(std::string_view k) const {
  if (auto v = optional<T>(k)) return *v;
  return declared_default<T>(spec(k));
}

template <class T>
T Table::required(std::string_view k) const {
  if (!has(k)) fail_missing(k, std::string(spec(k).doc));
  return *optional<T>(k);
}

template <>
std::string Table::required<std::string>(std::string_view k) const {
  return required_string(k, std::string(spec(k).doc));
}

template double Table::value<double>(std::string_view) const;
template int64_t Table::value<int64_t>(std::string_view) const;
template bool Table::value<bool>(std::string_view) const;
template std::string Table::value<std::string>(std::string_view) const;
template Vec3 Table::value<Vec3>(std::string_view) const;
template double Table::required<double>(std::string_view) const;
template int64_t Table::required<int64_t>(std::string_view) const;
template Vec3 Table::required<Vec3>(std::string_view) const;

std::string Table::choice(std::string_view k) const { return choice(spec(k)); }

std::string Table::choice(const schema::KeySpec& k) const {
  return choice(k.name, schema::default_string(k).value_or(""), schema::choices(k));
}

Table optional_table(const Table& root, std::string_view k) {
  static const toml::table empty;
  if (auto t = root.table(k)) return *t;
  return Table(root.doc(), empty, root.key(k));
}

std::vector<Table> array_of_tables(const Table& root, std::string_view k) {
  std::vector<Table> out;
  const toml::node* n = root.node(k);
  if (!n) return out;
  const toml::array* a = n->as_array();
  if (!a)
    root.fail(k, std::string("expected an array of tables ([[") + root.key(k) + "]]), found " + type_name(*n));
  for (size_t i = 0; i < a->size(); ++i) {
    const toml::node& e = *a->get(i);
    const std::string path = root.key(k) + "[" + std::to_string(i) + "]";
    const toml::table* t = e.as_table();
    if (!t) fail(loc_of(root.doc(), e), path, std::string("expected a table, found ") + type_name(e));
    out.emplace_back(root.doc(), *t, path);
  }
  return out;
}

// ---- names ----------------------------------------------------------------

void UniqueNames::add(const Table& t, const std::string& name) {
  auto it = seen_.find(name);
  if (it != seen_.end())
    t.fail("name", "duplicate name '" + name + "' (also " + it->second + "); every entry of [[" + kind_ +
                       "]] needs its own name");
  seen_.emplace(name, t.path() + ", line " + std::to_string(t.line("name")));
  order_.push_back(name);
}

void check_reference(const Table& t, std::string_view k, const std::string& name, const UniqueNames& known,
                     std::string_view what) {
  if (known.contains(name)) return;
  const auto names = known.names();
  t.fail(k, "unknown " + std::string(what) + " '" + name + "'" + did_you_mean(name, names) + "; known: " +
                (names.empty() ? std::string("none") : join(names)));
}

}  // namespace mlcg::config::detail

namespace mlcg::config {

std::string unknown_key(std::string_view key, const std::vector<std::string>& allowed, std::string_view kind) {
  const std::string where = kind.empty() ? std::string() : " for " + std::string(kind);
  return "unknown key" + detail::did_you_mean(key, allowed) + "; allowed keys" + where + ": " + detail::join(allowed);
}

}  // namespace mlcg::config
