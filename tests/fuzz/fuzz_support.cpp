#include "fuzz_support.hpp"

#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <stdexcept>

#include "config/case_parser.hpp"
#include "level/level.hpp"

namespace fs = std::filesystem;

namespace mlcg::fuzz {
namespace {

void remove_scratch() {
  std::error_code ec;
  fs::remove_all(scratch(), ec);
}

}  // namespace

fs::path source(const std::string& relative) { return fs::path(MLCG_SOURCE_DIR) / relative; }

fs::path scratch(const std::string& sub) {
  // Never destroyed: remove_scratch runs after the destructors of statics made before it was registered.
  static const fs::path& root = *[] {
    const char* tmp = std::getenv("TMPDIR");
    const auto* r = new fs::path(fs::path(tmp && *tmp ? tmp : "/tmp") / ("mlcg-fuzz-" + std::to_string(getpid())));
    fs::create_directories(*r);
    std::atexit(remove_scratch);
    return r;
  }();
  if (sub.empty()) return root;
  fs::create_directories(root / sub);
  return root / sub;
}

void write_file(const fs::path& path, const uint8_t* data, size_t size) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  if (!out) throw std::runtime_error("fuzz: cannot write " + path.string());
}

void write_file(const fs::path& path, std::string_view text) {
  write_file(path, reinterpret_cast<const uint8_t*>(text.data()), text.size());
}

void run_level(const config::CaseSpec& cs, const fs::path& restart) {
  LevelOptions opt;
  opt.restart = restart;
  opt.quiet = true;
  opt.single_rank = true;
  try {
    Level level(cs, opt);
    level.step_once();
    level.step_once();
  } catch (const std::runtime_error&) {
  }
}

config::CaseSpec shipped_case(const std::string& relative) { return config::load_case(source(relative).string()); }

const CouplerSetup& quickstart_coupler() {
  static const CouplerSetup s = [] {
    CouplerSetup c;
    c.cs = shipped_case("cases/quickstart/mlcg.toml");
    c.cc = coupling::coupling_from_case(c.cs);
    return c;
  }();
  return s;
}

std::vector<bus::IntervalStats> plausible_stats(const coupling::Coupler& c, uint64_t k) {
  std::vector<bus::IntervalStats> st(c.config().levels.size());
  for (auto& s : st) s.set_interval(k);
  for (size_t r = 0; r < c.config().regions.size(); ++r) {
    const auto& geo = c.geometry(r);
    const auto& grid = c.config().regions[r].grid;
    const size_t bins = c.config().regions[r].planner.radius_bins.size() - 1;
    for (const bool coarse : {true, false}) {
      auto* g = st[coarse ? grid.coarse_level() : grid.fine_level()].add_grids();
      g->set_grid(static_cast<uint32_t>(r));
      for (size_t cell = 0; cell < geo.cells(); ++cell) {
        for (double s : {200.0, 200.0, 400.0, 0.0, 0.0, 0.0}) g->add_cell_stress(s);
        g->add_cell_volume_fraction(0.55);
        for (double v : {0.0, 0.0, -0.1}) g->add_cell_velocity(v);
        g->add_cell_max_speed(0.3);
      }
      if (!coarse) {
        g->set_occupants_sent(true);
        continue;
      }
      const double mass = 2e-4;  // kg per face and interval: a few fine particles
      for (size_t f = 0; f < geo.faces(); ++f) {
        Vec3 lo, hi;
        geo.face_slab(f, 0.0, lo, hi);
        const Vec3 centre = 0.5 * (lo + hi);
        g->add_face_mass(mass);
        for (double q : {0.0, 0.0, -0.1 * mass}) g->add_face_momentum(q);
        for (double q : {mass * centre.x, mass * centre.y, mass * centre.z}) g->add_face_moment(q);
        for (size_t b = 0; b < bins; ++b) g->add_face_histogram(b == 0 ? 1 : 0);
      }
    }
  }
  return st;
}

}  // namespace mlcg::fuzz
