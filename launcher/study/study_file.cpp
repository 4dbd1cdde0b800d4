#include "study/study_file.hpp"

#include <algorithm>
#include <cstdint>
#include <fstream>
#include <optional>
#include <set>
#include <sstream>

#include <fmt/format.h>
#include <toml++/toml.h>

#include "config/case_keys.hpp"
#include "config/case_schema.hpp"
#include "config/case_parser.hpp"
#include "run/run_case.hpp"

namespace fs = std::filesystem;

namespace mlcg::launcher {
namespace {

std::string join(const std::vector<std::string>& v) {
  std::string s;
  for (const auto& w : v) s += (s.empty() ? "" : ", ") + w;
  return s;
}

int line_of(const toml::node& n) { return static_cast<int>(n.source().begin.line); }

// Messages name the study file, the line and the key path ("sweep[0].key").
struct Reader {
  std::string file;
  [[noreturn]] void fail(int line, const std::string& key, const std::string& what) const {
    throw StudyError(fmt::format("{}:{}: {}: {}", file, line, key, what));
  }
  void allow(const toml::table& t, const std::string& path, const std::vector<std::string>& allowed) const {
    for (const auto& [k, v] : t)
      if (std::find(allowed.begin(), allowed.end(), k.str()) == allowed.end())
        fail(line_of(v), path.empty() ? std::string(k.str()) : path + "." + std::string(k.str()),
             config::unknown_key(k.str(), allowed));
  }
  std::optional<std::string> str(const toml::table& t, const std::string& path, const char* k) const {
    const toml::node* n = t.get(k);
    if (!n) return std::nullopt;
    if (!n->is_string()) fail(line_of(*n), path + k, "expected a string");
    return n->value<std::string>();
  }
  // A required string key: missing or empty -> "required: DOC" (its declared doc).
  std::string required(const toml::table& t, const std::string& path, const config::schema::KeySpec& k) const {
    const std::string name(k.name);
    auto s = str(t, path, name.c_str());
    if (!s || s->empty()) fail(line_of(t), path + name, "required: " + std::string(k.doc));
    return *s;
  }
};

// A variant or sweep name becomes a folder name.
void check_name(const Reader& r, int line, const std::string& key, const std::string& name) {
  const bool ok = std::all_of(name.begin(), name.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.';
  });
  if (!ok || name.front() == '.') r.fail(line, key, "'" + name + "' is not a folder name; use letters, digits, _ - .");
}

std::string value_text(const toml::node& v) {
  if (auto i = v.value_exact<int64_t>()) return std::to_string(*i);
  if (auto d = v.value_exact<double>()) return fmt::format("{:g}", *d);
  if (auto s = v.value_exact<std::string>()) return *s;
  if (const auto* a = v.as_array()) {
    std::vector<std::string> items;
    for (const auto& e : *a) items.push_back(value_text(e));
    return "[" + join(items) + "]";
  }
  std::ostringstream ss;
  v.visit([&](const auto& x) { ss << x; });  // a table as TOML
  return ss.str();
}

// "levels.fine.dt_alpha1", "coupling.regions[0].max", "levels.1.alpha": table keys, and
// array entries by their `name` or by index.
std::vector<std::string> split_key(const std::string& key) {
  std::vector<std::string> out;
  std::string cur;
  for (char c : key) {
    if (c == '.' || c == '[') {
      if (!cur.empty()) out.push_back(cur);
      cur.clear();
    } else if (c != ']') {
      cur += c;
    }
  }
  if (!cur.empty()) out.push_back(cur);
  return out;
}

std::optional<size_t> as_index(const std::string& s) {
  if (s.empty() || !std::all_of(s.begin(), s.end(), [](char c) { return std::isdigit(static_cast<unsigned char>(c)); }))
    return std::nullopt;
  return static_cast<size_t>(std::stoul(s));
}

// Sets `key` of the case `doc` to `value`; missing tables on the way are created (the case parser
// then refuses a key it does not know). Errors are std::string messages for the caller to place.
void set_key(toml::table& doc, const std::string& key, const toml::node& value, const std::string& base_name) {
  const auto parts = split_key(key);
  if (parts.empty()) throw std::string("empty key");
  toml::node* cur = &doc;
  std::string path;
  for (size_t i = 0; i < parts.size(); ++i) {
    const std::string& p = parts[i];
    const bool last = i + 1 == parts.size();
    if (auto* t = cur->as_table()) {
      if (last) {
        t->insert_or_assign(p, value);
        return;
      }
      if (!t->contains(p)) t->insert(p, toml::table{});
      cur = t->get(p);
    } else if (auto* a = cur->as_array()) {
      std::vector<std::string> names;
      toml::node* hit = nullptr;
      size_t hit_index = 0;
      for (size_t e = 0; e < a->size(); ++e) {
        const auto* et = a->get(e)->as_table();
        const std::string n = et && et->get("name") ? et->get("name")->value_or(std::string()) : std::string();
        if (!n.empty()) names.push_back(n);
        if ((!n.empty() && n == p) || as_index(p) == e) hit = a->get(e), hit_index = e;
      }
      if (!hit)
        throw fmt::format("'{}' selects no entry of {} in {}; give a name ({}) or an index 0-{}", p, path, base_name,
                          names.empty() ? "none has one" : join(names), a->size() == 0 ? 0 : a->size() - 1);
      if (last) {
        a->replace(a->cbegin() + static_cast<long>(hit_index), value);
        return;
      }
      cur = hit;
    } else {
      throw fmt::format("'{}' in {} is a value, not a table; '{}' cannot be inside it", path, base_name, p);
    }
    path += (path.empty() ? "" : ".") + p;
  }
}

// A derived case lives in the study folder: files the base names relative to its own folder
// (mesh walls, the initial snapshot) are made absolute so they still resolve.
void absolutize_files(toml::table& doc, const fs::path& base_dir) {
  auto fix = [&](toml::table* t) {
    if (!t) return;
    if (auto f = (*t)["file"].value<std::string>(); f && fs::path(*f).is_relative())
      t->insert_or_assign("file", (base_dir / *f).lexically_normal().string());
  };
  if (auto* walls = doc["walls"].as_array())
    for (auto& w : *walls) fix(w.as_table());
  fix(doc["initial"].as_table());
}

// A variant file's case is its base chain resolved: what its run folder keeps, so a change to a base
// counts as a change of the case.
void add_case(const Reader& r, int line, const std::string& key, Variant& v) {
  try {
    v.case_text = config::resolved_case_text(v.case_file);
    v.seed = config::parse_case(v.case_text, v.case_file).seed;
  } catch (const config::CaseError& e) {
    r.fail(line, key, std::string("the case is refused: ") + e.what());
  }
}

// A TOML file, refused as the case parser refuses text the TOML reader cannot take safely (a study file
// of a 100,000-part key overflowed its stack).
toml::table parse_toml(const fs::path& file) {
  const std::string text = read_text(file);
  config::check_toml_text(text, file.string());
  return toml::parse(text, file.string());
}

// The base case of derived ones, its relative files made absolute; a syntax error is the study's, at `line`.
toml::table read_base(const Reader& r, int line, const std::string& key, const fs::path& base) {
  toml::table doc;
  try {
    doc = toml::parse(config::resolved_case_text(base.string()), base.string());  // a variant laid over its base
  } catch (const toml::parse_error& e) {
    r.fail(line, key, fmt::format("{}:{}: TOML syntax error: {}", base.string(), e.source().begin.line, e.description()));
  } catch (const config::CaseError& e) {
    r.fail(line, key, e.what());
  }
  absolutize_files(doc, fs::absolute(base).parent_path());
  return doc;
}

// A derived case's text says where it comes from, so a user opening cases/ knows.
std::string derived_text(const fs::path& base, const std::string& change, const toml::table& doc) {
  std::ostringstream ss;
  ss << "# derived by `mlcg study` from " << fs::absolute(base).lexically_normal().string() << " with " << change
     << "\n\n"
     << doc << "\n";
  return ss.str();
}

void add_sweep(const Reader& r, const toml::table& t, const std::string& path, const fs::path& study_dir,
               const fs::path& folder, std::vector<Variant>& out) {
  using config::schema::at, config::schema::kStudySweep;
  r.allow(t, path, config::keys::kStudySweep);
  const std::string base_rel = r.required(t, path + ".", at(kStudySweep, "base"));
  const std::string key = r.required(t, path + ".", at(kStudySweep, "key"));
  const fs::path base = study_dir / base_rel;
  if (!fs::is_regular_file(base)) r.fail(line_of(*t.get("base")), path + ".base", "file not found: " + base.string());
  const auto parts = split_key(key);
  std::string name = "sweep";  // the last named part: "regions[0].max" -> "max"
  for (const auto& p : parts)
    if (!as_index(p)) name = p;
  if (auto n = r.str(t, path + ".", "name")) name = *n;
  check_name(r, line_of(t), path + ".name", name);
  const std::string label = r.str(t, path + ".", "label").value_or(name);
  const auto* values = t.get_as<toml::array>("values");
  if (!values || values->empty())
    r.fail(t.get("values") ? line_of(*t.get("values")) : line_of(t), path + ".values",
           "required: " + std::string(at(kStudySweep, "values").doc));
  const toml::table doc = read_base(r, line_of(*t.get("base")), path + ".base", base);
  const int key_line = line_of(*t.get("key"));
  for (size_t i = 0; i < values->size(); ++i) {
    Variant v;
    v.name = fmt::format("{}-{}", name, i + 1);
    v.sweep = name;
    v.sweep_key = key;
    v.sweep_value = value_text(*values->get(i));
    v.label = label + " = " + v.sweep_value;
    v.derived = true;
    v.case_file = (folder / "cases" / (v.name + ".toml")).string();
    v.run = folder / v.name;
    v.where = fmt::format("{}:{}", r.file, key_line);
    toml::table d = doc;
    try {
      set_key(d, key, *values->get(i), base.filename().string());
    } catch (const std::string& what) {
      r.fail(key_line, path + ".key", "'" + key + "': " + what);
    }
    v.case_text = derived_text(base, key + " = " + v.sweep_value, d);
    try {
      v.seed = config::parse_case(v.case_text, v.case_file).seed;
    } catch (const config::CaseError& e) {
      r.fail(key_line, path + ".key",
             fmt::format("'{}' = {} gives a case the case parser refuses: {}", key, v.sweep_value, e.what()));
    }
    out.push_back(std::move(v));
  }
}

// `replicas`: absent = 1; a whole number within its declared bounds, only with a `case` to run.
int read_replicas(const Reader& r, const toml::table& t, const std::string& path) {
  const config::schema::KeySpec& spec = config::schema::at(config::schema::kStudyVariant, "replicas");
  const toml::node* n = t.get("replicas");
  if (!n) return static_cast<int>(config::schema::default_number(spec).value_or(1.0));
  const std::string key = path + ".replicas";
  const std::string allowed = fmt::format("; allowed {} ({})", spec.allowed, spec.doc);
  const auto i = n->value_exact<int64_t>();
  if (!i)
    r.fail(line_of(*n), key,
           (n->is_number() ? value_text(*n) + " is not a whole number" : "'" + value_text(*n) + "' is not a number") +
               allowed);
  if (!spec.bounds.contains(static_cast<double>(*i)))
    r.fail(line_of(*n), key, std::to_string(*i) + " is out of range" + allowed);
  if (!t.get("case") || t.get("run"))
    r.fail(line_of(*n), key, "needs `case` and no `run`: a given run is used as it is, never run again");
  return static_cast<int>(*i);
}

// The runs of a variant with `replicas = N` (N >= 2): its case with seed = base seed + k - 1, derived
// into <study folder>/cases/<name>-r<k>.toml and run into <study folder>/<name>-r<k>/.
void add_replicas(const Reader& r, int line, const std::string& key, const Variant& v, int n,
                  const fs::path& folder, std::vector<Variant>& out) {
  if (v.seed > static_cast<uint64_t>(INT64_MAX - kMaxReplicas))
    r.fail(line, key, fmt::format("the case's seed {} leaves no room for {} seeds", v.seed, n));
  const toml::table doc = read_base(r, line, key, v.case_file);
  for (int k = 1; k <= n; ++k) {
    Variant rep = v;
    rep.replica = k;
    rep.replicas = n;
    rep.derived = true;
    rep.seed = v.seed + static_cast<uint64_t>(k - 1);
    const std::string stem = fmt::format("{}-r{}", v.name, k);
    rep.case_file = (folder / "cases" / (stem + ".toml")).string();
    rep.run = folder / stem;
    toml::table d = doc;
    d.insert_or_assign("seed", static_cast<int64_t>(rep.seed));
    rep.case_text = derived_text(v.case_file, fmt::format("seed = {} (replica {} of {})", rep.seed, k, n), d);
    try {
      config::parse_case(rep.case_text, rep.case_file);
    } catch (const config::CaseError& e) {
      r.fail(line, key, fmt::format("replica {} (seed {}) gives a case the case parser refuses: {}", k, rep.seed, e.what()));
    }
    out.push_back(std::move(rep));
  }
}

// One [[variants]] entry: a case to run (once, or once per replica) or an earlier run folder.
void add_variant(const Reader& r, const toml::table& t, const std::string& path, const fs::path& study_dir,
                 const fs::path& folder, std::vector<Variant>& out) {
  r.allow(t, path, config::keys::kStudyVariant);
  Variant v;
  v.name = r.required(t, path + ".", config::schema::at(config::schema::kStudyVariant, "name"));
  check_name(r, line_of(t), path + ".name", v.name);
  v.label = r.str(t, path + ".", "label").value_or(v.name);
  v.where = fmt::format("{}:{}", r.file, line_of(t));
  const auto c = r.str(t, path + ".", "case");
  const auto run = r.str(t, path + ".", "run");
  if (!c && !run) r.fail(line_of(t), path, "give `case` (a case file to run) or `run` (an earlier run folder)");
  v.run = run ? fs::path(*run) : folder / v.name;
  v.pointed = run.has_value();
  if (v.pointed && !fs::is_regular_file(v.run / "summary.json"))
    r.fail(line_of(*t.get("run")), path + ".run", "no summary.json in " + v.run.string() + "; give a run folder");
  if (c) {
    v.case_file = (study_dir / *c).string();
    if (!fs::is_regular_file(v.case_file))
      r.fail(line_of(*t.get("case")), path + ".case", "file not found: " + v.case_file);
    add_case(r, line_of(*t.get("case")), path + ".case", v);
  }
  if (const int n = read_replicas(r, t, path); n > 1)
    add_replicas(r, line_of(*t.get("replicas")), path + ".replicas", v, n, folder, out);
  else
    out.push_back(std::move(v));
}

// Names name one row each (a variant's replicas share its name), run folders one run each.
void check_unique(const StudySpec& s) {
  std::set<std::string> seen;
  std::set<fs::path> runs;
  for (const auto& v : s.variants) {
    if (v.replica <= 1 && !seen.insert(v.name).second) throw StudyError(v.where + ": name: '" + v.name + "' is used twice");
    if (!runs.insert(fs::absolute(v.run).lexically_normal()).second)
      throw StudyError(fmt::format("{}: variant '{}': its run folder {} is another variant's too; rename one",
                                   v.where, v.name, v.run.string()));
  }
}

// No study file: the usual files of a case folder, those present.
std::vector<Variant> default_variants(const fs::path& dir) {
  const std::pair<const char*, const char*> files[] = {{"reference.toml", "reference"},
                                                       {"cg2.toml", "coarse grain α = 2"},
                                                       {"mlcg.toml", "MLCG"},
                                                       {"mlcg_no_pi.toml", "MLCG without PI"}};
  std::vector<Variant> out;
  for (const auto& [f, label] : files) {
    std::string file = f;
    if (out.empty() && file == "reference.toml" && !fs::exists(dir / file)) file = "case.toml";
    if (!fs::exists(dir / file)) continue;
    Variant v;
    v.name = fs::path(file).stem().string();
    v.label = label;
    v.case_file = (dir / file).string();
    v.where = v.case_file;
    out.push_back(std::move(v));
  }
  if (out.empty() || (out.front().name != "reference" && out.front().name != "case"))
    throw StudyError(fmt::format("{}: no study.toml and no reference.toml or case.toml to compare against; write a "
                                 "study file (keys in cases/README.md)", dir.string()));
  return out;
}

// The study compares one probe's discharge: every case to run must have it. A hierarchy's
// regions must pass the region rules before anything of the study runs.
void check_probes(const StudySpec& s) {
  for (const auto& v : s.variants) {
    if (v.case_text.empty()) continue;
    const auto cs = config::parse_case(v.case_text, v.case_file);
    try {
      check_regions(cs);
    } catch (const std::runtime_error& e) {
      throw StudyError(fmt::format("{}: variant '{}': {}", v.where, v.name, e.what()));
    }
    const bool found = std::any_of(cs.probes.begin(), cs.probes.end(),
                                   [&](const auto& p) { return s.probe.empty() || p.name == s.probe; });
    if (!found)
      throw StudyError(fmt::format("{}: variant '{}': {} has no [[probes]] entry{}; the study compares a probe's "
                                   "discharge",
                                   v.where, v.name, v.case_file, s.probe.empty() ? "" : " named '" + s.probe + "'"));
  }
}

}  // namespace

