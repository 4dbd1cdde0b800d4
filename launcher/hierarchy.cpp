#include "hierarchy.hpp"

#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "io/atomic_file.hpp"
#include "process.hpp"

namespace fs = std::filesystem;

namespace mlcg::launcher {
namespace {

// ipc:// paths must stay under ~107 characters; fall back to /tmp.
std::string bus_endpoint(const fs::path& run_dir) {
  const std::string p = (fs::absolute(run_dir) / "bus.ipc").string();
  if (p.size() < 100) return "ipc://" + p;
  return fmt::format("ipc:///tmp/mlcg-bus-{}.ipc", getpid());
}

// The level with the smallest alpha: its data are the best resolved.
size_t finest_level(const config::CaseSpec& cs) {
  size_t finest = 0;
  for (size_t l = 0; l < cs.levels.size(); ++l)
    if (cs.levels[l].alpha < cs.levels[finest].alpha) finest = l;
  return finest;
}

nlohmann::json read_json(const fs::path& p) {
  std::ifstream in(p);
  if (!in) return nlohmann::json::object();
  try {
    return nlohmann::json::parse(in);
  } catch (const std::exception&) {
    return nlohmann::json::object();
  }
}

// One summary over the hierarchy: every level's entry, the finest level's
// probes (data at the highest resolution available), overall status.
void write_summary(const config::CaseSpec& cs, const fs::path& run_dir, const GroupResult& r) {
  nlohmann::json s;
  s["case"] = cs.path;
  s["title"] = cs.title;
  s["status"] = r.exit_code == 0 ? "completed" : (r.interrupted ? "interrupted" : "failed");
  s["reason"] = r.failed.empty() ? "" : r.failed + " exited with code " + std::to_string(r.exit_code);
  s["levels"] = nlohmann::json::array();
  double wall = 0.0;
  const size_t finest = finest_level(cs);
  for (size_t l = 0; l < cs.levels.size(); ++l) {
    const auto j = read_json(run_dir / "levels" / cs.levels[l].name / "summary.json");
    nlohmann::json e = j.contains("levels") && !j["levels"].empty() ? j["levels"][0] : nlohmann::json::object();
    e["name"] = cs.levels[l].name;
    e["wall_seconds"] = j.value("wall_seconds", 0.0);
    e["status"] = j.value("status", "missing");
    e["mass_balance"] = j.value("mass_balance", nlohmann::json::object());
    wall = std::max(wall, j.value("wall_seconds", 0.0));
    s["simulated_time"] = j.value("simulated_time", 0.0);
    s["levels"].push_back(e);
  }
  const auto fine = read_json(run_dir / "levels" / cs.levels[finest].name / "summary.json");
  s["probes"] = fine.value("probes", nlohmann::json::array());
  s["probes_from_level"] = cs.levels[finest].name;
  s["wall_seconds"] = wall;
  // Coupling overhead: the largest level share of coupling work plus the coupler's busy time,
  // over the run's wall time; waiting on the coupler (the levels' different pace) reported apart.
  const auto cpl = read_json(run_dir / "coupling" / "summary.json");
  double work = 0.0, wait = 0.0;
  for (const auto& e : s["levels"]) {
    if (!e.contains("performance")) continue;
    work = std::max(work, e["performance"]["seconds"].value("coupling", 0.0));
    wait = std::max(wait, e["performance"]["seconds"].value("coupling_wait", 0.0));
  }
  const double busy = cpl.value("coupler_busy_seconds", 0.0);
  s["coupling"] = cpl;
  s["coupling"]["overhead_share"] = wall > 0.0 ? (work + busy) / wall : 0.0;
  s["coupling"]["level_coupling_seconds_max"] = work;
  s["coupling"]["level_wait_seconds_max"] = wait;
  io::write_file_atomic(run_dir / "summary.json", s.dump(2) + "\n");
}

}  // namespace

int run_hierarchy(const config::CaseSpec& cs, const std::string& case_file, const std::string& out_dir, bool quiet,
                  Placement placement) {
  const fs::path run_dir(out_dir);
  std::string ep = !cs.coupling->endpoint.empty() ? cs.coupling->endpoint : bus_endpoint(run_dir);
  ep = placement.prepare(cs, run_dir, ep);  // hosts / CURVE hook (hosts.hpp)
  const fs::path bin(own_directory());
  std::printf("mlcg: case %s, %zu levels coupled over %s; run folder %s\n%s", case_file.c_str(), cs.levels.size(),
              ep.c_str(), out_dir.c_str(), placement.describe().c_str());
  std::vector<NamedChild> children;
  std::vector<std::string> coupler = placement.launch_prefix("coupler", 1);
  coupler.insert(coupler.end(), {(bin / "coupler_service").string(), case_file, "--out", out_dir, "--endpoint", ep});
  if (quiet) coupler.push_back("--quiet");
  for (auto& a : placement.extra_args("coupler")) coupler.push_back(a);
  children.push_back({"coupler", spawn(coupler)});
  ep = placement.bound_endpoint(children.back().pid);  // tcp://HOST:* resolved to the coupler's port
  // Progress lines come from the finest level; the others write their logs only.
  const size_t finest = finest_level(cs);
  for (size_t l = 0; l < cs.levels.size(); ++l) {
    const auto& lvl = cs.levels[l];
    std::vector<std::string> argv = placement.launch_prefix(lvl.name, lvl.ranks);
    argv.push_back((bin / "dem_level").string());
    argv.insert(argv.end(), {case_file, "--out", (run_dir / "levels" / lvl.name).string(), "--level", lvl.name,
                             "--coupler", ep});
    if (quiet || l != finest) argv.push_back("--quiet");
    for (auto& a : placement.extra_args(lvl.name)) argv.push_back(a);
    std::printf("mlcg: level '%s' (alpha %g, dt %g s, %d rank(s))\n", lvl.name.c_str(), lvl.alpha,
                lvl.dt, lvl.ranks);
    children.push_back({"level '" + lvl.name + "'", spawn(argv)});
  }
  std::fflush(stdout);
  const GroupResult r = wait_group(children);
  write_summary(cs, run_dir, r);
  const auto s = read_json(run_dir / "summary.json");
  std::printf("\n== %s: %s ==\n", out_dir.c_str(), s.value("status", "?").c_str());
  for (const auto& l : s["levels"])
    std::printf("level %s: alpha %g, up to %d particles, %.1f s wall, %.3g particle-steps/s\n",
                l.value("name", "?").c_str(), l.value("alpha", 0.0), l.value("particles_max", 0),
                l.value("wall_seconds", 0.0), l.value("particle_steps_per_second", 0.0));
  if (s.contains("coupling") && s["coupling"].contains("regions"))
    for (const auto& r : s["coupling"]["regions"])
      std::printf("coupling: %llu fine particles inserted (%.6g kg of %.6g kg crossed, %.3g kg carried); overhead "
                  "%.1f %% of wall time\n",
                  r.value("inserted_particles", 0ULL), r.value("inserted_kg", 0.0), r.value("crossed_kg", 0.0),
                  r.value("remainder_kg", 0.0), 100.0 * s["coupling"].value("overhead_share", 0.0));
  for (const auto& p : s["probes"])
    std::printf("probe %s (level %s): mass flow %.4f +- %.4f kg/s\n", p.value("name", "?").c_str(),
                s.value("probes_from_level", "?").c_str(), p.value("mean_kg_per_s", 0.0), p.value("std_kg_per_s", 0.0));
  if (r.exit_code != 0)
    std::fprintf(stderr, "mlcg: %s exited with code %d; every other process was stopped\n", r.failed.c_str(),
                 r.exit_code);
  return r.exit_code;
}

}  // namespace mlcg::launcher
