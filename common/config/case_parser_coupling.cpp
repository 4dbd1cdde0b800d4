// The [coupling] section of a multi-level case: the coupling interval, the bus
// settings and one [[coupling.regions]] entry per fine level. It runs after
// [[levels]] (with their resolved dt) and [domain] are read, so level names,
// time steps and boxes are checked where they are written.
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <optional>

#include "config/case_parser_detail.hpp"
#include "core/time_steps.hpp"

namespace mlcg::config::detail {

namespace {

const char* const kAxis[3] = {"x", "y", "z"};

constexpr double kMinFineSteps = 15.0;   // automatic interval: at least this many steps of the finest dt
constexpr int kMaxMultiples = 10000;      // multiples of the largest dt tried before giving up
constexpr double kReachTolerance = 1e-9;  // relative: a multiple this close below at_least reaches it

bool divides(double dt, double interval) { return whole_steps(interval, dt) > 0; }

double largest_dt(const std::vector<LevelSpec>& levels) {
  double dt = 0.0;
  for (const LevelSpec& l : levels) dt = std::max(dt, l.dt);
  return dt;
}

double smallest_dt(const std::vector<LevelSpec>& levels) {
  double dt = std::numeric_limits<double>::infinity();
  for (const LevelSpec& l : levels) dt = std::min(dt, l.dt);
  return dt;
}

// The smallest multiple k x (largest dt) that is >= at_least and that every
// level's dt divides; nullopt when none of kMaxMultiples multiples (counting
// from the first one that could reach at_least) is.
std::optional<double> common_multiple(const std::vector<LevelSpec>& levels, double at_least) {
  const double dt_max = largest_dt(levels);
  const double first = std::max(1.0, std::floor(at_least / dt_max));
  for (int i = 0; i < kMaxMultiples; ++i) {
    const double c = (first + i) * dt_max;
    if (c < at_least * (1.0 - kReachTolerance)) continue;
    if (std::all_of(levels.begin(), levels.end(), [&](const LevelSpec& l) { return divides(l.dt, c); })) return c;
  }
  return std::nullopt;
}

// "level 'coarse' (dt = 2e-06)", saying where dt came from when it was scaled.
std::string describe_dt(const LevelSpec& l) {
  std::string s = "level '" + l.name + "' (dt = " + num(l.dt);
  if (l.dt_alpha1 > 0.0) s += " = dt_alpha1 " + num(l.dt_alpha1) + " x alpha " + num(l.alpha);
  return s + ")";
}

std::string all_dts(const std::vector<LevelSpec>& levels) {
  std::vector<std::string> parts;
  for (const LevelSpec& l : levels) parts.push_back("'" + l.name + "' " + num(l.dt));
  return join(parts);
}

const LevelSpec& level_named(const CaseSpec& spec, const std::string& name) {
  return *std::find_if(spec.levels.begin(), spec.levels.end(), [&](const LevelSpec& l) { return l.name == name; });
}

// interval > 0: every level's dt must divide it. interval == 0: the smallest
// multiple of every dt that is >= 15 steps of the finest level.
double resolve_interval(const Table& t, double interval, const std::vector<LevelSpec>& levels) {
  const auto automatic = common_multiple(levels, kMinFineSteps * smallest_dt(levels));
  if (interval > 0.0) {
    for (const LevelSpec& l : levels) {
      if (divides(l.dt, interval)) continue;
      const auto next = common_multiple(levels, interval);
      std::string fix = next ? "e.g. interval = " + num(*next) + " (the next multiple of every level's dt)"
                             : std::string("a whole multiple of every level's dt");
      if (automatic) fix += ", or interval = 0 (automatic: " + num(*automatic) + ")";
      t.fail("interval", num(interval) + " is not a whole multiple of the time step of " + describe_dt(l) +
                             "; interval / dt = " + num(interval / l.dt) +
                             "; every level's dt must divide the coupling interval; give " + fix);
    }
    return interval;
  }
  if (!automatic)
    t.fail("interval", "no automatic coupling interval: none of " + std::to_string(kMaxMultiples) +
                           " multiples of the largest dt (" + num(largest_dt(levels)) +
                           ") is a whole multiple of every level's dt (" + all_dts(levels) +
                           "); give the levels time steps with a common multiple, e.g. each a whole multiple of the finest dt");
  return *automatic;
}

CouplingRegionSpec read_region(const Table& raw, const CaseSpec& spec, const Names& names) {
  const Table r = raw.declared({schema::kCouplingRegion});
  CouplingRegionSpec g;
  g.coarse = r.required<std::string>("coarse");
  check_reference(r, "coarse", g.coarse, names.levels, "level");
  g.fine = r.required<std::string>("fine");
  check_reference(r, "fine", g.fine, names.levels, "level");
  const LevelSpec& coarse = level_named(spec, g.coarse);
  const LevelSpec& fine = level_named(spec, g.fine);
  r.check("fine", g.fine != g.coarse,
          "'" + g.fine + "' is also the coarse level; a region couples two different levels, the fine one with "
          "the smaller alpha");
  r.check("fine", fine.alpha < coarse.alpha,
          "level '" + g.fine + "' has alpha = " + num(fine.alpha) + ", not below alpha = " + num(coarse.alpha) +
              " of the coarse level '" + g.coarse + "'; the fine level needs the smaller coarse-grain ratio "
              "(alpha(coarse) > alpha(fine)); swap coarse and fine or correct the levels' alpha");

  read_box(r, g.min, g.max, "the fine region");
  check_inside_domain(r, "min", "max", g.min, g.max, spec.domain);
  g.cell_size = r.value<double>("cell_size");
  if (const auto p = r.optional<Vec3>("inside")) {
    for (int a = 0; a < 3; ++a)
      r.check("inside", (*p)[a] >= g.min[a] && (*p)[a] <= g.max[a],
              std::string(kAxis[a]) + " = " + num((*p)[a]) + " is outside the region's box (" + kAxis[a] +
                  " from " + num(g.min[a]) + " to " + num(g.max[a]) +
                  "); give a point inside min..max that lies inside the geometry");
    g.inside = *p;
  }
  g.insert_depth = r.value<double>("insert_depth");
  g.fade = r.value<double>("fade");
  g.kp = r.value<double>("kp");
  g.ki = r.value<double>("ki");
  g.traction_limit = r.value<double>("traction_limit");
  g.correct = r.choice("correct");
  g.velocity_gain = r.value<double>("velocity_gain");
  g.velocity_ki = r.optional<double>("velocity_ki").value_or(0.1 * g.velocity_gain * g.velocity_gain);
  g.acceleration_limit = r.value<double>("acceleration_limit");
  g.velocity_only_below = r.value<double>("velocity_only_below");
  g.radius_bins = static_cast<int>(r.value<int64_t>("radius_bins"));
  g.open_bottom = r.value<bool>("open_bottom");
  g.loc = r.loc();
  for (const char* k : {"min", "max", "cell_size", "coarse", "fine", "open_bottom"})
    if (r.has(k)) g.key_locs[k] = r.loc(k);
  return g;
}

}  // namespace

void read_coupling(const Table& root, CaseSpec& spec, const Names& names) {
  const auto t = root.table("coupling");
  if (!t) return;  // more than one level without [coupling] is refused by read_levels
  if (spec.levels.size() < 2)
    t->fail_table("a [coupling] section needs more than one [[levels]] entry, found " +
                  std::to_string(spec.levels.size()) +
                  "; remove [coupling] for a single-level case, or add the finer [[levels]] it couples");
  const Table d = t->declared({schema::kCoupling});
  CouplingSpec c;
  c.interval = resolve_interval(d, d.value<double>("interval"), spec.levels);
  c.endpoint = d.value<std::string>("endpoint");
  d.check("endpoint",
           c.endpoint.empty() || ((c.endpoint.rfind("tcp://", 0) == 0 || c.endpoint.rfind("ipc://", 0) == 0) &&
                                  c.endpoint.size() > 6),
           "'" + c.endpoint + "' is not an endpoint the levels can reach; give tcp://HOST:PORT or ipc://PATH, or "
           "leave it out (ipc:// in the run folder)");
  c.heartbeat = d.value<double>("heartbeat");
  c.timeout = d.value<double>("timeout");
  d.check("timeout", c.timeout > c.heartbeat,
           num(c.timeout) + " is not longer than heartbeat = " + num(c.heartbeat) +
               "; give a timeout in s of wall time above the heartbeat");

  c.checkpoint_every = d.value<double>("checkpoint_every");
  c.lead = d.value<double>("lead");
  c.samples = static_cast<int>(d.value<int64_t>("samples"));
  c.retry_full_every = static_cast<int>(d.value<int64_t>("retry_full_every"));

  const auto tables = array_of_tables(*t, "regions");
  if (tables.empty())
    fail(t->loc("regions"), t->key("regions"),
         "no regions; give at least one [[coupling.regions]] entry (the fine region of each finer level)");
  std::map<std::string, std::string> fine_of;  // fine level -> "coupling.regions[0], line 40"
  for (const Table& r : tables) {
    CouplingRegionSpec g = read_region(r, spec, names);
    // The correction is applied explicitly once per interval: a gain x interval near 1 overshoots.
    r.check("velocity_gain", g.velocity_gain * c.interval <= 0.5,
            num(g.velocity_gain) + " 1/s x the coupling interval " + num(c.interval) + " s = " +
                num(g.velocity_gain * c.interval) + " would overshoot; give at most " + num(0.5 / c.interval) +
                " 1/s, or a shorter interval");
    // The correction acts on the cells' velocity, an integrator of the acceleration: a PI with
    // ki > gain^2 / 4 is underdamped there and makes the coarse flow oscillate.
    r.check("velocity_ki", g.velocity_ki <= 0.25 * g.velocity_gain * g.velocity_gain,
            num(g.velocity_ki) + " 1/s^2 is above velocity_gain^2 / 4 = " +
                num(0.25 * g.velocity_gain * g.velocity_gain) +
                " 1/s^2, where the correction oscillates; give at most that, or a higher velocity_gain");
    // The integral acts once per interval on a stress that answers within it: ki x interval near 1 rings.
    r.check("ki", g.ki * c.interval <= 0.5,
            num(g.ki) + " 1/s x the coupling interval " + num(c.interval) + " s = " + num(g.ki * c.interval) +
                " would ring; give at most " + num(0.5 / c.interval) + " 1/s, or a shorter interval");
    const auto [it, fresh] = fine_of.emplace(g.fine, r.path() + ", line " + std::to_string(r.line("fine")));
    if (!fresh)
      r.fail("fine", "level '" + g.fine + "' is already the fine level of " + it->second +
                         "; every fine level belongs to exactly one [[coupling.regions]] entry");
    c.regions.push_back(std::move(g));
  }
  // A level no region names would run uncoupled next to the others.
  const auto levels = array_of_tables(root, "levels");
  for (size_t i = 0; i < spec.levels.size(); ++i) {
    const std::string& name = spec.levels[i].name;
    const bool used = std::any_of(c.regions.begin(), c.regions.end(), [&](const CouplingRegionSpec& g) {
      return g.coarse == name || g.fine == name;
    });
    if (used) continue;
    const std::string what = "level '" + name + "' is in no [[coupling.regions]] entry; name it as coarse or fine "
                             "of a region, or remove the level";
    if (levels[i].has("name")) levels[i].fail("name", what);
    levels[i].fail_table(what);
  }
  c.loc = t->loc();
  spec.coupling = std::move(c);
}

void read_launcher(const Table& root, CaseSpec& spec) {
  for (const Table& w : array_of_tables(root, "swap")) {
    if (spec.levels.size() < 2)
      w.fail_table("[[swap]] replaces a level of a multi-level run; a single-level case has none: remove it");
    const Table t = w.declared({schema::kSwap});
    SwapSpec s;
    s.loc = t.loc();
    s.level = t.required<std::string>("level");
    const bool known = std::any_of(spec.levels.begin(), spec.levels.end(), [&](const LevelSpec& l) { return l.name == s.level; });
    t.check("level", known, "'" + s.level + "' is not a [[levels]] entry of this case");
    s.at = t.required<double>("at");
    s.binary = t.required<std::string>("binary");
    if (!s.binary.empty() && s.binary.front() != '/') s.binary = t.folder("binary") + "/" + s.binary;
    spec.swaps.push_back(std::move(s));
  }
  const auto t = root.table("launcher");
  if (!t) return;
  if (spec.levels.size() < 2)
    t->fail_table("[launcher] supervises a multi-level run; a single-level case has nothing to restart: remove it");
  spec.launcher.restart_on_failure =
      static_cast<int>(t->declared({schema::kLauncher}).value<int64_t>("restart_on_failure"));
}

}  // namespace mlcg::config::detail
