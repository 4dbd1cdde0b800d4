// [limits] and what a case asks of the machine, estimated before step 1: time
// steps to reach the end, files written, memory held. A key that would ask for
// more (a cell size of 1e-7 m, a snapshot every 1e-300 s, dt = 1e-300 s) is
// refused where it is written, with the value that fits and the [limits] key
// that raises the bound; otherwise such a case ends in std::bad_alloc, fills the
// disk or runs for ever.
#include <algorithm>
#include <cmath>
#include <functional>
#include <numbers>

#include <fmt/format.h>

#include "config/case_parser_detail.hpp"
#include "core/material.hpp"

namespace mlcg::config::detail {

namespace {

// Estimates, generous rather than tight (README: [limits]).
constexpr double kBytesPerParticle = 1000.0;     // ~400 measured (summary.json), plus the gather buffers of output
constexpr double kBytesPerGridCell = 400.0;      // accumulators, one sample's sums and maxima, the averages written
constexpr double kBytesPerCouplingCell = 3000.0; // the coarse level, the fine level and the coupler each hold a cell
constexpr double kBytesPerProbeSample = 16.0;    // time and rate
constexpr double kBytesPerSeriesRow = 256.0;     // a row of series.csv, in memory and in each checkpoint
constexpr double kPacking = 0.64;                // random close packing: the most a fine region holds
constexpr double kSsiPacking = 0.38;             // random sequential placement of equal spheres jams there
constexpr double kGB = 1e9;

// What one key costs (bytes or files) and the value of that key that would cost at most a given amount.
struct Cost {
  SourceLoc at;
  std::string key, what;
  double amount = 0.0;
  std::function<std::string(double)> fix;
};

// Where key k of table `name` is written; the top of the file when the table is absent (defaults).
std::pair<SourceLoc, std::string> where(const Table& root, const std::string& name, std::string_view k) {
  const auto t = root.table(name);
  return t ? std::pair(t->loc(k), t->key(k)) : std::pair(SourceLoc{root.doc().file, 1}, name + "." + std::string(k));
}

// The simulated end time when the case fixes it (a time, or an event at a time or with a latest time); else -1.
double known_end(const CaseSpec& spec) {
  if (spec.time.end > 0.0) return spec.time.end;
  for (const EventSpec& e : spec.events) {
    if (e.name != spec.time.end_event) continue;
    if (e.at >= 0.0) return e.at + spec.time.end_plus;
    if (std::isfinite(e.latest)) return e.latest + spec.time.end_plus;
  }
  return -1.0;
}

const MaterialSpec& material(const CaseSpec& spec, const std::string& name) {
  return *std::find_if(spec.materials.begin(), spec.materials.end(), [&](const MaterialSpec& m) { return m.name == name; });
}

double largest_alpha(const CaseSpec& spec) {
  double a = 1.0;
  for (const LevelSpec& l : spec.levels) a = std::max(a, l.alpha);
  return a;
}

double sphere_volume(double r) { return 4.0 / 3.0 * std::numbers::pi * r * r * r; }

// The particles an insertion asks for at coarse-grain ratio alpha.
double particles_of(const CaseSpec& spec, const InsertionSpec& in, double alpha) {
  if (in.count > 0) return static_cast<double>(in.count);
  const double mean_mass = material(spec, in.material).density * 4.0 / 3.0 * std::numbers::pi *
                           in.radius.mean_volume_factor() * alpha * alpha * alpha;
  return in.mass / mean_mass;
}

// The key an insertion's amount is written in, and that key's value that inserts at most `most` of the
// `n` particles it asks for at alpha: "count <= 120", "count_alpha1 <= 960", "mass <= 0.5 kg".
std::pair<std::string, std::function<std::string(double, double)>> amount_key(const Table& t, const InsertionSpec& in,
                                                                               double alpha) {
  if (t.has("count_alpha1"))
    return {"count_alpha1", [=](double most, double) {
              return fmt::format("count_alpha1 <= {:.0f}", std::floor(most * alpha * alpha * alpha));
            }};
  if (in.count > 0) return {"count", [](double most, double) { return fmt::format("count <= {:.0f}", most); }};
  return {"mass", [m = in.mass](double most, double n) { return fmt::format("mass <= {:.3g} kg", m * most / n); }};
}

std::string gb(double bytes) { return fmt::format("{:.3g} GB", bytes / kGB); }

// Refuses when the costs add up to more than `limit`, at the key of the largest one.
void enforce(std::vector<Cost> costs, double limit, const std::string& limit_key,
             const std::function<std::string(double)>& show) {
  double total = 0.0;
  for (const Cost& c : costs) total += c.amount;
  if (!(total > limit)) return;
  const Cost& big = *std::max_element(costs.begin(), costs.end(),
                                      [](const Cost& a, const Cost& b) { return a.amount < b.amount; });
  const double rest = total - big.amount;
  std::string what = big.what + ": " + show(big.amount);
  if (rest > 0.01 * total) what += " (" + show(total) + " with the rest of the case)";
  what += ", above [limits] " + limit_key + "; ";
  if (rest < limit) what += "give " + big.fix(limit - rest) + ", or ";
  fail(big.at, big.key, what + "raise [limits] " + limit_key.substr(0, limit_key.find(' ')));
}

}  // namespace

void read_limits(const Table& root, CaseSpec& spec) {
  const Table d = optional_table(root, "limits").declared({schema::kLimits}, "[limits]");
  LimitsSpec& l = spec.limits;
  l.max_steps = d.value<int64_t>("max_steps");
  l.max_output_files = d.value<int64_t>("max_output_files");
  l.max_memory_gb = d.value<double>("max_memory_gb");
  if (root.has("limits")) l.loc = d.loc();
}

namespace {

// Every level's steps to the end, and the steps the time-step guard would force on the stiffest,
// smallest particle (a youngs_modulus of 1e308 Pa needs a dt of 1e-155 s).
void check_steps(const Table& root, const CaseSpec& spec, double end) {
  const auto levels = array_of_tables(root, "levels");
  const double max = static_cast<double>(spec.limits.max_steps);
  const std::string raise = "raise [limits] max_steps";
  for (size_t i = 0; i < spec.levels.size(); ++i) {
    const LevelSpec& l = spec.levels[i];
    const double steps = end / l.dt;
    if (steps <= max) continue;
    const char* k = levels[i].has("dt_alpha1") ? "dt_alpha1" : levels[i].has("dt_rayleigh") ? "dt_rayleigh" : "dt";
    const double v = *levels[i].number(k);
    const std::string dt = std::string(k) == "dt" ? num(v) + " s" : num(v) + " makes dt = " + num(l.dt) + " s, which";
    levels[i].fail(k, fmt::format("{} takes {:.3g} steps to reach the end at t = {} s, above [limits] max_steps = {}; "
                                  "give {} >= {:.3g}{}, or {}",
                                  dt, steps, num(end), spec.limits.max_steps, k, v * steps / max,
                                  std::string(k) == "dt_rayleigh" ? "" : " s", raise));
  }
  if (!spec.stability.dt_override_reason.empty()) return;
  const auto materials = array_of_tables(root, "materials");
  auto consider = [&](const std::string& name, double radius) {
    for (size_t m = 0; m < spec.materials.size(); ++m) {
      const MaterialSpec& ms = spec.materials[m];
      if (ms.name != name) continue;
      for (const LevelSpec& l : spec.levels) {
        const double r = radius * l.alpha;
        const double dt = spec.stability.rayleigh_fraction *
                          rayleigh_time(r, {ms.name, ms.youngs_modulus, ms.poisson_ratio, ms.density});
        const double steps = end / dt;
        if (steps <= max) continue;
        materials[m].fail("youngs_modulus",
                          fmt::format("{} Pa makes the time-step guard ask for dt <= {:.3g} s (particles of radius {} "
                                      "m on level '{}'), {:.3g} steps to reach the end at t = {} s, above [limits] "
                                      "max_steps = {}; give youngs_modulus <= {:.3g} Pa, or {}",
                                      num(ms.youngs_modulus), dt, num(r), l.name, steps, num(end),
                                      spec.limits.max_steps, ms.youngs_modulus * (max / steps) * (max / steps), raise));
      }
    }
  };
  for (const InsertionSpec& in : spec.insertions) consider(in.material, in.radius.smallest());
  for (const ParticleSpec& p : spec.particles) consider(p.material, p.radius);
}

// How often something is written or kept over the run on one level: at most once a step.
double events_over_run(double end, double interval, double dt) { return end / std::max(interval, dt) + 1.0; }

double steps_total(const CaseSpec& spec, double end, double interval) {
  double n = 0.0;
  for (const LevelSpec& l : spec.levels) n += events_over_run(end, interval, l.dt);
  return n;
}

// Snapshots, grid frames and checkpoints over the run, on every level.
std::vector<Cost> file_costs(const Table& root, const CaseSpec& spec, double end) {
  std::vector<Cost> costs;
  const double levels = static_cast<double>(spec.levels.size());
  auto interval_cost = [&](std::pair<SourceLoc, std::string> at, double interval, const std::string& what, double per) {
    const std::string k = at.second.substr(at.second.rfind('.') + 1);
    costs.push_back({at.first, at.second, what + " every " + num(interval) + " s on each of " + num(levels) + " level(s)",
                     per * steps_total(spec, end, interval),
                     [=](double allowed) { return fmt::format("{} >= {:.3g} s", k, end * levels * per / allowed); }});
  };
  const OutputSpec& o = spec.output;
  if (o.snapshot_interval > 0.0)
    interval_cost(where(root, "output", "snapshot_interval"), o.snapshot_interval, "a particle snapshot", 1.0);
  if (o.checkpoint_interval > 0.0)
    interval_cost(where(root, "output", "checkpoint_interval"), o.checkpoint_interval, "a checkpoint", 1.0);
  const auto grids = array_of_tables(root, "grids");
  for (size_t g = 0; g < spec.grids.size(); ++g)
    interval_cost({grids[g].loc("output_interval"), grids[g].key("output_interval")}, spec.grids[g].output_interval,
                  "a frame of grid '" + spec.grids[g].name + "'", 1.0);
  if (spec.coupling && spec.coupling->checkpoint_every > 0.0) {
    const double every = std::max(spec.coupling->checkpoint_every, spec.coupling->interval);
    const auto at = where(root, "coupling", "checkpoint_every");
    costs.push_back({at.first, at.second, "a checkpoint of every level and the coupler every " + num(every) + " s",
                     (levels + 1.0) * (end / every + 1.0), [=](double allowed) {
                       return fmt::format("checkpoint_every >= {:.3g} s", end * (levels + 1.0) / allowed);
                     }});
  }
  return costs;
}

// Particles: what the case inserts and places, held by the level(s) that fill the scene; a finer level of a
// hierarchy holds at most what its fine region can (random close packing of its smallest particles).
void particle_costs(const Table& root, const CaseSpec& spec, std::vector<Cost>& costs) {
  const double fill = largest_alpha(spec);
  double filling = 0.0;
  for (const LevelSpec& l : spec.levels) filling += l.alpha == fill || !spec.coupling ? 1.0 : 0.0;
  const auto tables = array_of_tables(root, "insertion");
  double r_min = 0.0, total = 0.0;
  for (size_t i = 0; i < spec.insertions.size(); ++i) {
    const InsertionSpec& in = spec.insertions[i];
    const double n = particles_of(spec, in, fill);
    total += n;
    r_min = r_min > 0.0 ? std::min(r_min, in.radius.smallest()) : in.radius.smallest();
    const auto [k, fix] = amount_key(tables[i], in, fill);
    costs.push_back({tables[i].loc(k), tables[i].key(k), fmt::format("{:.3g} particles of insertion '{}'", n, in.name),
                     n * filling * kBytesPerParticle, [=, fix = fix](double allowed) {
                       return fix(std::floor(allowed / (filling * kBytesPerParticle)), n);
                     }});
  }
  if (!spec.particles.empty())
    costs.push_back({root.loc("particles"), "particles", std::to_string(spec.particles.size()) + " [[particles]]",
                     static_cast<double>(spec.particles.size()) * filling * kBytesPerParticle,
                     [](double) { return std::string("fewer [[particles]] entries"); }});
  if (!spec.coupling || r_min <= 0.0) return;
  const auto regions = array_of_tables(*root.table("coupling"), "regions");
  for (size_t r = 0; r < spec.coupling->regions.size(); ++r) {
    const CouplingRegionSpec& g = spec.coupling->regions[r];
    const LevelSpec& fine = *std::find_if(spec.levels.begin(), spec.levels.end(),
                                          [&](const LevelSpec& l) { return l.name == g.fine; });
    const Vec3 e = g.max - g.min;
    const double room = kPacking * e.x * e.y * e.z / sphere_volume(r_min * fine.alpha);
    const double scaled = (total + static_cast<double>(spec.particles.size())) * std::pow(fill / fine.alpha, 3.0);
    const double n = std::min(room, scaled);
    costs.push_back({regions[r].loc("max"), regions[r].key("max"),
                     fmt::format("up to {:.3g} particles of level '{}' in this fine region", n, g.fine),
                     n * kBytesPerParticle, [](double) { return std::string("a smaller fine region"); }});
  }
}

// Cells of the statistics grids (on every level) and of the coupling regions.
void cell_costs(const Table& root, const CaseSpec& spec, std::vector<Cost>& costs) {
  auto cells = [](const Vec3& lo, const Vec3& hi, double h) {
    double n = 1.0;
    for (int a = 0; a < 3; ++a) n *= std::max(1.0, std::ceil((hi[a] - lo[a]) / h - 1e-9));
    return n;
  };
  auto cost = [&](const Table& t, const Vec3& lo, const Vec3& hi, double h, double bytes, const std::string& what) {
    const Vec3 e = hi - lo;
    const double n = cells(lo, hi, h);
    costs.push_back({t.loc("cell_size"), t.key("cell_size"), fmt::format("{} m makes {:.3g} cells of {}", num(h), n, what),
                     n * bytes, [=](double allowed) {
                       return fmt::format("cell_size >= {:.3g} m", std::cbrt(e.x * e.y * e.z * bytes / allowed));
                     }});
  };
  const auto grids = array_of_tables(root, "grids");
  const double levels = static_cast<double>(spec.levels.size());
  for (size_t g = 0; g < spec.grids.size(); ++g)
    cost(grids[g], spec.grids[g].min, spec.grids[g].max, spec.grids[g].cell_size, kBytesPerGridCell * levels,
         "grid '" + spec.grids[g].name + "' on each level");
  if (!spec.coupling) return;
  const auto regions = array_of_tables(*root.table("coupling"), "regions");
  for (size_t r = 0; r < spec.coupling->regions.size(); ++r) {
    const CouplingRegionSpec& g = spec.coupling->regions[r];
    cost(regions[r], g.min, g.max, g.cell_size, kBytesPerCouplingCell, "the fine region of level '" + g.fine + "'");
  }
}

// Probe samples and rows of series.csv and energy.csv, kept for the whole run.
void series_costs(const Table& root, const CaseSpec& spec, double end, std::vector<Cost>& costs) {
  const double levels = static_cast<double>(spec.levels.size());
  const auto probes = array_of_tables(root, "probes");
  for (size_t p = 0; p < spec.probes.size(); ++p) {
    const double rate = spec.probes[p].sample_rate;
    costs.push_back({probes[p].loc("sample_rate"), probes[p].key("sample_rate"),
                     num(rate) + " Hz keeps a sample of probe '" + spec.probes[p].name + "' at most every step",
                     kBytesPerProbeSample * steps_total(spec, end, 1.0 / rate), [=](double allowed) {
                       return fmt::format("sample_rate <= {:.3g} Hz", allowed / (kBytesPerProbeSample * levels * end));
                     }});
  }
  const auto at = where(root, "output", "stats_interval");
  const double every = spec.output.stats_interval;
  costs.push_back({at.first, at.second, num(every) + " s keeps a row of series.csv at most every step",
                   kBytesPerSeriesRow * steps_total(spec, end, every), [=](double allowed) {
                     return fmt::format("stats_interval >= {:.3g} s", end * levels * kBytesPerSeriesRow / allowed);
                   }});
  const double energy = spec.output.energy_interval;
  if (energy <= 0.0) return;
  const auto eat = where(root, "output", "energy_interval");
  costs.push_back({eat.first, eat.second, num(energy) + " s keeps a row of energy.csv at most every step",
                   kBytesPerSeriesRow * steps_total(spec, end, energy), [=](double allowed) {
                     return fmt::format("energy_interval >= {:.3g} s", end * levels * kBytesPerSeriesRow / allowed);
                   }});
}

}  // namespace

void check_batch_room(const Table& t, const InsertionSpec& in, const CaseSpec& spec, double alpha) {
  const RegionSpec& r = in.region;
  const double height = r.max.z - r.min.z;
  double volume = r.type == RegionType::Cylinder ? std::numbers::pi * r.radius * r.radius * height
                                                 : (r.max.x - r.min.x) * (r.max.y - r.min.y) * height;
  if (in.follow_gap >= 0.0) {  // each batch fills a slab of the region
    const double slab = in.follow_height > 0.0 ? in.follow_height : 10.0 * in.radius.largest() * alpha;
    volume *= std::min(1.0, slab / height);
  }
  const double n = particles_of(spec, in, alpha);
  const double each = sphere_volume(1.0) * in.radius.mean_volume_factor() * alpha * alpha * alpha;
  const double most = std::floor(kSsiPacking * volume / each);
  if (n <= most) return;
  const auto [k, fix] = amount_key(t, in, alpha);
  t.fail(k, fmt::format("{:.3g} particles of {:.3g} m^3 on average (alpha {}) would fill {:.3g} % of the {:.3g} m^3 "
                        "the first batch fills (no rate or mass_rate: all in one batch); random placement fits at "
                        "most {:.0f} %, about {:.0f} particles; give a rate or mass_rate, a larger region, or {}",
                        n, each, num(alpha), 100.0 * n * each / volume, volume, 100.0 * kSsiPacking, most,
                        fix(most, n)));
}

void check_limits(const Table& root, const CaseSpec& spec) {
  const LimitsSpec& l = spec.limits;
  const double end = known_end(spec);
  if (end > 0.0) {
    check_steps(root, spec, end);
    enforce(file_costs(root, spec, end), static_cast<double>(l.max_output_files),
            "max_output_files = " + std::to_string(l.max_output_files),
            [](double n) { return fmt::format("{:.3g} files over the run", n); });
  }
  std::vector<Cost> memory;
  particle_costs(root, spec, memory);
  cell_costs(root, spec, memory);
  if (end > 0.0) series_costs(root, spec, end, memory);
  enforce(memory, l.max_memory_gb * kGB, "max_memory_gb = " + num(l.max_memory_gb),
          [](double bytes) { return "about " + gb(bytes) + " of memory"; });
}

}  // namespace mlcg::config::detail
