// The scene tables of a case file: [[walls]], [[insertion]], [[events]],
// [[probes]] and [[grids]]. They run after materials, levels and the domain
// are read, so every reference and extent can be checked where it is written.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <numeric>

#include <fmt/format.h>

#include "config/case_parser_detail.hpp"

namespace mlcg::config::detail {

namespace {

const char* const kAxis[3] = {"x", "y", "z"};

// A direction: a non-zero 3-vector, returned normalised.
Vec3 direction(const Table& t, std::string_view k) {
  const Vec3 v = t.value<Vec3>(k);
  t.check(k, norm(v) > 0.0 && std::isfinite(norm(v)), vec(v) + " has zero length; give a nonzero direction");
  return normalized(v);
}

// bottom < top along a wall's axis.
void read_extent(const Table& t, WallSpec& w) {
  w.bottom = t.required<double>("bottom");
  w.top = t.required<double>("top");
  t.check("top", w.bottom < w.top,
          "bottom = " + num(w.bottom) + " is not below top = " + num(w.top) + "; the wall needs bottom < top");
}

void read_rims(const Table& t, WallSpec& w) {
  const std::string rims = t.choice("rims");
  w.rim_bottom = rims == "bottom" || rims == "both";
  w.rim_top = rims == "top" || rims == "both";
}

}  // namespace

void read_box(const Table& t, Vec3& lo, Vec3& hi, const std::string& what) {
  lo = t.required_vec3("min", "the lower corner of " + what + " (m)");
  hi = t.required_vec3("max", "the upper corner of " + what + " (m)");
  for (int a = 0; a < 3; ++a)
    t.check("max", hi[a] > lo[a],
            std::string("max.") + kAxis[a] + " = " + num(hi[a]) + " is not above min." + kAxis[a] + " = " +
                num(lo[a]) + "; " + what + " needs min < max in every axis");
}

void check_inside_domain(const Table& t, std::string_view k_lo, std::string_view k_hi, const Vec3& lo, const Vec3& hi,
                         const DomainSpec& d) {
  for (int a = 0; a < 3; ++a) {
    if (lo[a] >= d.min[a] && hi[a] <= d.max[a]) continue;
    const std::string_view k = lo[a] < d.min[a] ? k_lo : k_hi;
    const std::string range = "domain " + std::string(kAxis[a]) + " from " + num(d.min[a]) + " to " + num(d.max[a]);
    if (lo == hi)
      t.fail(k, std::string(kAxis[a]) + " = " + num(lo[a]) + " is outside the domain (" + range +
                    "); keep it inside [domain]");
    t.fail(k, "reaches outside the domain in " + std::string(kAxis[a]) + " (" + num(lo[a]) + " to " + num(hi[a]) +
                  ", " + range + "); keep it inside [domain]");
  }
}

// ---- [[walls]] --------------------------------------------------------------

namespace {

// A wall's surface motion: a plane or mesh slides along itself (a belt), a surface of revolution turns about
// its own axis (a drum); either way the geometry stays where it is. A mesh's velocity is checked against its
// triangles when it is read (scene/walls_from_case.cpp).
void read_wall_motion(const Table& t, WallSpec& w) {
  w.surface_velocity = t.value<Vec3>("surface_velocity");
  w.angular_velocity = t.value<double>("angular_velocity");
  const bool flat = w.type == WallType::Plane || w.type == WallType::Mesh;
  t.check("angular_velocity", flat ? w.angular_velocity == 0.0 : true,
          w.type == WallType::Plane
              ? "a plane has no axis of its own to turn about; give surface_velocity for a belt"
              : "a mesh does not turn its surface in place (only a cylinder, cone or disk does); turn the whole "
                "mesh with move_angular_velocity and move_center, or give surface_velocity for a belt");
  t.check("surface_velocity", flat || w.surface_velocity == Vec3{},
          "a " + std::string(w.type == WallType::Cylinder ? "cylinder" : w.type == WallType::Cone ? "cone" : "disk") +
              " moves by turning about its axis: give angular_velocity in rad/s instead");
  w.move_velocity = t.value<Vec3>("move_velocity");
  w.move_angular_velocity = t.value<Vec3>("move_angular_velocity");
  w.move_center = t.value<Vec3>("move_center");
  const char* const key = w.move_velocity == Vec3{} ? "move_angular_velocity" : "move_velocity";
  t.check(key, !w.moves_rigidly() || w.type == WallType::Mesh,
          "only a mesh moves as a whole; a plane, cylinder, cone or disk moves its surface only (surface_velocity, "
          "angular_velocity), or give the wall as a mesh");
  t.check(key, !w.moves_rigidly() || !w.moving(),
          "the mesh has surface_velocity too; give either the surface's motion (the geometry in place) or the "
          "whole mesh's");
  if (w.type == WallType::Plane) {
    const Vec3 n = w.normal / norm(w.normal);
    const double along = dot(w.surface_velocity, n);
    t.check("surface_velocity", std::abs(along) <= 1e-9 * norm(w.surface_velocity),
            "has " + num(along) + " m/s along the plane's normal; a belt moves in its own plane (give a velocity "
            "at right angles to normal)");
  }
}

}  // namespace

void read_walls(const Table& root, CaseSpec& spec, Names& names) {
  const std::vector<std::string> types = schema::choices(schema::at(schema::kWall, "type"));
  static const schema::Keys of_type[] = {schema::kPlane, schema::kCylinder, schema::kCone, schema::kDisk,
                                         schema::kMesh};  // in WallType order
  for (const Table& raw : array_of_tables(root, "walls")) {
    WallSpec w;
    if (!raw.has("type")) raw.fail_missing("type", "the wall's type, one of " + join(types));
    const std::string type = raw.choice("type", "", types);
    w.type = static_cast<WallType>(std::find(types.begin(), types.end(), type) - types.begin());
    const Table t = raw.declared({schema::kWall, of_type[static_cast<int>(w.type)]}, "a " + type + " wall");
    w.name = t.required<std::string>("name");
    names.walls.add(t, w.name);
    w.material = t.required<std::string>("material");
    check_reference(t, "material", w.material, names.materials, "material");

    switch (w.type) {
      case WallType::Plane:
        w.point = t.value<Vec3>("point");
        w.normal = direction(t, "normal");
        break;
      case WallType::Cylinder:
      case WallType::Disk:
        w.center = t.value<Vec3>("center");
        w.axis = direction(t, "axis");
        w.radius = t.required<double>("radius");
        if (w.type == WallType::Cylinder) {
          read_extent(t, w);
          read_rims(t, w);
        } else {  // an annulus: its inner edge is the rim of a hole (an orifice in a flat floor)
          w.inner_radius = t.value<double>("inner_radius");
          t.check("inner_radius", w.inner_radius >= 0.0 && w.inner_radius < w.radius,
                  num(w.inner_radius) + " is outside [0, radius = " + num(w.radius) +
                      "); give the radius of the disk's hole in m (0 = a full disk)");
        }
        break;
      case WallType::Cone:
        w.center = t.value<Vec3>("center");
        w.axis = direction(t, "axis");
        w.radius_bottom = t.required<double>("radius_bottom");
        w.radius_top = t.required<double>("radius_top");
        t.check("radius_top", w.radius_bottom > 0.0 || w.radius_top > 0.0,
                "both radii are 0; at least one of radius_bottom, radius_top must be > 0");
        read_extent(t, w);
        read_rims(t, w);
        break;
      case WallType::Mesh: {
        namespace fs = std::filesystem;
        const std::string file = t.required<std::string>("file");
        fs::path p(file);
        if (p.is_relative()) p = fs::path(t.folder("file")) / p;
        p = p.lexically_normal();
        std::error_code ec;
        if (!fs::is_regular_file(p, ec))
          t.fail("file", "file not found: " + p.string() + "; give an STL file (a relative path resolves against "
                                                          "the case file's folder " + t.folder("file") + ")");
        w.file = p.string();
        w.scale = t.value<double>("scale");
        w.offset = t.value<Vec3>("offset");
        break;
      }
    }
    read_wall_motion(t, w);
    w.loc = t.loc();
    spec.walls.push_back(w);
  }
}

// ---- [[insertion]] ----------------------------------------------------------

namespace {

RegionSpec read_region(const Table& ins, const DomainSpec& domain) {
  if (!ins.has("region")) ins.fail_missing("region", std::string(ins.spec("region").doc));
  const Table raw = *ins.table("region");
  RegionSpec r;
  const std::string type = raw.choice(schema::kRegionType);  // before the keys, which depend on it
  if (type == "box") {
    const Table t = raw.declared({schema::kBoxRegion}, "a box region");
    read_box(t, r.min, r.max, "the region");
  } else {
    const Table t = raw.declared({schema::kCylinderRegion}, "a cylinder region");
    r.type = RegionType::Cylinder;
    if (!t.has("center")) t.fail_missing("center", std::string(t.spec("center").doc));
    const auto c = *t.numbers("center", 2);
    r.cx = c[0];
    r.cy = c[1];
    r.radius = t.required<double>("radius");
    const double zmin = t.required<double>("zmin");
    const double zmax = t.required<double>("zmax");
    t.check("zmax", zmin < zmax, "zmin = " + num(zmin) + " is not below zmax = " + num(zmax) + "; need zmin < zmax");
    r.min = {r.cx - r.radius, r.cy - r.radius, zmin};
    r.max = {r.cx + r.radius, r.cy + r.radius, zmax};
  }
  check_inside_domain(ins, "region", "region", r.min, r.max, domain);
  return r;
}

RadiusSpec read_radius(const Table& ins) {
  const std::string how(ins.spec("radius").doc);
  RadiusSpec r;
  const toml::node* n = ins.node("radius");
  if (!n) ins.fail_missing("radius", how);
  if (n->is_number()) {
    r.value = ins.required<double>("radius");
    return r;
  }
  if (!n->is_table()) ins.fail("radius", std::string("expected a number or a table, found ") + type_name(*n) + "; give " + how);
  const Table t = ins.table("radius")->declared({schema::kRadiusDistribution}, "a radius distribution");
  const bool uniform = t.has("uniform"), values = t.has("values");
  if (uniform == values)
    t.fail_table(uniform ? "both uniform and values given; give one of them" : "neither uniform nor values given; give " + how);
  if (uniform) {
    t.check("fractions", !t.has("fractions"), "fractions go with values, not with uniform; remove it");
    const auto mm = *t.numbers("uniform", 2);
    r.kind = RadiusKind::Uniform;
    r.min = mm[0];
    r.max = mm[1];
    t.check("uniform", r.min > 0.0, "min = " + num(r.min) + " is not > 0; radii are positive (m)");
    t.check("uniform", r.min < r.max,
            "min = " + num(r.min) + " >= max = " + num(r.max) + "; need 0 < min < max (m)");
    return r;
  }
  r.kind = RadiusKind::Discrete;
  r.values = *t.numbers("values");
  for (size_t i = 0; i < r.values.size(); ++i)
    t.check("values", r.values[i] > 0.0, "value " + num(r.values[i]) + " is not > 0; radii are positive (m)");
  if (!t.has("fractions")) t.fail_missing("fractions", std::string(t.spec("fractions").doc));
  r.fractions = *t.numbers("fractions", r.values.size());
  for (double f : r.fractions)
    t.check("fractions", f >= 0.0, "fraction " + num(f) + " is negative; fractions are >= 0");
  const double sum = std::accumulate(r.fractions.begin(), r.fractions.end(), 0.0);
  t.check("fractions", std::abs(sum - 1.0) <= 1e-9,
          "fractions sum to " + num(sum) + ", not 1; fractions (by number) must sum to 1 within 1e-9");
  return r;
}

// Given more than one of `keys`: refused at the second, naming them all.
void at_most_one(const Table& t, const std::vector<std::string>& keys, bool required, const std::string& what) {
  std::vector<std::string> given;
  for (const auto& k : keys)
    if (t.has(k)) given.push_back(k);
  if (given.size() > 1) t.fail(given[1], "both " + given[0] + " and " + given[1] + " given; give exactly one of " + what);
  if (required && given.empty())
    t.fail_table("neither " + join({keys.begin(), keys.end() - 1}) + " nor " + keys.back() + " given; give exactly one of " +
                 what);
}

// How much an insertion inserts, and how fast. count and rate are the level's own; count_alpha1 and
// rate_alpha1 are at alpha = 1 and scaled here by 1 / alpha^3 (alpha of the coarsest level, the one an
// insertion fills), so one [[insertion]] keeps the mass at every alpha; mass and mass_rate are in kg.
void read_amount(const Table& t, double alpha, InsertionSpec& s) {
  const double scale = 1.0 / (alpha * alpha * alpha);
  at_most_one(t, {"count", "count_alpha1", "mass"}, true,
              "them: count (particles), count_alpha1 (particles at alpha = 1) or mass (kg)");
  if (const auto count = t.optional<int64_t>("count")) {
    s.count = *count;
  } else if (const auto count1 = t.integer("count_alpha1")) {
    t.check("count_alpha1", *count1 >= 1 && *count1 <= (int64_t{1} << 53),
            std::to_string(*count1) + " is outside [1, 2^53]; give the number of particles at alpha = 1");
    s.count = std::llround(static_cast<double>(*count1) * scale);
    t.check("count_alpha1", s.count >= 1,
            fmt::format("{} particles at alpha = 1 are {:.3g} at alpha = {}, less than one; give count_alpha1 >= {:.0f}",
                        *count1, static_cast<double>(*count1) * scale, num(alpha), std::ceil(0.5 / scale)));
  } else {
    s.mass = t.required<double>("mass");
  }
  at_most_one(t, {"rate", "rate_alpha1", "mass_rate"}, false,
              "them, or none: rate (particles/s), rate_alpha1 (particles/s at alpha = 1) or mass_rate (kg/s)");
  if (const auto rate = t.optional<double>("rate")) {
    s.rate = *rate;
  } else if (const auto rate1 = t.optional<double>("rate_alpha1")) {
    s.rate = *rate1 * scale;
  } else if (const auto mass_rate = t.optional<double>("mass_rate")) {
    s.mass_rate = *mass_rate;
  }
}

}  // namespace

void read_insertions(const Table& root, CaseSpec& spec, Names& names) {
  const auto tables = array_of_tables(root, "insertion");
  UniqueNames insertions("insertion");
  for (size_t i = 0; i < tables.size(); ++i) {
    const Table t = tables[i].declared({schema::kInsertion});
    InsertionSpec s;
    s.name = t.has("name") ? t.required<std::string>("name") : "insertion" + std::to_string(i);
    insertions.add(t, s.name);
    s.material = t.required<std::string>("material");
    check_reference(t, "material", s.material, names.materials, "material");
    s.region = read_region(t, spec.domain);
    s.radius = read_radius(t);
    // Centres are drawn at least a radius inside the region, so it must hold the largest
    // particle at the coarsest level (the one an insertion fills); else they land outside it.
    double alpha = 1.0;
    for (const LevelSpec& l : spec.levels) alpha = std::max(alpha, l.alpha);
    const double diameter = 2.0 * s.radius.largest() * alpha;
    for (int a = 0; a < 3; ++a) {
      const double width = s.region.max[a] - s.region.min[a];
      t.check("region", width >= diameter,
              fmt::format("is {} m wide along {}, less than the diameter {} m of its largest particle (radius {} x "
                          "alpha {}); make the region at least {} m wide in every axis",
                          num(width), "xyz"[a], num(diameter), num(s.radius.largest()), num(alpha), num(diameter)));
    }

    read_amount(t, alpha, s);
    const bool rate = s.rate > 0.0 || s.mass_rate > 0.0;
    s.start = t.value<double>("start");
    s.interval = t.value<double>("interval");
    s.velocity = t.value<Vec3>("velocity");
    if (const auto gap = t.optional<double>("follow_gap")) s.follow_gap = *gap;
    if (const auto h = t.optional<double>("follow_height")) {
      t.check("follow_height", s.follow_gap >= 0.0, "follow_height needs follow_gap (the slab follows the heap)");
      s.follow_height = *h;
    }
    if (!rate) check_batch_room(t, s, spec, alpha);
    s.max_attempts = static_cast<int>(t.value<int64_t>("max_attempts"));
    s.loc = t.loc();
    spec.insertions.push_back(s);
  }
}

// ---- [[events]] -------------------------------------------------------------

void read_events(const Table& root, CaseSpec& spec, Names& names) {
  for (const Table& raw : array_of_tables(root, "events")) {
    const Table t = raw.declared({schema::kEvent});
    EventSpec e;
    e.name = t.required<std::string>("name");
    names.events.add(t, e.name);
    const auto at = t.optional<double>("at");
    e.after_insertion = t.value<bool>("after_insertion");
    const auto speed = t.optional<double>("mean_speed_below");
    const bool condition = e.after_insertion || speed.has_value();
    if (!at && !condition)
      t.fail_table("neither at nor a condition given; give at = <s>, or after_insertion = true and/or "
                   "mean_speed_below = <m/s>");
    if (at && condition)
      t.fail("at", "both at and a condition (after_insertion / mean_speed_below) given; give one of them");
    if (condition && spec.coupling)
      t.fail(speed ? "mean_speed_below" : "after_insertion",
             "a condition would fire at a different time on each level of a multi-level case; give at = <s> "
             "(e.g. the time the condition fired in a single-level run)");
    if (at) e.at = *at;
    if (speed) e.mean_speed_below = *speed;
    e.check_interval = t.value<double>("check_interval");
    if (const auto latest = t.optional<double>("latest")) {
      t.check("latest", condition, "latest only applies to a condition, not to at; remove it");
      e.latest = *latest;
    }
    if (t.has("remove_walls")) {
      e.remove_walls = *t.strings("remove_walls");
      for (const auto& w : e.remove_walls) check_reference(t, "remove_walls", w, names.walls, "wall");
    }
    e.loc = t.loc();
    spec.events.push_back(e);
  }
}

// ---- [[probes]] -------------------------------------------------------------

void read_probes(const Table& root, CaseSpec& spec, Names& names) {
  for (const Table& raw : array_of_tables(root, "probes")) {
    const Table t = raw.declared({schema::kProbe});
    ProbeSpec p;
    p.name = t.required<std::string>("name");
    names.probes.add(t, p.name);
    p.point = t.required<Vec3>("point");
    check_inside_domain(t, "point", "point", p.point, p.point, spec.domain);
    p.normal = direction(t, "normal");
    p.radius = t.required<double>("radius");
    p.sample_rate = t.value<double>("sample_rate");
    if (const auto w = t.numbers("window", 2, true)) {
      p.window_start = (*w)[0];
      p.window_end = (*w)[1];
      t.check("window", std::isfinite(p.window_start) && p.window_start >= 0.0,
              "start " + num(p.window_start) + " is not a time >= 0; give window = [t0, t1] with 0 <= t0 < t1 (s)");
      t.check("window", p.window_start < p.window_end,
              "start " + num(p.window_start) + " is not before end " + num(p.window_end) +
                  "; give window = [t0, t1] with 0 <= t0 < t1 (s)");
    }
    if (const auto ev = t.optional<std::string>("window_relative_to")) {
      p.window_event = *ev;
      check_reference(t, "window_relative_to", p.window_event, names.events, "event");
    }
    p.loc = t.loc();
    spec.probes.push_back(p);
  }
}

// ---- [[grids]] --------------------------------------------------------------

void read_grids(const Table& root, CaseSpec& spec, Names& names) {
  for (const Table& raw : array_of_tables(root, "grids")) {
    const Table t = raw.declared({schema::kGrid});
    GridSpec g;
    g.name = t.required<std::string>("name");
    names.grids.add(t, g.name);
    read_box(t, g.min, g.max, "the grid box");
    check_inside_domain(t, "min", "max", g.min, g.max, spec.domain);
    g.cell_size = t.required<double>("cell_size");
    for (int a = 0; a < 3; ++a) {
      const double extent = g.max[a] - g.min[a];
      t.check("cell_size", g.cell_size <= extent,
              num(g.cell_size) + " is larger than the box (" + num(extent) + " in " + kAxis[a] +
                  "); give a cell_size no larger than the box's smallest extent");
    }
    g.output_interval = t.required<double>("output_interval");
    g.sample_interval = t.value<double>("sample_interval");
    t.check("sample_interval", g.sample_interval <= g.output_interval,
            num(g.sample_interval) + " is longer than output_interval = " + num(g.output_interval) +
                "; sample at least once per output interval");
    g.loc = t.loc();
    spec.grids.push_back(g);
  }
}

}  // namespace mlcg::config::detail

