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

void read_materials(const Table& root, CaseSpec& spec, Names& names) {
  for (const Table& raw : array_of_tables(root, "materials")) {
    const Table t = raw.declared({schema::kMaterial});
    MaterialSpec m;
    m.name = t.required<std::string>("name");
    names.materials.add(t, m.name);
    m.youngs_modulus = t.required<double>("youngs_modulus");
    m.poisson_ratio = t.required<double>("poisson_ratio");
    m.density = t.required<double>("density");
    m.loc = t.loc();
    spec.materials.push_back(m);
  }
  if (spec.materials.empty())
    root.fail("materials", "no materials; give at least one [[materials]] entry");
}

void read_contact(const Table& root, CaseSpec& spec) {
  const Table t = optional_table(root, "contact").declared({schema::kContact});
  ContactSpec& c = spec.contact;
  c.normal = t.choice("normal");
  c.tangential = t.choice("tangential");
  c.rolling = t.choice("rolling");
  c.clamp_normal = t.value<bool>("clamp_normal");
}

void read_interactions(const Table& root, CaseSpec& spec, const Names& names) {
  std::map<std::pair<std::string, std::string>, std::string> seen;  // sorted pair -> "interactions[0], line 5"
  for (const Table& raw : array_of_tables(root, "interactions")) {
    const Table t = raw.declared({schema::kInteraction});
    InteractionSpec in;
    if (!t.has("between")) t.fail_missing("between", std::string(t.spec("between").doc));
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
    in.restitution = t.required<double>("restitution");
    in.friction = t.required<double>("friction");
    in.rolling_friction = t.value<double>("rolling_friction");
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
    const Table t = tables[i].declared({schema::kLevel});
    LevelSpec l;
    l.name = t.has("name") ? t.required<std::string>("name") : "level" + std::to_string(i);
    names.levels.add(t, l.name);
    l.alpha = t.value<double>("alpha");
    if (t.has("dt") && t.has("dt_alpha1"))
      t.fail("dt_alpha1", "both dt and dt_alpha1 given; give dt (this level's step) or dt_alpha1 (the step at "
                          "alpha = 1, scaled by alpha)");
    if (t.has("dt_rayleigh") && (t.has("dt") || t.has("dt_alpha1")))
      t.fail("dt_rayleigh", "given together with dt or dt_alpha1; give exactly one way to set the time step");
    if (t.has("dt_alpha1")) {
      l.dt_alpha1 = t.required<double>("dt_alpha1");
      l.dt = l.dt_alpha1 * l.alpha;
    } else if (t.has("dt_rayleigh")) {  // resolved once the particles are known (resolve_rayleigh_dt)
      l.dt_rayleigh = t.required<double>("dt_rayleigh");
    } else {
      l.dt = t.required<double>("dt");
    }
    l.ranks = static_cast<int>(t.value<int64_t>("ranks"));
    l.skin = t.value<double>("skin");
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
    l.balance = t.value<bool>("balance");
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
  const Table t = root.table("domain")->declared({schema::kDomain});
  spec.domain.min = t.required<Vec3>("min");
  spec.domain.max = t.required<Vec3>("max");
  for (int a = 0; a < 3; ++a)
    t.check("max", spec.domain.max[a] > spec.domain.min[a],
             std::string("max.") + kAxis[a] + " = " + num(spec.domain.max[a]) + " is not above min." + kAxis[a] +
                 " = " + num(spec.domain.min[a]) + "; the domain needs min < max in every axis");
}

void read_output(const Table& root, CaseSpec& spec) {
  const Table t = optional_table(root, "output").declared({schema::kOutput});
  OutputSpec& o = spec.output;
  o.snapshot_interval = t.value<double>("snapshot_interval");
  o.checkpoint_interval = t.value<double>("checkpoint_interval");
  o.stats_interval = t.value<double>("stats_interval");
  o.energy_interval = t.value<double>("energy_interval");
}

void read_stability(const Table& root, CaseSpec& spec) {
  const Table t = optional_table(root, "stability").declared({schema::kStability});
  StabilitySpec& s = spec.stability;
  s.rayleigh_fraction = t.value<double>("rayleigh_fraction");
  s.max_overlap_fraction = t.value<double>("max_overlap_fraction");
  s.min_steps_per_contact = t.value<double>("min_steps_per_contact");
  s.max_impact_speed = t.value<double>("max_impact_speed");
  t.check("max_impact_speed", s.max_impact_speed != 0.0,
          "0 is not allowed; give a speed > 0 in m/s, or a negative value to estimate it");
  s.dt_override_reason = t.value<std::string>("dt_override_reason");
}

void read_time(const Table& root, CaseSpec& spec, const Names& names) {
  const Table t = root.table("time")->declared({schema::kTime});
  TimeSpec& tm = spec.time;
  const toml::node* end = t.node("end");
  const std::string how(t.spec("end").doc);
  if (!end) t.fail_missing("end", how);
  if (end->is_table()) {
    const Table e = t.table("end")->declared({schema::kEndAfterEvent}, "end = { ... }");
    tm.end_event = e.required<std::string>("event");
    check_reference(e, "event", tm.end_event, names.events, "event");
    tm.end_plus = e.value<double>("plus");
  } else if (end->is_number()) {
    tm.end = t.required<double>("end");
  } else {
    t.fail("end", std::string("expected a number or a table, found ") + type_name(*end) + "; give " + how);
  }
  tm.progress_interval = t.value<double>("progress_interval");
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
  const Table root = Table(doc, tbl, "").declared({schema::kTop}, "the top level");
  for (const char* k : {"materials", "interactions", "levels"})
    if (!root.has(k)) fail(doc, 1, k, "missing required table; add at least one [[" + std::string(k) + "]] entry");
  for (const char* k : {"domain", "time"})
    if (!root.has(k)) fail(doc, 1, k, "missing required table; add a [" + std::string(k) + "] table");

  CaseSpec spec;
  spec.path = path_for_messages;
  spec.dir = doc.dir;
  spec.bases = std::move(tree.bases);
  spec.title = root.value<std::string>("title");
  spec.seed = static_cast<uint64_t>(root.value<int64_t>("seed"));
  spec.gravity = root.value<Vec3>("gravity");

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
