#pragma once
// Internal to the case parser (case_parser*.cpp); no other module includes this.
// `Table` wraps one TOML table together with its key path ("walls[2]") so every
// reader and every check can name FILE:LINE: KEY in its message.
#include <toml++/toml.h>

#include <cstdint>
#include <initializer_list>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "config/case_keys.hpp"
#include "config/case_schema.hpp"
#include "config/case_parser.hpp"

namespace mlcg::config::detail {

struct Doc {
  std::string file;  // the case file as named in messages
  std::string dir;   // its folder (absolute); relative files resolve here
};

// The absolute folder of the file at `path` ("x.toml" is in the current folder), without a trailing slash.
std::string folder_of(const std::string& path);

// ---- formatting -----------------------------------------------------------
std::string num(double v);                       // 0.7, 1e-06, inf
std::string vec(const Vec3& v);                  // [0, 0, 0.3]
std::string join(const std::vector<std::string>& words, std::string_view sep = ", ");
// " (did you mean 'x'?)" for the closest option by edit distance, or "".
std::string did_you_mean(std::string_view word, const std::vector<std::string>& options);
const char* type_name(const toml::node& n);      // "string", "integer", "float", ...
int line_of(const toml::node& n);

// Throws CaseError "FILE:LINE: KEY: WHAT" (": KEY" left out when key is empty).
[[noreturn]] void fail(const Doc& doc, int line, std::string_view key, const std::string& what);
[[noreturn]] void fail(const SourceLoc& at, std::string_view key, const std::string& what);
// Where a node was read: its own file (a variant's base, case_variant.cpp) or the case file.
SourceLoc loc_of(const Doc& doc, const toml::node& n);

// Refuses text the TOML reader cannot take safely (case_text_scan.cpp): a line
// longer than 65,536 characters, a dotted key or table header of more than 64 parts.
void scan_text(const Doc& doc, std::string_view text);

// The case's TOML tree (case_variant.cpp): the text parsed and, when it names a `base`, laid over its chain
// of bases. `variant` says whether it did.
struct CaseTree {
  toml::table root;
  bool variant = false;
  std::vector<std::string> bases;  // the files it varies, nearest first (empty for a plain case)
};
CaseTree read_case_tree(std::string_view text, const Doc& doc);
std::string case_file_text(const std::string& path);  // a case file's bytes, or CaseError naming why not

// ---- one table being read -------------------------------------------------
class Table {
 public:
  Table(const Doc& doc, const toml::table& t, std::string path);

  const Doc& doc() const { return *doc_; }
  const std::string& path() const { return path_; }
  std::string key(std::string_view k) const;     // path.k
  int line() const;                                // line of the table itself
  int line(std::string_view k) const;             // line of k's value; the table's if k is absent
  SourceLoc loc() const;                           // where the table itself is written
  SourceLoc loc(std::string_view k) const;        // where k's value is written; the table's if k is absent
  // The folder a relative path at k resolves against: that of the file k is written in.
  std::string folder(std::string_view k) const;
  bool has(std::string_view k) const { return node(k) != nullptr; }
  const toml::node* node(std::string_view k) const;

  [[noreturn]] void fail(std::string_view k, const std::string& what) const;  // at k's line
  [[noreturn]] void fail_table(const std::string& what) const;                // at the table's line
  [[noreturn]] void fail_missing(std::string_view k, const std::string& expected) const;

  // Refuses any key not in `allowed`, suggesting the closest allowed key.
  // `kind` names what the list belongs to, e.g. "a cylinder wall".
  void allow(const std::vector<std::string>& allowed, std::string_view kind = {}) const;

  // The same table with its keys declared (case_schema*.hpp): any other key is refused as by allow(), and
  // the readers below take a key's type, default, bounds and doc from its declaration.
  Table declared(std::initializer_list<schema::Keys> keys, std::string_view kind = {}) const;
  const schema::KeySpec& spec(std::string_view k) const;  // the declaration of k (std::logic_error if none)
  // T is double, int64_t, bool, std::string or Vec3. Numbers and integers are checked against the declared
  // bounds ("0 is not > 0; give a positive value in s").
  template <class T> std::optional<T> optional(std::string_view k) const;  // absent -> nullopt
  template <class T> T value(std::string_view k) const;                    // absent -> the declared default
  template <class T> T required(std::string_view k) const;  // absent -> "missing required key; give DOC"
  std::string choice(std::string_view k) const;  // one of the declared allowed values; absent -> the default
  std::string choice(const schema::KeySpec& k) const;  // the same for a declaration given here

