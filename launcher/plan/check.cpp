#include "plan/check.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <numbers>
#include <thread>

#include <fmt/format.h>

#include "config/regions.hpp"
#include "from_case.hpp"
#include "process/process.hpp"
#include "run/run_case.hpp"
#include "run/run_folder.hpp"
#include "scene/beverloo.hpp"
#include "stability/stability_preview.hpp"

namespace fs = std::filesystem;

namespace mlcg::launcher {
namespace {

// A fine region fed by the coupler holds a flowing bed: random packing, 0.55 (loose) to 0.64 (close).
constexpr double kPacking = 0.6;
// Throughput of a level on several ranks per rank: 102 % was measured on 2 ranks (README, Parallel runs);
// 0.9 leaves room for the borders of larger grids.
constexpr double kEfficiencyManyRanks = 0.9;
// The coupling's share of a hierarchy's wall time: 6-7 % measured (README, Multi-level runs).
constexpr double kCouplingOverhead = 0.10;

struct LevelCost {
  const config::LevelSpec* spec = nullptr;
  LevelPreview preview;
  double particles = 0.0;
  std::string particles_how;  // how the count was made
  double particle_steps = 0.0, cpu_seconds = 0.0;
};

// The simulated end: fixed, or an event's time; for a conditional event its earliest and latest.
struct EndTime {
  double earliest = -1.0, latest = -1.0;  // latest < 0: unbounded
  std::string how;
};

double sphere_volume(double r) { return 4.0 / 3.0 * std::numbers::pi * r * r * r; }

const config::MaterialSpec& material(const config::CaseSpec& cs, const std::string& name) {
  return *std::find_if(cs.materials.begin(), cs.materials.end(), [&](const auto& m) { return m.name == name; });
}

// As the level counts its target (Level::setup_insertions): count, or mass / mean particle mass.
double inserted_particles(const config::CaseSpec& cs, const config::InsertionSpec& in, double alpha) {
  if (in.count >= 0) return static_cast<double>(in.count);
  const double mean_mass = material(cs, in.material).density * sphere_volume(1.0) * in.radius.mean_volume_factor() *
                           alpha * alpha * alpha;
  return std::round(in.mass / mean_mass);
}

// When the last insertion has poured its particles in (at the coarsest level's alpha).
double insertions_end(const config::CaseSpec& cs, double alpha) {
  double end = 0.0;
  for (const auto& in : cs.insertions) {
    const double n = inserted_particles(cs, in, alpha);
    const double mean_mass = material(cs, in.material).density * sphere_volume(1.0) * in.radius.mean_volume_factor() *
                             alpha * alpha * alpha;
    const double rate = in.rate > 0.0 ? in.rate : in.mass_rate > 0.0 ? in.mass_rate / mean_mass : 0.0;
    end = std::max(end, in.start + (rate > 0.0 ? n / rate : 0.0));
  }
  return end;
}

EndTime end_time(const config::CaseSpec& cs, double fill_alpha) {
  if (cs.time.end >= 0.0) return {cs.time.end, cs.time.end, ""};
  for (const auto& e : cs.events) {
    if (e.name != cs.time.end_event) continue;
    const double plus = cs.time.end_plus;
    if (e.at >= 0.0) return {e.at + plus, e.at + plus, fmt::format("event '{}' at t = {:g} s", e.name, e.at)};
    const double first = e.after_insertion ? insertions_end(cs, fill_alpha) : e.check_interval;
    EndTime t{first + plus, std::isfinite(e.latest) ? e.latest + plus : -1.0, ""};
    t.how = fmt::format("event '{}' fires at t = {:.3g} s at the earliest ({}){}", e.name, first,
                        e.after_insertion ? "when the insertions end" : "its first check",
                        t.latest >= 0.0 ? fmt::format(", {:g} s at the latest", e.latest) : ", with no latest time");
    return t;
  }
  return {};
}

std::string duration_text(double s) {
  if (s < 10.0) return fmt::format("{:.2g} s", s);  // a collision scene: milliseconds
  if (s < 120.0) return fmt::format("{:.0f} s", s);
  if (s < 2.0 * 3600.0) return fmt::format("{:.0f} min", s / 60.0);
  if (s < 48.0 * 3600.0) return fmt::format("{:.1f} h", s / 3600.0);
  return fmt::format("{:.1f} days", s / 86400.0);
}

std::string diameter_text(const LevelPreview& p) {
  if (p.r_max <= 0.0) return "no particles";
  const double lo = 2e3 * p.r_min, hi = 2e3 * p.r_max;
  return lo == hi ? fmt::format("particle diameter {:.3g} mm", lo)
                  : fmt::format("particle diameter {:.3g}-{:.3g} mm", lo, hi);
}

// Mean particle volume at alpha = 1 over what the case inserts and places (number-weighted).
double mean_volume(const config::CaseSpec& cs, double fill_alpha) {
  double n = 0.0, v = 0.0;
  for (const auto& in : cs.insertions) {
    const double k = inserted_particles(cs, in, fill_alpha);
    n += k;
    v += k * sphere_volume(1.0) * in.radius.mean_volume_factor();
  }
  for (const auto& p : cs.particles) {
    n += 1.0;
    v += sphere_volume(p.radius);
  }
  return n > 0.0 ? v / n : 0.0;
}

struct RegionInfo {
  std::string coarse, fine;
  double inside_volume = 0.0;  // of the active cells, inside the walls [m^3]
};

// The coupler's grids (coupling_from_case: the coupler's own code), one line per region with the verdict
// of the region rules (none when `rules` is null). Throws std::invalid_argument as the coupler would refuse
// the case.
std::vector<RegionInfo> print_regions(const config::CaseSpec& cs, const config::RegionRuleReport* rules) {
  std::vector<RegionInfo> out;
  if (!cs.coupling) return out;
  const auto cc = coupling::coupling_from_case(cs);
  if (rules) std::printf("coupling: interval %.4g s, %zu region(s)\n", cs.coupling->interval, cc.cfg.regions.size());
  for (size_t r = 0; r < cc.cfg.regions.size(); ++r) {
    const auto& spec = cs.coupling->regions[r];
    const bus::CouplingGeometry geo(cc.cfg.regions[r].grid);
    const double h = geo.cell_size();
    RegionInfo info{spec.coarse, spec.fine, 0.0};
    size_t transition = 0;
    for (size_t c = 0; c < geo.cells(); ++c) {
      info.inside_volume += geo.inside_volume(c) * h * h * h;
      transition += geo.is_transition(c) ? 1 : 0;
    }
    out.push_back(info);
    if (!rules) continue;
    const std::string key = fmt::format("coupling.regions[{}]", r);
    const auto warnings = std::count_if(rules->warnings.begin(), rules->warnings.end(),
                                        [&](const std::string& w) { return w.find(key) != std::string::npos; });
    const auto& g = geo.grid();
    const size_t bottom = static_cast<size_t>(g.bottom_faces_size());
    std::printf("region %zu ('%s' -> '%s'): %u x %u x %u cells of %g m, %zu inside the walls (%zu transition, "
                "%zu correction), %zu boundary faces (%zu top, %zu side%s), %.3g m^3 inside; region rules: %s\n",
                r, spec.coarse.c_str(), spec.fine.c_str(), g.nx(), g.ny(), g.nz(), h, geo.cells(), transition,
                geo.cells() - transition, geo.faces(), geo.top_faces(), geo.faces() - geo.top_faces() - bottom,
                bottom > 0 ? fmt::format(", {} bottom", bottom).c_str() : "", info.inside_volume,
                warnings == 0 ? "passed" : fmt::format("passed with {} warning(s) (above)", warnings).c_str());
  }
  return out;
}

// The scene's outlets (found once: scene/outlets.hpp), each with Beverloo's rate as a sanity line, and the
// openings that are none, with the reason.
void print_outlets(const config::CaseSpec& cs, const config::OutletScan& scan) {
  std::printf("outlets: %zu %s\n", scan.outlets.size(),
              scan.given ? "given by [orifice] / [[orifices]]" : "found in the walls");
  for (const auto& o : scan.outlets) {
    std::printf("  %s\n", config::outlet_text(o).c_str());
    if (const auto b = beverloo(cs, o))
      std::printf("    Beverloo: %.4g kg/s (%s %.3g mm, d = %.3g mm, bulk density %g kg/m^3; a sanity line, not the "
                  "answer: hoppers discharge faster than the flat-bottomed bins it is for)\n",
                  b->kg_per_s, o.shape == "slot" ? "slot law, W0 =" : "circle law, D0 =", b->size * 1e3, b->d * 1e3,
                  b->rho_b);
    else if (!faces_down(o))
      std::printf("    Beverloo: no estimate (its law is for outlets in a floor; this one faces %s)\n",
                  config::vec_text(o.normal).c_str());
  }
  for (const auto& n : scan.notes) std::printf("  not an outlet: %s\n", n.c_str());
}

// The walls that move (belts, drums, moving meshes), with the speed a particle touching them meets.
void print_moving_walls(const config::CaseSpec& cs) {
  for (const auto& w : cs.walls) {
    if (w.moves_rigidly())
      std::printf("wall '%s' moves as a whole from t = 0: at %s m/s, turning at %s rad/s about the axis through %s\n",
                  w.name.c_str(), config::vec_text(w.move_velocity).c_str(),
                  config::vec_text(w.move_angular_velocity).c_str(), config::vec_text(w.move_center).c_str());
    if (!w.moving()) continue;
    if (w.angular_velocity != 0.0) {
      const double rim = w.outer_radius();
      std::printf("wall '%s' turns at %g rad/s about %s through %s (its surface at %.3g m/s at radius %g m)\n",
                  w.name.c_str(), w.angular_velocity, config::vec_text(w.axis / norm(w.axis)).c_str(),
                  config::vec_text(w.center).c_str(), w.surface_speed(), rim);
    } else {
      std::printf("wall '%s' moves its surface at %s m/s (%.3g m/s), the geometry in place\n", w.name.c_str(),
                  config::vec_text(w.surface_velocity).c_str(), norm(w.surface_velocity));
    }
  }
}

// Which level each probe is read from: the finest level whose region holds it (config/regions.hpp).
void print_probes(const config::CaseSpec& cs) {
  if (!cs.coupling) return;
  for (const auto& p : cs.probes) {
    const auto& l = cs.levels[config::resolving_level(cs, p.point)];
    std::printf("probe '%s' at [%g, %g, %g]: read from level '%s' (alpha %g)\n", p.name.c_str(), p.point.x, p.point.y,
                p.point.z, l.name.c_str(), l.alpha);
  }
}

// Particles of one level: what the case places and inserts on the level that fills the scene; on a fine
// level the coupler feeds, an estimate: its regions' volume inside the walls x packing, at most the coarse
// level's particles refined.
void count_particles(const config::CaseSpec& cs, const std::vector<RegionInfo>& regions,
                     const std::vector<LevelCost>& done, LevelCost& lc) {
  const double alpha = lc.spec->alpha;
  if (lc.preview.fills_scene) {
    double inserted = 0.0;
    for (const auto& in : cs.insertions) inserted += inserted_particles(cs, in, alpha);
    lc.particles = static_cast<double>(lc.preview.placed) + inserted;
    lc.particles_how = fmt::format("{} placed + {:.0f} inserted", lc.preview.placed, inserted);
    return;
  }
  const double each = mean_volume(cs, alpha) * alpha * alpha * alpha;
  for (const auto& r : regions) {
    if (r.fine != lc.spec->name || each <= 0.0) continue;
    const auto coarse = std::find_if(done.begin(), done.end(), [&](const LevelCost& d) { return d.spec->name == r.coarse; });
    const double room = kPacking * r.inside_volume / each;
    const double refined = coarse == done.end() ? room : coarse->particles * std::pow(coarse->spec->alpha / alpha, 3.0);
    lc.particles += std::min(room, refined);
  }
  lc.particles_how = fmt::format("an estimate: fed by the coupler; its region's volume inside the walls x packing "
                                 "{:g}, at most the coarse level's particles refined", kPacking);
}

// Every level's guard, particles and particle-steps to `end`, coarsest first (a fine level's estimate needs
// its coarse level's count). Throws StabilityError with every level's refusal: under `mlcg run` each level
// refuses on its own, and which one speaks first is a race.
std::vector<LevelCost> level_costs(const config::CaseSpec& cs, const std::vector<RegionInfo>& regions, double end) {
  std::vector<const config::LevelSpec*> order;
  for (const auto& l : cs.levels) order.push_back(&l);
  std::stable_sort(order.begin(), order.end(), [](auto* a, auto* b) { return a->alpha > b->alpha; });
  std::vector<LevelCost> out;
  std::string refused;
  for (const auto* l : order) {
    LevelCost lc;
    lc.spec = l;
    try {
      lc.preview = preview_level(cs, *l);
    } catch (const StabilityError& e) {
      refused += (refused.empty() ? "" : "\nerror: ") + std::string(e.what());
      continue;
    }
    count_particles(cs, regions, out, lc);
    lc.particle_steps = end > 0.0 ? lc.particles * end / l->dt : 0.0;
    out.push_back(std::move(lc));
  }
  if (!refused.empty()) throw StabilityError(refused);
  return out;
}

double efficiency(int ranks) { return ranks > 1 ? kEfficiencyManyRanks : 1.0; }

// Wall seconds of the case: each level at the throughput on its ranks, side by side; when the ranks
// outnumber the cores they share them. A hierarchy adds the coupling's share.
double wall_seconds(const std::vector<LevelCost>& levels, double per_core, double scale) {
  double longest = 0.0, cpu = 0.0;
  int ranks = 0;
  for (const auto& l : levels) {
    const double level_cpu = scale * l.particle_steps / (per_core * efficiency(l.spec->ranks));
    longest = std::max(longest, level_cpu / l.spec->ranks);
    cpu += level_cpu;
    ranks += l.spec->ranks;
  }
  const double cores = std::max(1u, std::thread::hardware_concurrency());
  const double wall = ranks > cores ? std::max(longest, cpu / cores) : longest;
  return levels.size() > 1 ? wall * (1.0 + kCouplingOverhead) : wall;
}

void print_levels(const config::CaseSpec& cs, const std::vector<LevelCost>& costs, double end) {
  for (const auto& l : cs.levels) {
    const auto& c = *std::find_if(costs.begin(), costs.end(), [&](const LevelCost& x) { return x.spec == &l; });
    std::printf("level '%s': alpha %g, %s, %d rank(s), dt %.4g s%s\n", l.name.c_str(), l.alpha,
                diameter_text(c.preview).c_str(), l.ranks, l.dt,
                end > 0.0 ? fmt::format(", {:.4g} steps to t = {:.4g} s", end / l.dt, end).c_str() : "");
    for (const auto& line : c.preview.stability.lines) std::printf("  %s\n", line.c_str());
    std::printf("  particles: %s%.4g (%s)\n", c.preview.fills_scene ? "" : "about ", c.particles,
                c.particles_how.c_str());
  }
}

// The estimate line(s): particle-steps and, with a throughput, the wall time.
void print_estimate(const config::CaseSpec& cs, const std::vector<LevelCost>& costs, const EndTime& end,
                    const std::optional<Throughput>& tp, const std::string& why) {
  double ps = 0.0;
  for (const auto& c : costs) ps += c.particle_steps;
  const std::string measured =
      tp ? fmt::format("measured {:.3g} particle-steps/s per core on {}{}", tp->per_core, tp->measured,
                       tp->from_cache ? ", cached" : "")
         : std::string();
  if (tp)
    std::printf("estimate: %.3g particle-steps, about %s on this machine (%s)\n", ps,
                duration_text(wall_seconds(costs, tp->per_core, 1.0)).c_str(), measured.c_str());
  else
    std::printf("estimate: %.3g particle-steps; no wall time: %s\n", ps, why.c_str());
  if (!end.how.empty()) {
    std::printf("  end time: %s; the estimate ends at t = %.4g s\n", end.how.c_str(), end.earliest);
    if (end.latest > end.earliest) {
      const double scale = end.latest / end.earliest;
      std::printf("  if it fires only at its latest (end t = %.4g s): %.3g particle-steps%s\n", end.latest,
                  ps * scale,
                  tp ? (", about " + duration_text(wall_seconds(costs, tp->per_core, scale))).c_str() : "");
    }
  }
  std::printf("  (wall time = particle-steps / (throughput x ranks x efficiency): efficiency 1 on one rank, %g on "
              "several%s)\n",
              kEfficiencyManyRanks,
              cs.levels.size() > 1
                  ? fmt::format("; levels run side by side, +{:.0f} % for the coupling", 100.0 * kCouplingOverhead).c_str()
                  : "");
}

}  // namespace

double particle_steps_to(const config::CaseSpec& cs, double end) {
  double ps = 0.0;
  for (const auto& c : level_costs(cs, print_regions(cs, nullptr), end)) ps += c.particle_steps;
  return ps;
}

double estimated_end(const config::CaseSpec& cs) {
  double fill_alpha = 1.0;
  for (const auto& l : cs.levels) fill_alpha = std::max(fill_alpha, l.alpha);
  return end_time(cs, fill_alpha).earliest;
}

int check_case(const CheckOptions& o) {
  try {
    const PreparedCase p = prepare_case(o.case_file, o.hosts, o.curve);  // exactly what `mlcg run` checks
    if (!o.out_dir.empty()) check_new_run_folder(o.out_dir);
    const config::CaseSpec& cs = p.cs;
    std::printf("mlcg check: case %s (%s): %zu level(s)%s; no run is started, no run folder written\n", o.case_file.c_str(),
                cs.title.c_str(), cs.levels.size(), cs.coupling ? ", coupled" : ", no coupler needed");
    for (size_t i = 0; i < cs.bases.size(); ++i)  // base = ..., nearest first
      std::printf("  %s %s\n", i == 0 ? "a variant of" : "  itself a variant of", cs.bases[i].c_str());
    print_outlets(cs, p.outlets);
    print_moving_walls(cs);
    const auto regions = print_regions(cs, &p.regions);
    print_probes(cs);
    double fill_alpha = 1.0;
    for (const auto& l : cs.levels) fill_alpha = std::max(fill_alpha, l.alpha);
    const EndTime end = end_time(cs, fill_alpha);
    const auto costs = level_costs(cs, regions, end.earliest);
    print_levels(cs, costs, end.earliest);
    if (end.earliest <= 0.0) {
      std::printf("estimate: none: the end time is not known before the run (%s)\n", end.how.c_str());
      return 0;
    }
    std::string why;
    const auto tp = machine_throughput((fs::path(own_directory()) / "dem_level").string(), o.calibration, why);
    print_estimate(cs, costs, end, tp, why);
    return 0;
  } catch (const std::exception& e) {  // the case, the region rules, a level's guard, the coupler's grids
    std::fprintf(stderr, "error: %s\n", e.what());
    return 2;
  }
}

}  // namespace mlcg::launcher
