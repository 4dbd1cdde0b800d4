#include "plan/plan.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <stdexcept>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "plan/check.hpp"
#include "config/case_parser.hpp"
#include "config/region_rules.hpp"
#include "config/regions.hpp"
#include "from_case.hpp"
#include "io/atomic_file.hpp"
#include "run/checkpoints.hpp"
#include "scene/outlets.hpp"
#include "scene/vessel.hpp"
#include "stability/stability_preview.hpp"

namespace fs = std::filesystem;

namespace mlcg::launcher {
namespace {

using config::Outlet;
using config::RegionBox;

struct PlanError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct Region {
  std::string coarse, fine;
  RegionBox box;
  double cell = 0.0;
  std::vector<const Outlet*> outlets;
  std::vector<std::string> why;
};

// A level of the plan: the reference's level at alpha x factor, dt scaled alike.
struct Level {
  std::string name;
  double alpha, dt;
  int ranks;
};

double clean(double x) { return std::round(x * 1e9) / 1e9 + 0.0; }
std::string num(double x) { return fmt::format("{:.6g}", clean(x)); }
std::string vec(const Vec3& v) { return fmt::format("[{}, {}, {}]", num(v.x), num(v.y), num(v.z)); }

// The box around an outlet in its own frame: `depth` along the inward normal, `beyond` past the outlet,
// `half` across it; its axis-aligned hull snapped outward to whole cells: counted from the outlet's centre along
// an axis the box is lopsided on (the outlet's plane then lies on a cell face), centred on it along an axis it
// spans evenly (a 9 cm span takes 5 cells of 2 cm, not 6: neighbouring outlets' regions stay apart).
// An outlet the flow does not leave downward (a hole in a side wall) is fed from above: the box also reaches
// `depth` above the outlet's upper edge, against gravity (`up`, zero for a downward outlet). side_outlet: its
// region 1.5 D0 above the hole's top was +3.2 +- 3.0 %, cut to 1.17 D0 by the centred rounding +8.6 +- 2.9 %.
// The fewest whole cells a planned region reaches above a downward outlet: the rules' advised count, rounded up.
const double kPlanCellsAbove = std::ceil(config::kAdvisedCellsAboveOrifice - 1e-9);

// A downward outlet whose normal is an axis (`down`): along that axis at least kPlanCellsAbove whole
// cells, and with `floor` > 0 the depth goes to the nearest whole cell, never below `floor`, instead of up:
// rounding 1.5 D0 up to 2 cm cells put the top 2 D0 above a 3 cm orifice, and on fills 2-3 D0 deep
// (cases/hoppers) the planned runs then cost as much as the reference.
RegionBox outlet_box(const Outlet& o, double depth, double beyond, double half, double cell, const Vec3& up,
                     double floor, bool down) {
  const Vec3 n = o.normal;
  Vec3 a, b;
  config::across(o, a, b);
  RegionBox box{o.center, o.center};
  for (double sn : {beyond, -depth})
    for (double sa : {-half, half})
      for (double sb : {-half, half}) box = box.grown_to(o.center + sn * n + sa * a + sb * b);
  if (norm2(up) > 0.0) box = box.grown_to(o.center + (0.5 * o.length + depth) * up);
  for (int k = 0; k < 3; ++k) {
    const double below = o.center[k] - box.lo[k], above = box.hi[k] - o.center[k];
    if (std::abs(below - above) <= 1e-9 * cell) {
      const double n = std::ceil((below + above) / cell - 1e-9);
      box.lo[k] = o.center[k] - 0.5 * n * cell;
      box.hi[k] = o.center[k] + 0.5 * n * cell;
      continue;
    }
    box.lo[k] = o.center[k] - std::ceil(below / cell - 1e-9) * cell;
    box.hi[k] = o.center[k] + std::ceil(above / cell - 1e-9) * cell;
    if (!down || std::abs(n[k]) < 1.0 - 1e-9) continue;
    const double rounded = floor > 0.0 ? std::max(std::floor(depth / cell + 0.5 + 1e-9), std::ceil(floor / cell - 1e-9))
                                       : std::ceil(depth / cell - 1e-9);
    const double cells = std::max(rounded, kPlanCellsAbove);
    (n[k] < 0.0 ? box.hi[k] : box.lo[k]) = o.center[k] - n[k] * cells * cell;
  }
  return box;
}

RegionBox hull(const RegionBox& a, const RegionBox& b) { return a.grown_to(b.lo).grown_to(b.hi); }

bool near(const RegionBox& a, const RegionBox& b, double gap) {
  for (int k = 0; k < 3; ++k)
    if (a.lo[k] > b.hi[k] + gap || b.lo[k] > a.hi[k] + gap) return false;
  return true;
}

// A box kept inside the domain (the parser refuses a region outside it): its low side moved to the domain's,
// then as many whole cells from there as fit.
bool clip_to_domain(RegionBox& box, double cell, const config::DomainSpec& d) {
  bool clipped = false;
  for (int k = 0; k < 3; ++k) {
    const double lo = std::max(box.lo[k], d.min[k]);
    int n = static_cast<int>(std::ceil((box.hi[k] - lo) / cell - 1e-9));
    while (n > 1 && lo + n * cell > d.max[k] + 1e-12) --n;
    clipped = clipped || lo != box.lo[k] || std::abs(lo + n * cell - box.hi[k]) > 1e-9 * cell;
    box.lo[k] = lo;
    box.hi[k] = lo + n * cell;
  }
  return clipped;
}

// Cells of kPlanCellDiameters coarse diameters, to the millimetre.
double cell_for(const config::CaseSpec& cs, double coarse_alpha) {
  return std::max(0.001, std::round(kPlanCellDiameters * 2.0 * config::largest_radius(cs) * coarse_alpha * 1e3) / 1e3);
}

// One region per outlet around the finest level; regions that would touch become one. A downward outlet's depth
// goes to the nearest whole cell (floor_widths > 0) or up to one (0). (Level names are given once the regions are
// known: each fine region needs a fine level of its own.)
std::vector<Region> outlet_regions(const config::CaseSpec& cs, const std::vector<Outlet>& outlets, double h,
                                   double depth_widths, double floor_widths) {
  std::vector<Region> out;
  for (const Outlet& o : outlets) {
    const bool down = config::leaves_downward(o, cs.gravity);
    const bool nearest = down && floor_widths > 0.0;
    const Vec3 up = down || norm2(cs.gravity) == 0.0 ? Vec3{} : -1.0 * normalized(cs.gravity);
    const RegionBox box = outlet_box(o, depth_widths * o.size(), h, 0.5 * o.length + o.size(), h, up,
                                     nearest ? floor_widths * o.size() : 0.0, down);
    Region r{"", "", box, h, {&o}, {}};
    r.why.push_back(fmt::format(
        "{}: {:g} D0 deep along its inward normal{}, one cell past it, its half-length + 1 D0 across it{}", o.name,
        depth_widths,
        nearest ? fmt::format(" (to the nearest cell, at least {:g} D0 and {:g} cells: the region is alone over its "
                              "coarse level)", floor_widths, kPlanCellsAbove)
        : down  ? " (rounded up to whole cells: the regions share their coarse level)"
                : "",
        down ? "" : fmt::format(", {:g} D0 above its upper edge (it is fed from above)", depth_widths)));
    auto merge = std::find_if(out.begin(), out.end(), [&](const Region& q) { return near(q.box, r.box, h); });
    if (merge == out.end()) {
      out.push_back(r);
      continue;
    }
    merge->box = hull(merge->box, r.box);
    merge->outlets.push_back(&o);
    merge->why.push_back(r.why.front() + "; its region would touch this one's: one region around both");
  }
  return out;
}

// The finest level's regions. A region alone over its coarse level has its depth rounded to the nearest cell
// (cases/hoppers: within 2.2 % at 1.4-3.5x fewer particle-steps than rounded up); regions side by side are
// kPlanDepthSiblings deep, rounded up (config::kSiblingTopAboveOrifice: shallower ones read high).
std::vector<Region> fine_regions(const config::CaseSpec& cs, const std::vector<Outlet>& outlets, double coarse_alpha,
                                 double depth_widths, double floor_widths) {
  const double h = cell_for(cs, coarse_alpha);
  std::vector<Region> out = outlet_regions(cs, outlets, h, depth_widths, 0.0);
  if (out.size() == 1) {
    std::vector<Region> alone = outlet_regions(cs, outlets, h, depth_widths, floor_widths);
    if (alone.size() == 1) out = std::move(alone);
  } else if (depth_widths < kPlanDepthSiblings) {
    out = outlet_regions(cs, outlets, h, kPlanDepthSiblings, 0.0);
  }
  for (auto& r : out) {
    if (clip_to_domain(r.box, h, cs.domain)) r.why.push_back("kept inside [domain]: its low side at the domain's, whole cells from there");
    r.why.push_back(fmt::format("cells of {:g} m: {:g} coarse diameters ({:g} mm at alpha {:g})", h,
                                h / (2e3 * config::largest_radius(cs) * coarse_alpha) * 1e3, 2e3 * config::largest_radius(cs) * coarse_alpha,
                                coarse_alpha));
  }
  return out;
}

// Every probe inside a finest region: the nearest one grows to hold it.
void hold_probes(const config::CaseSpec& cs, std::vector<Region>& regions) {
  for (const auto& p : cs.probes) {
    if (std::any_of(regions.begin(), regions.end(), [&](const Region& r) { return r.box.contains(p.point); }))
      continue;
    auto r = std::min_element(regions.begin(), regions.end(), [&](const Region& a, const Region& b) {
      return a.box.distance(p.point) < b.box.distance(p.point);
    });
    const RegionBox grown = r->box.grown_to(p.point);
    r->box.lo = grown.lo;  // whole cells from min: the top rounds up when read
    r->box.hi = grown.hi;
    r->why.push_back(fmt::format("grown to hold probe '{}' at {}", p.name, vec(p.point)));
  }
}

// The coarsest level's region around each fine one: two of its cells deeper, one wider, as silo_paper's three
// levels (the middle region's top 3.5 D0 above the orifice).
Region outer_region(const config::CaseSpec& cs, const Region& inner, const Level& coarsest) {
  const double h = cell_for(cs, coarsest.alpha);
  Region r{coarsest.name, inner.coarse, inner.box, h, inner.outlets, {}};
  for (const Outlet* o : inner.outlets) {
    const Vec3 in = -1.0 * o->normal;
    for (int k = 0; k < 3; ++k) {
      const double grow_lo = in[k] < -0.5 ? 2.0 * h : h, grow_hi = in[k] > 0.5 ? 2.0 * h : h;
      r.box.lo[k] = std::min(r.box.lo[k], inner.box.lo[k] - grow_lo);
      r.box.hi[k] = std::max(r.box.hi[k], inner.box.hi[k] + grow_hi);
    }
  }
  r.why.push_back(fmt::format("around region of level '{}': two {:g} m cells deeper along the outlets' inward "
                              "normal, one wider", inner.fine, h));
  if (clip_to_domain(r.box, h, cs.domain)) r.why.push_back("kept inside [domain]: its low side at the domain's, whole cells from there");
  return r;
}

// The levels of the plan, coarsest first: the reference's level as each fine region's own finest level (a fine
// level belongs to one region), coarse levels at 2x (and 4x) its alpha with dt scaled alike; the coarsest is
// shared. Names the regions' levels. One region: "coarse" / "fine", as the shipped hierarchies.
std::vector<Level> plan_levels(const config::CaseSpec& cs, int count, std::vector<Region>& inner,
                               std::vector<Region>& outer) {
  const auto& ref = cs.levels.front();
  auto level = [&](const std::string& name, double f, int ranks) { return Level{name, ref.alpha * f, ref.dt * f, ranks}; };
  std::vector<Level> out{level(count == 3 ? "coarsest" : "coarse", count == 3 ? 4.0 : 2.0, 1)};
  for (size_t k = 0; k < inner.size(); ++k) {
    const std::string tag = inner.size() > 1 ? std::to_string(k) : "";
    inner[k].coarse = count == 3 ? "coarse" + tag : "coarse";
    inner[k].fine = "fine" + tag;
    if (count == 3) out.push_back(level(inner[k].coarse, 2.0, 1));
    out.push_back(level(inner[k].fine, 1.0, ref.ranks));
  }
  if (count == 3)
    for (const auto& r : inner) outer.push_back(outer_region(cs, r, out.front()));
  return out;
}

// Each event at a fixed time: the time it fired in the reference run, else its `latest`.
std::string events_text(const config::CaseSpec& cs, const std::string& reference_run, std::vector<std::string>& why) {
  nlohmann::json fired = nlohmann::json::array();
  if (!reference_run.empty()) {
    const auto s = read_json_or_null(fs::path(reference_run) / "summary.json");
    if (!s.is_object()) throw PlanError(reference_run + ": no readable summary.json; give a run folder of the case");
    fired = s.value("events", nlohmann::json::array());
  }
  std::string out;
  for (const auto& e : cs.events) {
    double at = e.at;
    if (at < 0.0) {
      for (const auto& f : fired)
        if (f.value("name", "") == e.name && f.value("fired", false)) at = f.value("time", -1.0);
      if (at >= 0.0) {
        why.push_back(fmt::format("event '{}' at t = {:g} s: when it fired in {}", e.name, at, reference_run));
      } else if (std::isfinite(e.latest)) {
        at = e.latest;
        why.push_back(fmt::format("event '{}' at its latest, t = {:g} s: a hierarchy's levels must open together, "
                                  "so a condition needs a fixed time; give --reference-run RUN (a run of the case) "
                                  "to use the time it fired there", e.name, at));
      } else {
        throw PlanError(fmt::format("{}: event '{}' fires on a condition with no `latest`: a hierarchy's levels must "
                                    "open together; give --reference-run RUN (a completed run of the case) to take the "
                                    "time it fired there", e.loc.str(), e.name));
      }
    }
    out += fmt::format("\n[[events]]\nname = \"{}\"\nat = {}\nremove_walls = [", e.name, num(at));
    for (size_t k = 0; k < e.remove_walls.size(); ++k) out += fmt::format("{}\"{}\"", k ? ", " : "", e.remove_walls[k]);
    out += "]\n";
  }
  return out;
}

std::string region_text(const config::CaseSpec& cs, const Region& r, bool finest) {
  std::string out = "\n[[coupling.regions]]\n";
  for (const auto& w : r.why) out += "# " + w + "\n";
  out += fmt::format("coarse = \"{}\"\nfine = \"{}\"\nmin = {}\nmax = {}\ncell_size = {}\n", r.coarse, r.fine,
                     vec(r.box.lo), vec(r.box.hi), num(r.cell));
  const Outlet& o = *r.outlets.front();
  if (config::leaves_downward(o, cs.gravity))
    out += fmt::format("velocity_only_below = {}   # below the outlet: pure velocity coupling\n", num(o.center.z));
  else if (finest)
    out += fmt::format("inside = {}   # a point inside the vessel, along the outlet's inward normal\n",
                       vec(o.center - 0.5 * o.size() * o.normal));
  return out;
}

// The case as the variant's `base`: relative to the variant's folder when that stays inside the case's tree.
std::string base_path(const std::string& case_file, const fs::path& out) {
  const fs::path abs = fs::absolute(case_file).lexically_normal();
  const fs::path rel = abs.lexically_relative(fs::absolute(out).parent_path().lexically_normal());
  return !rel.empty() && *rel.begin() != ".." ? rel.string() : abs.string();
}

struct Plan {
  std::vector<Level> levels;
  std::vector<Region> regions;  // outer ones first
  std::vector<std::string> why;
  std::string text;
};

Plan make_plan(const config::CaseSpec& cs, const config::OutletScan& scan, const PlanOptions& o, const fs::path& out) {
  Plan p;
  const double depth = o.error < 3.0 ? kPlanDepthOnePercent : kPlanDepth;
  const double floor = o.error < 3.0 ? config::kOnePercentTopAboveOrifice : config::kAdvisedTopAboveOrifice;
  auto inner = fine_regions(cs, scan.outlets, 2.0 * cs.levels.front().alpha, depth, floor);
  hold_probes(cs, inner);
  p.levels = plan_levels(cs, o.levels, inner, p.regions);
  p.regions.insert(p.regions.end(), inner.begin(), inner.end());
  std::string text = fmt::format(
      "# Written by `mlcg plan` from {} (--error {:g}, --levels {}): the scene's {} outlet(s) {}, one "
      "fine region per outlet (one around outlets whose regions would touch), sized by the region rules' evidence.\n"
      "base = \"{}\"\ntitle = \"{} (MLCG as planned: {} levels)\"\n",
      cs.path, o.error, o.levels, scan.outlets.size(),
      cs.orifices.empty() ? "found in its walls" : "given by [orifice] / [[orifices]]", base_path(cs.path, out),
      cs.title, o.levels);
  for (const auto& l : p.levels)
    text += fmt::format("\n[[levels]]\nname = \"{}\"\nalpha = {}\ndt = {}\n{}", l.name, num(l.alpha), num(l.dt),
                        l.ranks > 1 ? fmt::format("ranks = {}\n", l.ranks) : "");
  text += events_text(cs, o.reference_run, p.why);
  text += "\n[coupling]                 # interval automatic: the smallest multiple of every dt >= 15 finest steps\n";
  for (const auto& r : p.regions) text += region_text(cs, r, r.fine.rfind("fine", 0) == 0);
  p.text = text;
  return p;
}

// The variant as `mlcg run` would check it: the region rules, the coupler's grids, every level's guard.
config::CaseSpec check_plan(const Plan& p, const fs::path& out) {
  const config::CaseSpec v = config::parse_case(p.text, out.string());
  const auto rules = config::check_region_rules(v, find_outlets(v), vessel_crossing(v));
  for (const auto& w : rules.warnings) std::printf("  warning: %s\n", w.c_str());
  if (!rules.errors.empty()) {
    std::string all;
    for (const auto& e : rules.errors) all += "\n  " + e;
    throw PlanError("the planned hierarchy does not pass the region rules:" + all);
  }
  coupling::coupling_from_case(v);
  for (const auto& l : v.levels) preview_level(v, l);
  return v;
}

void print_plan(const config::CaseSpec& cs, const config::OutletScan& scan, const Plan& p) {
  std::printf("mlcg plan: %s, %zu outlet(s)\n", cs.path.c_str(), scan.outlets.size());
  for (const auto& o : scan.outlets) std::printf("  %s\n", config::outlet_text(o).c_str());
  for (const auto& l : p.levels) std::printf("level '%s': alpha %g, dt %g s\n", l.name.c_str(), l.alpha, l.dt);
  for (size_t k = 0; k < p.regions.size(); ++k) {
    const auto& r = p.regions[k];
    std::printf("region %zu ('%s' -> '%s'): min %s, max %s, cells of %g m\n", k, r.coarse.c_str(), r.fine.c_str(),
                vec(r.box.lo).c_str(), vec(r.box.hi).c_str(), r.cell);
    for (const auto& w : r.why) std::printf("  %s\n", w.c_str());
  }
  for (const auto& w : p.why) std::printf("%s\n", w.c_str());
}

}  // namespace

int plan_case(const PlanOptions& o) {
  try {
    const fs::path out(o.out);
    if (fs::exists(out)) throw PlanError(o.out + " exists; give another --out (nothing is overwritten)");
    if (o.levels != 2 && o.levels != 3) throw PlanError(fmt::format("--levels {}: allowed 2 or 3", o.levels));
    if (o.error < 1.0)
      throw PlanError(fmt::format("--error {:g}: no planned hierarchy was measured closer than about 1 % (silo_small "
                                  "with its region 2 D0 deep: +0.4 %); allowed >= 1", o.error));
    const config::CaseSpec cs = config::load_case(o.case_file);
    if (cs.levels.size() != 1)
      throw PlanError(o.case_file + " has " + std::to_string(cs.levels.size()) +
                      " levels; mlcg plan takes a single-level case (the fully resolved reference)");
    const auto scan = find_outlets(cs);
    if (scan.outlets.empty()) {
      const bool moving = std::any_of(cs.walls.begin(), cs.walls.end(), [](const auto& w) { return w.moving(); });
      // A drum or a belt without an outlet: the fine region would follow a flowing layer, which is not planned.
      throw PlanError(o.case_file + ": no outlet found in its walls; " +
                      (moving ? "mlcg plan places fine regions around outlets, and a scene whose flow leaves through "
                                "none (a drum's flowing layer, the shear zone over a belt) cannot be planned yet"
                              : "give [orifice] or [[orifices]] for an opening the walls do not show (cases/README.md)"));
    }
    const Plan p = make_plan(cs, scan, o, out);
    print_plan(cs, scan, p);
    const config::CaseSpec v = check_plan(p, out);
    const double end = estimated_end(v);
    if (end > 0.0) {
      const double ref = particle_steps_to(cs, end), mlcg = particle_steps_to(v, end);
      std::printf("expected cost: %.3g particle-steps against the reference's %.3g to t = %.3g s: %.2fx %s (the "
                  "estimate of `mlcg check`)\n", mlcg, ref, end, ref >= mlcg ? ref / mlcg : mlcg / ref,
                  ref >= mlcg ? "fewer" : "more");
      if (ref < 2.0 * mlcg)
        std::printf("note: less than 2x fewer: the fine regions hold much of the scene; on a vessel this small MLCG buys "
                    "accuracy, not speed\n");
    }
    if (out.has_parent_path()) fs::create_directories(out.parent_path());
    io::write_file_atomic(out, p.text);
    std::printf("wrote %s; run it with `mlcg run %s`, compare it with `mlcg study`\n", o.out.c_str(), o.out.c_str());
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 2;
  }
}

}  // namespace mlcg::launcher
