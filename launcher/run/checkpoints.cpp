#include "run/checkpoints.hpp"

#include <fstream>
#include <stdexcept>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "bus/checkpoint_file.hpp"
#include "io/atomic_file.hpp"
#include "io/h5.hpp"

namespace fs = std::filesystem;

namespace mlcg::launcher {
namespace {
nlohmann::json parse_file(const fs::path& p, const std::string& what) {
  std::ifstream in(p);
  if (!in) throw std::runtime_error("cannot read " + p.string() + " (" + what + ")");
  try {
    return nlohmann::json::parse(in);
  } catch (const std::exception& e) {
    throw std::runtime_error(p.string() + " is not valid JSON (" + what + "): " + e.what());
  }
}
}  // namespace

namespace {

// "string \"abc\"" or "array [1, 2]": what a field holds, for messages.
std::string describe(const nlohmann::json& v) {
  std::string text = v.dump();
  if (text.size() > 60) text = text.substr(0, 57) + "...";
  return std::string(v.type_name()) + " " + text;
}

[[noreturn]] void bad_field(const fs::path& file, const std::string& field, const nlohmann::json* found,
                            const std::string& expected) {
  throw std::runtime_error(file.string() + ": field '" + field + "' " +
                           (found ? "is " + describe(*found) : std::string("is missing")) + "; expected " + expected);
}

const nlohmann::json& field(const nlohmann::json& j, const std::string& key, const fs::path& file,
                            const std::string& name, bool (nlohmann::json::*is)() const noexcept,
                            const std::string& expected) {
  const auto it = j.find(key);
  if (it == j.end()) bad_field(file, name, nullptr, expected);
  if (!((*it).*is)()) bad_field(file, name, &*it, expected);
  return *it;
}

// A file the manifest names, relative to the checkpoints folder and inside it (no '..', no absolute
// path, no symbolic link leading out): a manifest must not load another run's state.
fs::path file_inside(const fs::path& root, const nlohmann::json& j, const std::string& key, const fs::path& file,
                     const std::string& name) {
  const std::string rel =
      field(j, key, file, name, &nlohmann::json::is_string, "a file name relative to " + root.string()).get<std::string>();
  const fs::path p = (root / rel).lexically_normal();
  const fs::path up = p.lexically_relative(root.lexically_normal());
  std::error_code ec;
  const fs::path real = fs::weakly_canonical(p, ec), real_root = fs::weakly_canonical(root, ec);
  const fs::path real_up = real.lexically_relative(real_root);
  const bool inside = !fs::path(rel).is_absolute() && !up.empty() && *up.begin() != ".." && !real_up.empty() &&
                      *real_up.begin() != "..";
  if (!inside)
    throw std::runtime_error(file.string() + ": field '" + name + "' names '" + rel + "', outside the run's "
                             "checkpoints folder " + root.string() + "; a manifest names only files of its own run");
  if (!fs::exists(p)) throw std::runtime_error(file.string() + " names " + p.string() + ", which is missing");
  return p;
}

// One consistent set: the manifest itself, or its "previous" entry (prefix "previous.").
ResumePoint read_set(const nlohmann::json& j, const fs::path& root, const fs::path& file, const std::string& prefix) {
  using J = nlohmann::json;
  ResumePoint r;
  r.interval = field(j, "interval", file, prefix + "interval", &J::is_number_unsigned,
                     "a whole number >= 0 (the first interval the resumed run runs)").get<uint64_t>();
  r.sim_time = field(j, "sim_time", file, prefix + "sim_time", &J::is_number, "the simulated time in s").get<double>();
  r.case_hash = field(j, "case_hash", file, prefix + "case_hash", &J::is_string, "the case's hash").get<std::string>();
  r.coupler = file_inside(root, j, "coupler", file, prefix + "coupler");
  const J& levels = field(j, "levels", file, prefix + "levels", &J::is_object, "an object: level name -> checkpoint file");
  for (const auto& [name, f] : levels.items()) r.levels[name] = file_inside(root, levels, name, file, prefix + "levels." + name);
  return r;
}

}  // namespace

std::optional<ResumePoint> read_manifest(const fs::path& run_dir) {
  const fs::path root = run_dir / "checkpoints", path = root / "manifest.json";
  if (!fs::exists(path)) return std::nullopt;
  const auto j = parse_file(path, "the hierarchy's consistent checkpoint");
  if (!j.is_object() || j.value("format", nlohmann::json()) != "mlcg-hierarchy-checkpoint")
    throw std::runtime_error(path.string() + " is not an MLCG hierarchy checkpoint manifest (its field 'format' is "
                             "not \"mlcg-hierarchy-checkpoint\")");
  ResumePoint r = read_set(j, root, path, "");
  if (const auto p = j.find("previous"); p != j.end() && p->is_object()) {
    try {  // an unusable previous set only means there is none to fall back on
      r.previous = std::make_shared<const ResumePoint>(read_set(*p, root, path, "previous."));
    } catch (const std::exception&) {
    }
  }
  return r;
}

std::string damage_of(const ResumePoint& set) {
  for (const auto& [name, f] : set.levels) {
    std::error_code ec;
    if (fs::file_size(f, ec) == 0 && !ec) return f.string() + " (level '" + name + "') is empty (0 bytes)";
    try {
      const io::H5Reader r(f);
      if (!r.has_attr("/", "format") || r.attr_string("/", "format") != "mlcg-level-checkpoint")
        return f.string() + " (level '" + name + "') is not an MLCG level checkpoint";
    } catch (const std::exception& e) {
      return f.string() + " (level '" + name + "') cannot be read: " + e.what();
    }
  }
  try {
    const auto c = bus::read_coupler_checkpoint(set.coupler);
    if (c.interval() != set.interval)
      return fmt::format("{} is the coupler's state of interval {}, the manifest's set is of interval {}",
                         set.coupler.string(), c.interval(), set.interval);
  } catch (const std::exception& e) {
    return e.what();
  }
  return {};
}

std::string damaged_set_advice(const ResumePoint& set, const std::string& damage, const fs::path& run_dir) {
  std::string s = fmt::format("the consistent checkpoint at interval {} (t = {:.6g} s) is damaged: {}; ", set.interval,
                              set.sim_time, damage);
  const std::string earlier = set.previous ? damage_of(*set.previous) : "";
  if (set.previous && earlier.empty())
    return s + fmt::format("the previous consistent set, interval {} (t = {:.6g} s), is intact: continue from it with "
                           "`mlcg resume {} --previous`",
                           set.previous->interval, set.previous->sim_time, run_dir.string());
  if (set.previous)
    s += fmt::format("the previous set, interval {}, is damaged too ({}); ", set.previous->interval, earlier);
  return s + "no earlier consistent set exists: start the run again with `mlcg run`";
}

void write_run_info(const fs::path& run_dir, const RunInfo& info) {
  nlohmann::json j;
  j["case"] = info.case_file;
  io::write_file_atomic(run_dir / "launcher.json", j.dump(2) + "\n");
}

RunInfo read_run_info(const fs::path& run_dir) {
  if (!fs::exists(run_dir / "launcher.json"))
    throw std::runtime_error(run_dir.string() + " is not the run folder of a multi-level run (no launcher.json)");
  const auto j = parse_file(run_dir / "launcher.json", "the run's launcher record");
  RunInfo r;
  r.case_file = field(j, "case", run_dir / "launcher.json", "case", &nlohmann::json::is_string,
                      "the case file's path").get<std::string>();
  return r;
}

nlohmann::json read_json_or_null(const fs::path& p) {
  std::ifstream in(p);
  if (!in) return nullptr;
  try {
    return nlohmann::json::parse(in);
  } catch (const std::exception&) {
    return nullptr;
  }
}

std::string probe_flow_text(const nlohmann::json& probe) {
  const auto ci = probe.find("ci95_kg_per_s");
  // significant digits: an hourglass's 2 g/s must not read "0.0019 +- 0.0002, CI +- 0.0000"
  return fmt::format("mass flow {:.4g} +- {:.2g} kg/s, mean's 95 % CI +- {}", probe.value("mean_kg_per_s", 0.0),
                     probe.value("std_kg_per_s", 0.0),
                     ci != probe.end() && ci->is_number() ? fmt::format("{:.2g} kg/s", ci->get<double>()) : "n/a");
}

}  // namespace mlcg::launcher