std::string read_text(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

StudySpec load_study(const fs::path& case_dir, const std::string& study_file, bool explicit_file,
                     const std::string& out) {
  StudySpec s;
  const fs::path dir_name = fs::weakly_canonical(fs::absolute(case_dir)).filename();
  s.folder = out.empty() ? fs::path("runs") / ("study-" + dir_name.string()) : fs::path(out);
  if (!fs::exists(study_file)) {
    if (explicit_file) throw StudyError(study_file + ": study file not found");
    s.variants = default_variants(case_dir);
    s.reference = s.variants.front().name;
    for (auto& v : s.variants) {
      v.run = s.folder / v.name;
      add_case(Reader{v.case_file}, 1, "case", v);
    }
    check_probes(s);
    return s;
  }
  s.file = study_file;
  const Reader r{study_file};
  toml::table doc;
  try {
    doc = parse_toml(study_file);
  } catch (const toml::parse_error& e) {
    r.fail(static_cast<int>(e.source().begin.line), "TOML syntax error", std::string(e.description()));
  } catch (const config::CaseError& e) {
    throw StudyError(e.what());
  }
  r.allow(doc, "", config::keys::kStudy);
  s.title = r.str(doc, "", "title").value_or("");
  if (auto f = r.str(doc, "", "folder"); f && out.empty()) s.folder = *f;
  s.probe = r.str(doc, "", "probe").value_or("");
  const fs::path study_dir = fs::path(study_file).parent_path();
  if (const auto* n = doc.get("variants"); n && !n->is_array_of_tables())
    r.fail(line_of(*n), "variants", "expected [[variants]] entries");
  if (const auto* vs = doc.get_as<toml::array>("variants")) {
    for (size_t i = 0; i < vs->size(); ++i)
      add_variant(r, *vs->get(i)->as_table(), fmt::format("variants[{}]", i), study_dir, s.folder, s.variants);
  }
  if (const auto* n = doc.get("sweep")) {
    if (const auto* t = n->as_table()) {
      add_sweep(r, *t, "sweep", study_dir, s.folder, s.variants);
    } else if (n->is_array_of_tables()) {
      const auto& a = *n->as_array();
      for (size_t i = 0; i < a.size(); ++i)
        add_sweep(r, *a.get(i)->as_table(), fmt::format("sweep[{}]", i), study_dir, s.folder, s.variants);
    } else {
      r.fail(line_of(*n), "sweep", "expected a [sweep] table or [[sweep]] entries");
    }
  }
  if (s.variants.empty()) r.fail(1, "variants", "the study lists no variant; give [[variants]] or a [sweep]");
  check_unique(s);
  s.reference = r.str(doc, "", "reference").value_or(s.variants.front().name);
  if (std::none_of(s.variants.begin(), s.variants.end(), [&](const Variant& v) { return v.name == s.reference; }))
    r.fail(line_of(*doc.get("reference")), "reference", "no variant is named '" + s.reference + "'");
  // The reference's runs (all its replicas) first, the others in the file's order.
  std::stable_partition(s.variants.begin(), s.variants.end(), [&](const Variant& v) { return v.name == s.reference; });
  check_probes(s);
  return s;
}

}  // namespace mlcg::launcher