  // Typed readers: absent -> nullopt (or the default); wrong type -> CaseError.
  // Integers are accepted for numbers; floats are not accepted for integers.
  std::optional<double> number(std::string_view k, bool allow_inf = false) const;
  std::optional<int64_t> integer(std::string_view k) const;
  std::optional<bool> boolean(std::string_view k) const;
  std::optional<std::string> string(std::string_view k) const;
  std::string required_string(std::string_view k, const std::string& expected) const;
  // One of `choices`; absent -> def.
  std::string choice(std::string_view k, const std::string& def, const std::vector<std::string>& choices) const;
  std::optional<Vec3> vec3(std::string_view k) const;
  Vec3 required_vec3(std::string_view k, const std::string& expected) const;
  // An array of numbers; exact_size 0 = any non-empty length.
  std::optional<std::vector<double>> numbers(std::string_view k, size_t exact_size = 0,
                                             bool allow_inf = false) const;
  std::optional<std::vector<std::string>> strings(std::string_view k, size_t exact_size = 0) const;
  std::optional<Table> table(std::string_view k) const;  // inline { } or [a.b]

  // A check at k's line that no declaration says: between keys, against other tables ("max.x = 0 is not above
  // min.x"). A key's own bounds are checked by the readers above, from its declaration.
  void check(std::string_view k, bool ok, const std::string& what) const {
    if (!ok) fail(k, what);
  }

 private:
  const Doc* doc_;
  const toml::table* t_;
  std::string path_;
  std::vector<schema::Keys> keys_;  // what declared() declared
};

template <> std::optional<double> Table::optional<double>(std::string_view k) const;
template <> std::optional<int64_t> Table::optional<int64_t>(std::string_view k) const;
template <> std::optional<bool> Table::optional<bool>(std::string_view k) const;
template <> std::optional<std::string> Table::optional<std::string>(std::string_view k) const;
template <> std::optional<Vec3> Table::optional<Vec3>(std::string_view k) const;
template <> std::string Table::required<std::string>(std::string_view k) const;

// An optional [k] table of root, or an empty one when k is absent: its keys then take their declared defaults.
Table optional_table(const Table& root, std::string_view k);

// [[key]] at the top level: every element must be a table. Absent -> empty.
std::vector<Table> array_of_tables(const Table& root, std::string_view k);

// Names that must be unique within one kind ("materials", "walls", ...).
class UniqueNames {
 public:
  explicit UniqueNames(std::string kind) : kind_(std::move(kind)) {}
  void add(const Table& t, const std::string& name);  // refuses a repeat at t's "name"
  bool contains(const std::string& name) const { return seen_.count(name) != 0; }
  const std::vector<std::string>& names() const { return order_; }

 private:
  std::string kind_;
  std::map<std::string, std::string> seen_;  // name -> "walls[0], line 12"
  std::vector<std::string> order_;           // names in file order
};

// Refuses a reference to a name that is not in `known` (at t's key k).
void check_reference(const Table& t, std::string_view k, const std::string& name, const UniqueNames& known,
                     std::string_view what);

// The names each kind of entry has defined so far, for references between tables.
struct Names {
  UniqueNames materials{"materials"}, levels{"levels"}, walls{"walls"}, events{"events"}, probes{"probes"},
      grids{"grids"};
};

// Table readers of the scene (case_parser_scene.cpp). Each reads one top-level
// key of `root` into `spec`, checking its values; they run after materials,
// levels and the domain are known.
void read_walls(const Table& root, CaseSpec& spec, Names& names);
void read_insertions(const Table& root, CaseSpec& spec, Names& names);
void read_particles(const Table& root, CaseSpec& spec, Names& names);
void read_initial(const Table& root, CaseSpec& spec, Names& names);
void read_events(const Table& root, CaseSpec& spec, Names& names);
void read_probes(const Table& root, CaseSpec& spec, Names& names);
void read_grids(const Table& root, CaseSpec& spec, Names& names);
void read_orifice(const Table& root, CaseSpec& spec);

// [coupling] and its [[coupling.regions]] (case_parser_coupling.cpp): runs after
// levels and the domain are read; resolves an automatic coupling interval.
// More than one [[levels]] entry without [coupling] is refused by the levels reader.
void read_coupling(const Table& root, CaseSpec& spec, const Names& names);
void read_launcher(const Table& root, CaseSpec& spec);

// [limits] (case_parser_limits.cpp), and the estimates checked against them once the
// whole case is read: steps to the end, files written, memory held.
void read_limits(const Table& root, CaseSpec& spec);
void check_limits(const Table& root, const CaseSpec& spec);
// An insertion without a rate asks for every particle in its first batch: refused at t's count or
// mass when they cannot fit in the space that batch fills (the batch would try for hours).
void check_batch_room(const Table& t, const InsertionSpec& in, const CaseSpec& spec, double alpha);

// min and max of a box at t's keys "min" and "max": both required, min < max in
// every axis; `what` names the box in messages ("the grid box").
void read_box(const Table& t, Vec3& lo, Vec3& hi, const std::string& what);

// Refuses a box [lo, hi] that reaches outside the domain: below it at t's key
// k_lo, above it at k_hi (the same key for a region or a point).
void check_inside_domain(const Table& t, std::string_view k_lo, std::string_view k_hi, const Vec3& lo, const Vec3& hi,
                         const DomainSpec& d);

}  // namespace mlcg::config::detail