namespace mlcg::config::detail {

// ---- [[particles]] -----------------------------------------------------------
void read_particles(const Table& root, CaseSpec& spec, Names& names) {
  for (const Table& raw : array_of_tables(root, "particles")) {
    const Table t = raw.declared({schema::kParticle}, "a particle");
    ParticleSpec p;
    p.material = t.required<std::string>("material");
    check_reference(t, "material", p.material, names.materials, "material");
    p.radius = t.required<double>("radius");
    p.position = t.required<Vec3>("position");
    check_inside_domain(t, "position", "position", p.position, p.position, spec.domain);
    p.velocity = t.value<Vec3>("velocity");
    p.omega = t.value<Vec3>("omega");
    p.loc = t.loc();
    spec.particles.push_back(p);
  }
}

}  // namespace mlcg::config::detail

namespace mlcg::config::detail {

// ---- [initial] -----------------------------------------------------------------
void read_initial(const Table& root, CaseSpec& spec, Names& names) {
  if (!root.has("initial")) return;
  const Table t = root.table("initial")->declared({schema::kInitial}, "[initial]");
  InitialSpec in;
  const std::string file = t.required<std::string>("file");
  const std::filesystem::path path = std::filesystem::path(t.folder("file")) / file;
  t.check("file", std::filesystem::is_regular_file(path), "'" + path.string() + "' does not exist or is not a file");
  in.file = path.string();
  in.material = t.required<std::string>("material");
  check_reference(t, "material", in.material, names.materials, "material");
  in.loc = t.loc();
  spec.initial = in;
}

// ---- [orifice] / [[orifices]] ----------------------------------------------------
// Outlets the walls cannot say (a slot under a round lid): a circle (`diameter`) or a slot
// (`width` x `length`), each with the direction the flow leaves through it. Given, they replace
// the outlets found in the geometry (scene/outlets.hpp). Checks and scripts read them.
namespace {

OrificeSpec read_one_orifice(const Table& t, const std::string& default_name, UniqueNames& names,
                              const DomainSpec& domain) {
  OrificeSpec o;
  o.name = t.has("name") ? t.required<std::string>("name") : default_name;
  names.add(t, o.name);
  o.center = t.required<Vec3>("center");
  check_inside_domain(t, "center", "center", o.center, o.center, domain);
  o.normal = direction(t, "normal");
  const bool circle = t.has("diameter"), slot = t.has("width") || t.has("length");
  if (circle == slot)
    t.fail_table(circle ? "give either diameter (a circular orifice) or width and length (a slot), not both"
                        : "give diameter = D (a circular orifice) or width = W and length = L (a slot) [m]");
  if (circle) {
    o.diameter = t.required<double>("diameter");
  } else {
    o.width = t.required<double>("width");
    o.length = t.required<double>("length");
    t.check("length", o.length >= o.width,
             num(o.length) + " is shorter than width = " + num(o.width) + "; width is the slot's narrow side");
  }
  o.loc = t.loc();
  return o;
}

}  // namespace

void read_orifice(const Table& root, CaseSpec& spec) {
  UniqueNames names{"orifices"};
  const auto list = array_of_tables(root, "orifices");
  if (root.has("orifice") && !list.empty())
    list.front().fail_table("give one [orifice] table or [[orifices]] entries, not both");
  if (root.has("orifice"))
    spec.orifices.push_back(
        read_one_orifice(root.table("orifice")->declared({schema::kOrifice}, "[orifice]"), "orifice", names,
                          spec.domain));
  for (size_t i = 0; i < list.size(); ++i)
    spec.orifices.push_back(
        read_one_orifice(list[i].declared({schema::kOrifice}), "orifice" + std::to_string(i), names,
                                               spec.domain));
}

}  // namespace mlcg::config::detail
