#include "checkpoints.hpp"

#include <fstream>
#include <stdexcept>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "io/atomic_file.hpp"

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

std::optional<ResumePoint> read_manifest(const fs::path& run_dir) {
  const fs::path root = run_dir / "checkpoints", path = root / "manifest.json";
  if (!fs::exists(path)) return std::nullopt;
  const auto j = parse_file(path, "the hierarchy's consistent checkpoint");
  if (j.value("format", "") != "mlcg-hierarchy-checkpoint")
    throw std::runtime_error(path.string() + " is not an MLCG hierarchy checkpoint manifest");
  ResumePoint r;
  r.interval = j.at("interval").get<uint64_t>();
  r.sim_time = j.at("sim_time").get<double>();
  r.case_hash = j.at("case_hash").get<std::string>();
  r.coupler = root / j.at("coupler").get<std::string>();
  for (const auto& [name, file] : j.at("levels").items()) r.levels[name] = root / file.get<std::string>();
  const auto need = [&](const fs::path& f) {
    if (!fs::exists(f)) throw std::runtime_error(path.string() + " names " + f.string() + ", which is missing");
  };
  need(r.coupler);
  for (const auto& [name, f] : r.levels) need(f);
  return r;
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
  r.case_file = j.at("case").get<std::string>();
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
  return fmt::format("mass flow {:.4f} +- {:.4f} kg/s, mean's 95 % CI +- {}", probe.value("mean_kg_per_s", 0.0),
                     probe.value("std_kg_per_s", 0.0),
                     ci != probe.end() && ci->is_number() ? fmt::format("{:.4f} kg/s", ci->get<double>()) : "n/a");
}

}  // namespace mlcg::launcher
