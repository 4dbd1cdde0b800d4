// The case file: the top level, the physics tables ([[materials]],
// [[interactions]], [contact], [[levels]], [domain], [output], [stability],
// [time]) and the checks that span tables. Walls, insertion, events, probes and
// grids are read in case_parser_scene.cpp, [coupling] in case_parser_coupling.cpp;
// the typed key readers live in case_parser_read.cpp.
#include "config/case_parser.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>

#include "config/case_parser_detail.hpp"
#include "core/material.hpp"

namespace mlcg::config {

using namespace detail;

namespace {

const char* const kAxis[3] = {"x", "y", "z"};
constexpr double kMaxYoungsModulus = 1e14;     // Pa
constexpr double kMinProgressInterval = 0.1;   // wall s: more often, the log grows by a line a step

void read_materials(const Table& root, CaseSpec& spec, Names& names) {
  for (const Table& t : array_of_tables(root, "materials")) {
    t.allow(keys::kMaterial);
    MaterialSpec m;
    m.name = t.required_string("name", "the material's name, e.g. name = \"glass\"");
    names.materials.add(t, m.name);
    m.youngs_modulus = t.required_number("youngs_modulus", "Young's modulus in Pa (> 0)");
    // Diamond has 1.2e12 Pa; far above, the Hertz coefficients overflow and the guard asks for dt = 0.
    t.positive("youngs_modulus", m.youngs_modulus, "Pa");
    t.check("youngs_modulus", m.youngs_modulus <= kMaxYoungsModulus,
            num(m.youngs_modulus) + " is outside (0, " + num(kMaxYoungsModulus) +
                "] Pa; no solid is stiffer than about 1.2e12 Pa (diamond)");
    m.poisson_ratio = t.required_number("poisson_ratio", "Poisson's ratio in [0, 0.5)");
    t.check("poisson_ratio", m.poisson_ratio >= 0.0 && m.poisson_ratio < 0.5,
            num(m.poisson_ratio) + " is outside [0, 0.5)");
    m.density = t.required_number("density", "the particle density in kg/m^3 (> 0)");
    t.positive("density", m.density, "kg/m^3");
    m.loc = t.loc();
    spec.materials.push_back(m);
  }
  if (spec.materials.empty())
    root.fail("materials", "no materials; give at least one [[materials]] entry");
}

void read_contact(const Table& root, CaseSpec& spec) {
  const auto t = root.table("contact");
  if (!t) return;
  t->allow(keys::kContact);
  ContactSpec& c = spec.contact;
  c.normal = t->choice("normal", c.normal, {"hertz"});
  c.tangential = t->choice("tangential", c.tangential, {"history", "none"});
  c.rolling = t->choice("rolling", c.rolling, {"none", "cdt"});
  c.clamp_normal = t->boolean("clamp_normal").value_or(c.clamp_normal);
}

void read_interactions(const Table& root, CaseSpec& spec, const Names& names) {
  std::map<std::pair<std::string, std::string>, std::string> seen;  // sorted pair -> "interactions[0], line 5"
  for (const Table& t : array_of_tables(root, "interactions")) {
    t.allow(keys::kInteraction);
    InteractionSpec in;
    if (!t.has("between")) t.fail_missing("between", "the two materials, e.g. between = [\"glass\", \"steel\"]");
    const auto between = *t.strings("between", 2);
    in.a = between[0];
    in.b = between[1];
    check_reference(t, "between", in.a, names.materials, "material");
    check_reference(t, "between", in.b, names.materials, "material");
    const auto pair = std::minmax(in.a, in.b);
    const auto [it, fresh] = seen.emplace(std::pair(pair.first, pair.second),
                                          t.path() + ", line " + std::to_string(t.line("between")));
    if (!fresh)
      t.fail("between", "a second interaction between '" + in.a + "' and '" + in.b + "' (also " + it->second +
                            "); give each pair of materials once");
    in.restitution = t.required_number("restitution", "the coefficient of restitution in (0, 1]");
    t.check("restitution", in.restitution > 0.0 && in.restitution <= 1.0, num(in.restitution) + " is outside (0, 1]");
    in.friction = t.required_number("friction", "the Coulomb friction coefficient (>= 0)");
    t.non_negative("friction", in.friction, "");
    in.rolling_friction = t.number("rolling_friction", 0.0);
    t.non_negative("rolling_friction", in.rolling_friction, "");
    if (in.rolling_friction > 0.0 && spec.contact.rolling == "none")
      t.fail("rolling_friction", num(in.rolling_friction) +
                                     " needs a rolling model, but [contact] rolling = \"none\"; set rolling = \"cdt\" "
                                     "in [contact] or rolling_friction = 0");
    in.loc = t.loc();
    spec.interactions.push_back(in);
  }
  if (spec.interactions.empty())
    root.fail("interactions", "no interactions; give an [[interactions]] entry for every pair of materials that can meet");
}

void read_levels(const Table& root, CaseSpec& spec, Names& names) {
  const auto tables = array_of_tables(root, "levels");
  for (size_t i = 0; i < tables.size(); ++i) {
    const Table& t = tables[i];
    t.allow(keys::kLevel);
    LevelSpec l;
    l.name = t.has("name") ? t.required_string("name", "the level's name") : "level" + std::to_string(i);
    names.levels.add(t, l.name);
    l.alpha = t.number("alpha", l.alpha);
    t.check("alpha", l.alpha >= 1.0, num(l.alpha) + " is below 1; the coarse-grain ratio alpha must be >= 1");
    if (t.has("dt") && t.has("dt_alpha1"))
      t.fail("dt_alpha1", "both dt and dt_alpha1 given; give dt (this level's step) or dt_alpha1 (the step at "
                          "alpha = 1, scaled by alpha)");
    if (t.has("dt_rayleigh") && (t.has("dt") || t.has("dt_alpha1")))
      t.fail("dt_rayleigh", "given together with dt or dt_alpha1; give exactly one way to set the time step");
    if (t.has("dt_alpha1")) {
      l.dt_alpha1 = t.required_number("dt_alpha1", "the time step at alpha = 1 in s (> 0)");
      t.positive("dt_alpha1", l.dt_alpha1, "s");
      l.dt = l.dt_alpha1 * l.alpha;
    } else if (t.has("dt_rayleigh")) {  // resolved once the particles are known (resolve_rayleigh_dt)
      l.dt_rayleigh = t.required_number("dt_rayleigh", "a share of the Rayleigh time in (0, 1]");
      t.check("dt_rayleigh", l.dt_rayleigh > 0.0 && l.dt_rayleigh <= 1.0, num(l.dt_rayleigh) + " is outside (0, 1]");
    } else {
      l.dt = t.required_number("dt", "the time step in s (> 0), or dt_alpha1, or dt_rayleigh");
      t.positive("dt", l.dt, "s");
    }
    const int64_t ranks = t.integer("ranks").value_or(l.ranks);
    t.check("ranks", ranks >= 1 && ranks <= 1'000'000, std::to_string(ranks) + " is not a valid number of MPI "
                                                             "processes; give ranks >= 1");
    l.ranks = static_cast<int>(ranks);
    l.skin = t.number("skin", l.skin);
    t.non_negative("skin", l.skin, "m (0 = automatic)");
    if (const auto grid = t.numbers("processors", 3)) {
      int64_t product = 1;
      for (double g : *grid) {
        t.check("processors", g >= 1.0 && g == std::floor(g) && g <= 1e6,
                "every entry must be a whole number >= 1, e.g. processors = [2, 1, 1]");
        l.processors.push_back(static_cast<int>(g));
        product *= static_cast<int64_t>(g);
      }
      t.check("processors", product == l.ranks,
              fmt::format("[{}, {}, {}] makes {} boxes but ranks = {}; the product must equal ranks",
                          l.processors[0], l.processors[1], l.processors[2], product, l.ranks));
    }
    l.balance = t.boolean("balance").value_or(l.balance);
    l.loc = t.loc();
    spec.levels.push_back(l);
  }
  if (tables.empty()) root.fail("levels", "no levels; give one [[levels]] entry");
  // More than one level runs only coupled; read_coupling checks the rest.
  if (tables.size() > 1 && !root.has("coupling"))
    fail(tables[1].loc(), "levels",
         std::to_string(tables.size()) +
             " [[levels]] entries given, but no [coupling] section; a multi-level case needs one: add [coupling] "
             "with one [[coupling.regions]] entry (coarse, fine, min, max) per finer level, or give exactly one "
             "[[levels]] entry");
}

void read_domain(const Table& root, CaseSpec& spec) {
  const auto t = root.table("domain");
  t->allow(keys::kDomain);
  spec.domain.min = t->required_vec3("min", "the lower corner, e.g. min = [-0.1, -0.1, 0.0] (m)");
  spec.domain.max = t->required_vec3("max", "the upper corner, e.g. max = [0.1, 0.1, 0.5] (m)");
  for (int a = 0; a < 3; ++a)
    t->check("max", spec.domain.max[a] > spec.domain.min[a],
             std::string("max.") + kAxis[a] + " = " + num(spec.domain.max[a]) + " is not above min." + kAxis[a] +
                 " = " + num(spec.domain.min[a]) + "; the domain needs min < max in every axis");
}

void read_output(const Table& root, CaseSpec& spec) {
  const auto t = root.table("output");
  if (!t) return;
  t->allow(keys::kOutput);
  OutputSpec& o = spec.output;
  o.snapshot_interval = t->number("snapshot_interval", o.snapshot_interval);
  t->non_negative("snapshot_interval", o.snapshot_interval, "s (0 = only the final state)");
  o.checkpoint_interval = t->number("checkpoint_interval", o.checkpoint_interval);
  t->non_negative("checkpoint_interval", o.checkpoint_interval, "s (0 = only at the end)");
  o.stats_interval = t->number("stats_interval", o.stats_interval);
  t->positive("stats_interval", o.stats_interval, "s");
  o.energy_interval = t->number("energy_interval", o.energy_interval);
  t->non_negative("energy_interval", o.energy_interval, "s (0 = no energy account)");
}

void read_stability(const Table& root, CaseSpec& spec) {
  const auto t = root.table("stability");
  if (!t) return;
  t->allow(keys::kStability);
  StabilitySpec& s = spec.stability;
  auto fraction = [&](const char* k, double& v) {
    v = t->number(k, v);
    t->check(k, v > 0.0 && v <= 1.0, num(v) + " is outside (0, 1]");
  };
  fraction("rayleigh_fraction", s.rayleigh_fraction);
  fraction("max_overlap_fraction", s.max_overlap_fraction);
  s.min_steps_per_contact = t->number("min_steps_per_contact", s.min_steps_per_contact);
  t->check("min_steps_per_contact", s.min_steps_per_contact >= 1.0,
           num(s.min_steps_per_contact) + " is below 1; give at least 1 time step per contact");
  s.max_impact_speed = t->number("max_impact_speed", s.max_impact_speed);
  t->check("max_impact_speed", s.max_impact_speed != 0.0,
           "0 is not allowed; give a speed > 0 in m/s, or a negative value to estimate it");
  s.dt_override_reason = t->string("dt_override_reason").value_or("");
}

void read_time(const Table& root, CaseSpec& spec, const Names& names) {
  const auto t = root.table("time");
  t->allow(keys::kTime);
  TimeSpec& tm = spec.time;
  const toml::node* end = t->node("end");
  const std::string how = "end = <seconds> or end = { event = \"<event name>\", plus = <seconds> }";
  if (!end) t->fail_missing("end", how);
  if (end->is_table()) {
    const Table e = *t->table("end");
    e.allow(keys::kEndAfterEvent, "end = { ... }");
    tm.end_event = e.required_string("event", "the name of an [[events]] entry");
    check_reference(e, "event", tm.end_event, names.events, "event");
    tm.end_plus = e.number("plus", 0.0);
    e.non_negative("plus", tm.end_plus, "s");
  } else if (end->is_number()) {
    tm.end = *t->number("end");
    t->positive("end", tm.end, "s");
  } else {
    t->fail("end", std::string("expected a number or a table, found ") + type_name(*end) + "; give " + how);
  }
  tm.progress_interval = t->number("progress_interval", tm.progress_interval);
  t->check("progress_interval", tm.progress_interval >= kMinProgressInterval,
           num(tm.progress_interval) + " is below " + num(kMinProgressInterval) +
               " s of wall time; progress lines more often would fill the log; give progress_interval >= " +
               num(kMinProgressInterval));
}

// Every pair of materials that can meet needs an [[interactions]] entry: each
// particle material with itself and with every other particle material, and
// each wall material with every particle material.
void check_pairs(const Table& root, const CaseSpec& spec) {
  auto defined = [&](const std::string& a, const std::string& b) {
    for (const auto& in : spec.interactions)
      if ((in.a == a && in.b == b) || (in.a == b && in.b == a)) return true;
    return false;
  };
  auto missing = [](const std::string& a, const std::string& b, const std::string& why) {
    return "no [[interactions]] entry between '" + a + "' and '" + b + "' (" + why + "); add one with between = [\"" +
           a + "\", \"" + b + "\"]";
  };
  const auto insertions = array_of_tables(root, "insertion");
  std::vector<std::string> particle;  // particle materials in file order
  for (size_t i = 0; i < spec.insertions.size(); ++i) {
    const std::string& p = spec.insertions[i].material;
    if (std::find(particle.begin(), particle.end(), p) != particle.end()) continue;
    particle.push_back(p);
    for (const std::string& q : particle)
      if (!defined(p, q))
        insertions[i].fail("material", missing(p, q, "particles of insertion '" + spec.insertions[i].name +
                                                         "' meet " + (p == q ? "each other" : "'" + q + "' particles")));
  }
  const auto explicit_particles = array_of_tables(root, "particles");
  for (size_t i = 0; i < spec.particles.size(); ++i) {
    const std::string& p = spec.particles[i].material;
    if (std::find(particle.begin(), particle.end(), p) != particle.end()) continue;
    particle.push_back(p);
    for (const std::string& q : particle)
      if (!defined(p, q))
        explicit_particles[i].fail("material", missing(p, q, "particles[" + std::to_string(i) + "] meets " +
                                                                 (p == q ? "particles of its own material" : "'" + q + "' particles")));
  }
  if (spec.initial) {
    const std::string& p = spec.initial->material;
    if (std::find(particle.begin(), particle.end(), p) == particle.end()) {
      particle.push_back(p);
      const auto init = root.table("initial");
      for (const std::string& q : particle)
        if (!defined(p, q)) init->fail("material", missing(p, q, "the initial particles meet " +
                                                                 (p == q ? std::string("each other") : "'" + q + "' particles")));
    }
  }
  const auto walls = array_of_tables(root, "walls");
  for (size_t w = 0; w < spec.walls.size(); ++w)
    for (const std::string& p : particle)
      if (!defined(spec.walls[w].material, p))
        walls[w].fail("material",
                      missing(spec.walls[w].material, p, "wall '" + spec.walls[w].name + "' meets '" + p + "' particles"));
}

// dt_rayleigh: dt = that share of the shortest Rayleigh time among the level's
// particles (every insertion's and [[particles]] radius times alpha), rounded
// down to 2 significant digits so that levels' steps stay commensurate.
void resolve_rayleigh_dt(const Table& root, CaseSpec& spec) {
  const auto levels = array_of_tables(root, "levels");
  for (size_t i = 0; i < spec.levels.size(); ++i) {
    LevelSpec& l = spec.levels[i];
    if (l.dt_rayleigh <= 0.0) continue;
    if (spec.initial)
      levels[i].fail("dt_rayleigh", "cannot be used with [initial] (its radii are only known when the snapshot is "
                                    "read); give dt or dt_alpha1");
    double tr = std::numeric_limits<double>::infinity();
    auto consider = [&](const std::string& material, double radius) {
      for (const MaterialSpec& m : spec.materials)
        if (m.name == material)
          tr = std::min(tr, rayleigh_time(radius * l.alpha, {m.name, m.youngs_modulus, m.poisson_ratio, m.density}));
    };
    for (const InsertionSpec& in : spec.insertions) consider(in.material, in.radius.smallest());
    for (const ParticleSpec& p : spec.particles) consider(p.material, p.radius);
    if (!std::isfinite(tr))
      levels[i].fail("dt_rayleigh", "the case has no [[insertion]] or [[particles]] whose Rayleigh time could set "
                                    "dt; give dt or dt_alpha1");
    const double x = l.dt_rayleigh * tr;
    const double unit = std::pow(10.0, std::floor(std::log10(x)) - 1.0);
    double k = std::floor(x / unit);
    if ((k + 1.0) * unit <= x) k += 1.0;  // floor of a quotient that rounded down
    l.dt = k * unit;
  }
}


}  // namespace

CaseSpec parse_case(std::string_view toml_text, const std::string& path_for_messages) {
  const Doc doc{path_for_messages, folder_of(path_for_messages)};
  CaseTree tree = read_case_tree(toml_text, doc);  // a variant laid over its base
  const toml::table& tbl = tree.root;
  const Table root(doc, tbl, "");
  root.allow(keys::kTop, "the top level");
  for (const char* k : {"materials", "interactions", "levels"})
    if (!root.has(k)) fail(doc, 1, k, "missing required table; add at least one [[" + std::string(k) + "]] entry");
  for (const char* k : {"domain", "time"})
    if (!root.has(k)) fail(doc, 1, k, "missing required table; add a [" + std::string(k) + "] table");

  CaseSpec spec;
  spec.path = path_for_messages;
  spec.dir = doc.dir;
  spec.bases = std::move(tree.bases);
  spec.title = root.string("title").value_or("");
  if (const auto seed = root.integer("seed")) {
    root.check("seed", *seed >= 0, std::to_string(*seed) + " is negative; give an integer >= 0");
    spec.seed = static_cast<uint64_t>(*seed);
  }
  spec.gravity = root.vec3("gravity").value_or(spec.gravity);

  // Order matters: later tables refer to names and the domain read earlier.
  Names names;
  read_materials(root, spec, names);
  read_contact(root, spec);
  read_interactions(root, spec, names);
  read_levels(root, spec, names);
  read_domain(root, spec);
  read_walls(root, spec, names);
  read_insertions(root, spec, names);
  read_particles(root, spec, names);
  read_initial(root, spec, names);
  read_orifice(root, spec);
  resolve_rayleigh_dt(root, spec);  // needs the particles; [coupling] needs every level's dt
  read_coupling(root, spec, names);
  read_launcher(root, spec);
  read_events(root, spec, names);
  read_probes(root, spec, names);
  read_grids(root, spec, names);
  read_output(root, spec);
  read_stability(root, spec);
  read_time(root, spec, names);
  check_pairs(root, spec);
  read_limits(root, spec);
  check_limits(root, spec);
  return spec;
}

void check_toml_text(std::string_view toml_text, const std::string& path_for_messages) {
  scan_text(Doc{path_for_messages, folder_of(path_for_messages)}, toml_text);
}

CaseSpec load_case(const std::string& path) { return parse_case(case_file_text(path), path); }

}  // namespace mlcg::config
