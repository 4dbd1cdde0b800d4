#include "plan/throughput.hpp"

#include <stdlib.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <thread>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "run/checkpoints.hpp"
#include "io/atomic_file.hpp"
#include "process/process.hpp"

namespace fs = std::filesystem;

namespace mlcg::launcher {
namespace {

// The scene: beads of the quickstart (4 mm, E = 25 MPa, its dt) on a simple cubic lattice, touching,
// in a box of five plane walls: every particle has its neighbours from step 1, like a hopper's bed
// (2.8 neighbour pairs per particle here, 4.2 over the quickstart's run; both measured 8-9e6
// particle-steps/s per CPU second on this machine).
constexpr int kSide = 16;       // 4,096 particles
constexpr int kSteps = 1000;
constexpr double kRadius = 2e-3, kDt = 1.2e-5;

std::string plane(const char* name, double px, double py, double nx, double ny, double nz) {
  return fmt::format("[[walls]]\nname = \"{}\"\ntype = \"plane\"\nmaterial = \"beads\"\npoint = [{}, {}, 0.0]\n"
                     "normal = [{}, {}, {}]\n", name, px, py, nx, ny, nz);
}

std::string today_utc() {
  const std::time_t now = std::time(nullptr);
  char stamp[32];
  std::strftime(stamp, sizeof stamp, "%Y-%m-%d %H:%M UTC", std::gmtime(&now));
  return stamp;
}

// "<path>|<mtime ns>|<cores>": a rebuilt binary or another machine is measured again.
std::string cache_key(const std::string& dem_level) {
  std::error_code ec;
  const fs::path p = fs::weakly_canonical(dem_level, ec);
  const auto t = fs::last_write_time(p, ec);
  return fmt::format("{}|{}|{}", p.string(), ec ? 0 : t.time_since_epoch().count(),
                     std::thread::hardware_concurrency());
}

// Runs dem_level on the scene in a temporary folder (removed afterwards); its particle-steps/s.
double measure(const std::string& dem_level, std::string& why) {
  std::string tmpl = (fs::temp_directory_path() / "mlcg-calibrate-XXXXXX").string();
  if (!mkdtemp(tmpl.data())) {
    why = "cannot create a temporary folder for the calibration";
    return 0.0;
  }
  const fs::path dir(tmpl);
  std::ofstream(dir / "calibration.toml") << calibration_case_text();
  std::fprintf(stderr, "mlcg: measuring this machine's throughput (dem_level, %d particles, %d steps)...\n",
               kSide * kSide * kSide, kSteps);
  GroupResult r;
  try {  // a missing binary costs the wall time, not the check
    const pid_t pid = spawn({dem_level, (dir / "calibration.toml").string(), "--out", (dir / "run").string(), "--quiet"});
    r = wait_group({{"dem_level", pid}});
  } catch (const std::exception& e) {
    r.exit_code = 127;
    std::fprintf(stderr, "mlcg: %s\n", e.what());
  }
  const auto s = read_json_or_null(dir / "run" / "summary.json");
  double rate = 0.0;
  if (r.exit_code == 0 && s.is_object() && s.contains("levels") && !s["levels"].empty())
    rate = s["levels"][0].value("particle_steps_per_second", 0.0);
  if (!(rate > 0.0)) why = fmt::format("the calibration run of {} failed (exit code {})", dem_level, r.exit_code);
  std::error_code ec;
  fs::remove_all(dir, ec);
  return rate;
}

}  // namespace

std::string calibration_case_text() {
  const double s = 2.0 * kRadius, side = kSide * s;
  std::string t = fmt::format(
      "title = \"mlcg check: throughput calibration\"\nseed = 1\ngravity = [0.0, 0.0, -9.81]\n"
      "[[materials]]\nname = \"beads\"\nyoungs_modulus = 2.5e7\npoisson_ratio = 0.25\ndensity = 1000.0\n"
      "[[interactions]]\nbetween = [\"beads\", \"beads\"]\nrestitution = 0.5\nfriction = 0.2\n"
      "[[levels]]\nname = \"main\"\ndt = {}\n[domain]\nmin = [0.0, 0.0, 0.0]\nmax = [{}, {}, {}]\n",
      kDt, side, side, 2.0 * side);
  t += plane("floor", 0.0, 0.0, 0.0, 0.0, 1.0) + plane("x0", 0.0, 0.0, 1.0, 0.0, 0.0) +
       plane("x1", side, 0.0, -1.0, 0.0, 0.0) + plane("y0", 0.0, 0.0, 0.0, 1.0, 0.0) +
       plane("y1", 0.0, side, 0.0, -1.0, 0.0);
  t += fmt::format("[time]\nend = {}\n[output]\nstats_interval = {}\n", kSteps * kDt, kSteps * kDt / 4.0);
  for (int k = 0; k < kSide; ++k)
    for (int j = 0; j < kSide; ++j)
      for (int i = 0; i < kSide; ++i)
        t += fmt::format("[[particles]]\nmaterial = \"beads\"\nradius = {}\nposition = [{}, {}, {}]\n", kRadius,
                         (i + 0.5) * s, (j + 0.5) * s, (k + 0.5) * s);
  return t;
}

std::string throughput_cache_file() {
  if (const char* x = std::getenv("XDG_CACHE_HOME"); x && *x) return (fs::path(x) / "mlcg" / "throughput.json").string();
  const char* home = std::getenv("HOME");
  return (fs::path(home && *home ? home : "/tmp") / ".cache" / "mlcg" / "throughput.json").string();
}

std::optional<Throughput> machine_throughput(const std::string& dem_level, Calibration how, std::string& why) {
  const fs::path file = throughput_cache_file();
  const std::string key = cache_key(dem_level);
  nlohmann::json cache = read_json_or_null(file);
  if (!cache.is_object()) cache = nlohmann::json::object();
  if (how != Calibration::Force && cache.contains(key) && cache[key].value("particle_steps_per_second", 0.0) > 0.0)
    return Throughput{cache[key]["particle_steps_per_second"].get<double>(), cache[key].value("measured", "?"), true};
  if (how == Calibration::Skip) {
    why = "calibration skipped and no measurement cached in " + file.string() + " (`mlcg check --calibrate`)";
    return std::nullopt;
  }
  const double rate = measure(dem_level, why);
  if (!(rate > 0.0)) return std::nullopt;
  Throughput t{rate, today_utc(), false};
  cache[key] = {{"particle_steps_per_second", rate}, {"measured", t.measured},
                {"scene", fmt::format("{} particles, {} steps", kSide * kSide * kSide, kSteps)}};
  try {  // a cache that cannot be written costs a measurement next time, nothing else
    fs::create_directories(file.parent_path());
    io::write_file_atomic(file, cache.dump(2) + "\n");
  } catch (const std::exception& e) {
    std::fprintf(stderr, "warning: cannot cache the throughput in %s: %s\n", file.c_str(), e.what());
  }
  return t;
}

}  // namespace mlcg::launcher
