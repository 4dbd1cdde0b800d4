#include "config/region_rules.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "config/regions.hpp"

namespace mlcg::config {
namespace {

double alpha_of(const CaseSpec& cs, const std::string& level) {
  for (const LevelSpec& l : cs.levels)
    if (l.name == level) return l.alpha;
  return 1.0;
}

// One region being checked: where its messages point and what they need.
struct Check {
  const CouplingRegionSpec& r;
  std::string path;     // "coupling.regions[0]"
  double d_coarse;      // coarse diameter [m]
  std::string d_text;   // "level 'coarse' (alpha 2 x the largest insertion diameter 2.8 mm = 5.6 mm)"
  std::string at(const std::string& key) const {
    return fmt::format("{}: {}.{}", r.loc_of(key).str(), path, key);
  }
};

void check_cells(const Check& c, RegionRuleReport& out) {
  const double ratio = c.r.cell_size / c.d_coarse;
  const std::string what =
      fmt::format("{}: cell_size = {:g} m is {:.2f} coarse diameters of {}; ", c.at("cell_size"), c.r.cell_size, ratio,
                  c.d_text);
  if (ratio > kMostCellDiameters) {
    out.warnings.push_back(what + fmt::format(
        "above the advised {:g}-{:g}: the transition layer is one cell deep, so the stress the fine level is "
        "pressed with is averaged over {:.3g} m, and the coupler samples the walls {} times along a cell's edge, "
        "so it misses walls closer than {:.3g} m (a cell's volume inside the walls is then overestimated); "
        "cell_size <= {:.3g} m would be within the advised range",
        kAdvisedCellDiameters, kMostCellDiameters, c.r.cell_size, kWallSamplesPerCell,
        c.r.cell_size / kWallSamplesPerCell, kMostCellDiameters * c.d_coarse));
    return;
  }
  if (ratio >= kAdvisedCellDiameters) return;
  if (ratio < kMinCellDiameters) {
    out.errors.push_back(what + fmt::format(
        "a cell that small holds fewer than about 9 coarse particles when packed (one particle moves its volume "
        "fraction by more than 10 %), so the coarse statistics the coupler controls on are noise; give cell_size "
        ">= {:.3g} m ({:g} coarse diameters; {:g}-10 advised, the paper's 2 cm cells are 3.6)",
        kMinCellDiameters * c.d_coarse, kMinCellDiameters, kAdvisedCellDiameters));
    return;
  }
  out.warnings.push_back(what + fmt::format(
      "below the advised {:g}-{:g} (about 31 coarse particles per packed cell); the cell statistics are noisy, "
      "cell_size >= {:.3g} m would be within the advised range",
      kAdvisedCellDiameters, kMostCellDiameters, kAdvisedCellDiameters * c.d_coarse));
}

// Ratios computed from rounded coordinates (a box of whole cells, a mesh's extents) meet a threshold they
// equal in decimals: a top exactly 1.0 D0 above passes.
constexpr double kEdge = 1e-9;

// How far the region's box reaches from the outlet's centre along its inward normal, and the face that
// limits it (for an outlet in a floor: the box's top, max z).
struct Reach {
  double depth = INFINITY;  // [m]
  int axis = 2;
  bool upper = true;        // the limiting face is the box's max side on `axis`
  const char* key() const { return upper ? "max" : "min"; }
  char axis_name() const { return "xyz"[axis]; }
  // The face's coordinate at which the region would reach `widths` D0.
  double face_for(const Outlet& o, double widths) const {
    return o.center[axis] - o.normal[axis] * widths * o.size();
  }
};

Reach reach_of(const RegionBox& b, const Outlet& o) {
  Reach r;
  for (int a = 0; a < 3; ++a) {
    const double in = -o.normal[a];
    if (std::abs(in) < 1e-9) continue;
    const double t = ((in > 0.0 ? b.hi[a] : b.lo[a]) - o.center[a]) / in;
    if (t < r.depth) r = {t, a, in > 0.0};
  }
  return r;
}

std::string outlet_ref(const Outlet& o) {
  return fmt::format("'{}', D0 = {:g} m, from {}", o.name, o.size(), o.from);
}

// Too few cells above the orifice (kAdvisedCellsAboveOrifice): a warning, not a refusal: the one scene measured
// at one cell (the hourglass) also has a neck its coarse particles jam in, so it does not show how far off
// every such region is. Returns false when it warned (no accuracy is then promised); silent when the top is
// below 1 D0, which check_top refuses with its own fix.
bool check_cells_above(const Check& c, const RegionBox& box, const Outlet& o, RegionRuleReport& out) {
  const double cells = (box.hi.z - o.center.z) / c.r.cell_size + kEdge;
  if (cells >= kAdvisedCellsAboveOrifice || (box.hi.z - o.center.z) / o.size() + kEdge < kMinTopAboveOrifice)
    return true;
  const std::string is = fmt::format(
      "the region's top is z = {:g} m, {:.2f} cells of {:g} m above the orifice ({}); the top cell is the "
      "transition layer (the hourglass's neck one cell below the top: -17.9 % off a fully resolved run, two cells: "
      "+3.5 %; the hoppers, 1.8-2 cells: within 3 %); raise max z to {:g} m or use smaller cells",
      box.hi.z, cells, c.r.cell_size, outlet_ref(o), o.center.z + 2.0 * c.r.cell_size);
  out.warnings.push_back(fmt::format(
      "{}: {}; below the advised {:g} cells no accuracy is promised{}", c.at("max"), is, kAdvisedCellsAboveOrifice,
      cells <= 1.0 + 2.0 * kEdge ? " (with one cell there is no correction cell between the transition layer and the "
                                   "orifice: the fine particles are placed straight over it)"
                                 : ""));
  return false;
}

// An outlet the flow leaves downward: the region's top above it (the thresholds' own frame).
void check_top(const Check& c, const RegionBox& box, const Outlet& o, bool vouched, RegionRuleReport& out) {
  vouched = check_cells_above(c, box, o, out) && vouched;
  const double above = (box.hi.z - o.center.z) / o.size() + kEdge;
  if (above >= kOnePercentTopAboveOrifice || (!vouched && above >= kAdvisedTopAboveOrifice)) return;
  const std::string is = fmt::format("the region's top is z = {:g} m, {:.2f} orifice diameters above the orifice ({})",
                                     box.hi.z, above, outlet_ref(o));
  if (above >= kAdvisedTopAboveOrifice) {
    out.notes.push_back(fmt::format(
        "{}: {}: expect the discharge through '{}' within about 3 % of a fully resolved run; for about 1 % raise max "
        "z to {:g} m ({:g} D0; silo_small: +1.2 % at 1.5 D0, +0.4 % at 2 D0), at the cost of more fine particles",
        c.at("max"), is, o.name, o.center.z + kOnePercentTopAboveOrifice * o.size(), kOnePercentTopAboveOrifice));
    return;
  }
  if (above >= kMinTopAboveOrifice) {
    out.warnings.push_back(fmt::format(
        "{}: {}, below the advised {:g}, the lowest height measured within 3 % of the reference (seven hoppers with "
        "their tops at 1.13-1.5 D0, cases/hoppers/README.md); max z >= {:g} m is advised",
        c.at("max"), is, kAdvisedTopAboveOrifice, o.center.z + kAdvisedTopAboveOrifice * o.size()));
    return;
  }
  out.errors.push_back(fmt::format(
      "{}: {} (its boundary surface: max z rounded up to whole {:g} m cells; the orifice at z = {:g} m); at least "
      "{:g} D0 is needed: with the boundary surface 0.6 D0 above the orifice the discharge was more than 10 % off "
      "the reference, at 1.1 D0 within 3 %; raise max z to at least {:g} m, or give [orifice] if the orifice is "
      "another one",
      c.at("max"), is, c.r.cell_size, o.center.z, kMinTopAboveOrifice, o.center.z + kMinTopAboveOrifice * o.size()));
}

// An outlet in a side wall or an inclined one: the region's depth along the outlet's inward normal. The
// 1 D0 minimum carries over; no measurement backs the rest, so never a promise, always a warning.
void check_depth_tilted(const Check& c, const RegionBox& box, const Outlet& o, const Vec3& gravity,
                        RegionRuleReport& out) {
  const Reach r = reach_of(box, o);
  const double deep = r.depth / o.size() + kEdge;
  const double g = norm(gravity);
  const double angle = g > 0.0 ? std::acos(std::clamp(dot(o.normal, gravity / g), -1.0, 1.0)) * 180.0 / std::numbers::pi : 90.0;
  const std::string is = fmt::format(
      "the region reaches {:.2f} outlet widths into the vessel from outlet {} along its inward normal {} (to its "
      "{} {} face at {:g} m)",
      deep, outlet_ref(o), fmt::format("[{:.3g}, {:.3g}, {:.3g}]", 0.0 - o.normal.x, 0.0 - o.normal.y, 0.0 - o.normal.z),
      r.key(), r.axis_name(), r.upper ? box.hi[r.axis] : box.lo[r.axis]);
  if (deep < kMinTopAboveOrifice) {
    out.errors.push_back(fmt::format(
        "{}: {}; at least {:g} D0 is needed (with a floor outlet's boundary surface 0.6 D0 above it the discharge "
        "was more than 10 % off); {} {} {} to {} {:g} m",
        c.at(r.key()), is, kMinTopAboveOrifice, r.upper ? "raise" : "lower", r.key(), r.axis_name(),
        r.upper ? "at least" : "at most", r.face_for(o, kAdvisedTopAboveOrifice)));
    return;
  }
  out.warnings.push_back(fmt::format(
      "{}: {}; the outlet faces {:.0f} degrees away from gravity, and the region rules were measured on outlets the "
      "flow leaves downward (a side outlet, cases/outlets/side_outlet, as mlcg plan writes it: +1.1 % over three "
      "seeds, which spread from -1.0 to +3.2 %; its region cut to 1.17 D0 above the hole: +8.6 %): this region's "
      "accuracy is not vouched for; compare it with a fully resolved run (mlcg study)",
      c.at(r.key()), is, angle));
}

void check_passage(const Check& c, const Outlet& o, bool held, RegionRuleReport& out) {
  const double ratio = o.size() / c.d_coarse;
  if (ratio + kEdge >= kJammingRatio) return;
  const std::string what = fmt::format(
      "{}: the orifice ({}) is only {:.2f} coarse diameters wide ({}), below the jamming ratio D0 / d = {:g} for "
      "spheres through a circular orifice (Zuriguel et al., Phys. Rev. E 71, 051303, 2005)",
      c.at("coarse"), outlet_ref(o), ratio, c.d_text, kJammingRatio);
  if (held) {
    out.warnings.push_back(what + "; a fine region contains the orifice, so the coarse level's flow through it "
                                  "relies on the correction cells");
    return;
  }
  out.errors.push_back(what + fmt::format(
      " and no fine region over level '{}' contains it, so the coarse level would jam; extend the region over the "
      "orifice at [{:g}, {:g}, {:g}], or couple a coarse level with D0 / d >= {:g}",
      c.r.coarse, o.center.x, o.center.y, o.center.z, kJammingRatio));
}

// How far the box reaches from p along the unit direction u (0 when p is outside it that way).
double reach_along(const RegionBox& b, const Vec3& p, const Vec3& u) {
  double t = INFINITY;
  for (int k = 0; k < 3; ++k)
    if (std::abs(u[k]) > 1e-9) t = std::min(t, ((u[k] > 0.0 ? b.hi[k] : b.lo[k]) - p[k]) / u[k]);
  return std::max(t, 0.0);
}

// Across the outlet, half a width into the vessel: kMinLateralMargin D0 past its rim each way, unless a wall
// ends the vessel first. False (with a warning per direction) when the region falls short.
bool check_lateral(const Check& c, const RegionBox& box, const Outlet& o, const WallCrossing& crosses,
                   RegionRuleReport& out) {
  if (!crosses || !box.contains(o.center)) return true;
  Vec3 a, b;
  across(o, a, b);
  const Vec3 p = o.center - 0.5 * o.size() * o.normal;
  const double rim = 0.5 * o.length;
  bool ok = true;
  for (const Vec3& u : {a, -1.0 * a, b, -1.0 * b}) {
    const Vec3 q = p + (rim + (kMinLateralMargin - kEdge) * o.size()) * u;  // a face exactly there passes
    if (box.contains(q) || crosses(p, q)) continue;
    int k = 0;
    for (int i = 1; i < 3; ++i) k = std::abs(u[i]) > std::abs(u[k]) ? i : k;
    out.warnings.push_back(fmt::format(
        "{}: the region reaches {:.2f} outlet widths past the rim of outlet {} toward {} (half a width into the "
        "vessel), where the vessel goes on; the margins measured within 3 % reach at least {:g} (cases/hoppers/"
        "offcentre_bin: 0.5 across its outlet, -1.9 +- 2.7 %), so no accuracy is promised; widen the region to "
        "hold {}",
        c.at(u[k] > 0.0 ? "max" : "min"), (reach_along(box, p, u) - rim) / o.size() + 0.0, outlet_ref(o),
        vec_text(u), kMinLateralMargin, vec_text(q)));
    ok = false;
  }
  return ok;
}

// Fine regions side by side over one coarse level read high when shallow (kSiblingTopAboveOrifice): true when
// this one is vouched for as a region alone would be (alone, or its top deep enough over each downward outlet).
bool check_siblings(const Check& c, long n, const RegionBox& box, const std::vector<const Outlet*>& outlets,
                    const Vec3& gravity, RegionRuleReport& out) {
  if (n < 2) return true;
  const Outlet* shallow = nullptr;
  for (const Outlet* o : outlets)
    if (!leaves_downward(*o, gravity) || (box.hi.z - o->center.z) / o->size() + kEdge < kSiblingTopAboveOrifice)
      shallow = o;
  if (!shallow) return true;
  const bool down = leaves_downward(*shallow, gravity);
  out.warnings.push_back(fmt::format(
      "{}: level '{}' is the coarse level of {} fine regions, and {}; regions side by side over one coarse level "
      "read high when shallow: with the tops at least {:g} D0 above their outlets (as mlcg plan writes them) "
      "cases/outlets/three_outlets' three outlets were -1.7 to +6.4 % per seed and +0.2 to +1.6 % over three seeds, "
      "two_outlets +0.9 % and -0.1 %; with a top at 1.6 D0 an outlet read +3.0 % over three seeds, at 1.33 D0 "
      "+5.4 %, and a hand-written two-outlet bin with tops about 1 D0 +26 % and +10 %: this region's accuracy is "
      "not vouched for; {}",
      c.at("coarse"), c.r.coarse, n,
      down ? fmt::format("this region's top is {:.2f} D0 above the orifice ({})", (box.hi.z - shallow->center.z) / shallow->size(),
                         outlet_ref(*shallow))
           : fmt::format("its outlet ({}) is not one the flow leaves downward", outlet_ref(*shallow)),
      kSiblingTopAboveOrifice,
      down ? fmt::format("raise max z to at least {:g} m ({:g} D0), or compare it with a fully resolved run (mlcg study)",
                         shallow->center.z + kSiblingTopAboveOrifice * shallow->size(), kSiblingTopAboveOrifice)
           : std::string("compare it with a fully resolved run (mlcg study)")));
  return false;
}

// The outlets a region is judged against: those its box contains, else the nearest one.
std::vector<const Outlet*> judged_outlets(const RegionBox& box, const OutletScan& scan) {
  std::vector<const Outlet*> in;
  const Outlet* nearest = nullptr;
  for (const Outlet& o : scan.outlets) {
    if (box.contains(o.center)) in.push_back(&o);
    if (!nearest || box.distance(o.center) < box.distance(nearest->center)) nearest = &o;
  }
  if (in.empty() && nearest) in.push_back(nearest);
  return in;
}

bool held_over(const CaseSpec& cs, const std::string& coarse, const Outlet& o) {
  return std::any_of(cs.coupling->regions.begin(), cs.coupling->regions.end(), [&](const CouplingRegionSpec& r) {
    return r.coarse == coarse && region_box(r).contains(o.center);
  });
}

// A probe no fine region holds is read from a coarse level: say so, and what would hold it.
void check_probes(const CaseSpec& cs, RegionRuleReport& out) {
  double finest = INFINITY;
  for (const LevelSpec& l : cs.levels) finest = std::min(finest, l.alpha);
  for (size_t k = 0; k < cs.probes.size(); ++k) {
    const ProbeSpec& p = cs.probes[k];
    const LevelSpec& l = cs.levels[resolving_level(cs, p.point)];
    if (l.alpha <= finest) continue;
    size_t best = 0;
    for (size_t i = 1; i < cs.coupling->regions.size(); ++i)
      if (region_box(cs.coupling->regions[i]).distance(p.point) < region_box(cs.coupling->regions[best]).distance(p.point))
        best = i;
    const RegionBox grown = region_box(cs.coupling->regions[best]).grown_to(p.point);
    out.warnings.push_back(fmt::format(
        "{}: probes[{}].point: probe '{}' at [{:g}, {:g}, {:g}] lies in no fine region, so its mass flow is read "
        "from level '{}' (alpha {:g}), not from a fine level; coupling.regions[{}] would hold it with min = [{:g}, "
        "{:g}, {:g}], max = [{:g}, {:g}, {:g}]",
        p.loc.str(), k, p.name, p.point.x, p.point.y, p.point.z, l.name, l.alpha, best, grown.lo.x, grown.lo.y,
        grown.lo.z, grown.hi.x, grown.hi.y, grown.hi.z));
  }
}

}  // namespace

bool leaves_downward(const Outlet& o, const Vec3& gravity) {
  const double g = norm(gravity);
  return g > 0.0 && dot(o.normal, gravity / g) >= kMeasuredTiltCos;
}

double largest_radius(const CaseSpec& cs) {
  double r = 0.0;
  for (const InsertionSpec& in : cs.insertions) r = std::max(r, in.radius.largest());
  for (const ParticleSpec& p : cs.particles) r = std::max(r, p.radius);
  return r;
}

// A drum or a belt with no outlet: the bulk circulates through the region's faces both ways. The coupling
// hands over its top and open sides (coarse mass crossing in is placed as fine, fine mass leaving is handed
// back), not its bottom: a region whose bottom lies inside the vessel would have fine particles leave
// downward unnoticed and coarse ones enter from below uncounted. A region reaching through the bed to below
// the walls (a slice through a drum) has no such face. Without `crosses` the bottom cannot be placed.
bool bottom_inside_vessel(const CaseSpec& cs, const CouplingRegionSpec& r, const WallCrossing& crosses) {
  if (!crosses) return true;
  Vec3 from;
  if (r.inside) {
    from = *r.inside;
  } else if (!cs.insertions.empty()) {
    from = 0.5 * (cs.insertions.front().region.min + cs.insertions.front().region.max);
  } else {
    return true;
  }
  constexpr int kSamples = 8;  // per side of the bottom face
  const double z = r.min.z + 1e-6 * r.cell_size;
  for (int j = 0; j < kSamples; ++j)
    for (int i = 0; i < kSamples; ++i) {
      const Vec3 q{r.min.x + (i + 0.5) / kSamples * (r.max.x - r.min.x),
                   r.min.y + (j + 0.5) / kSamples * (r.max.y - r.min.y), z};
      if (!crosses(from, q)) return true;
    }
  return false;
}

void check_closed_moving(const Check& c, const CaseSpec& cs, const OutletScan& scan, const WallCrossing& crosses,
                         RegionRuleReport& out) {
  if (!scan.outlets.empty()) return;
  const auto w = std::find_if(cs.walls.begin(), cs.walls.end(),
                              [](const WallSpec& x) { return x.moving() || x.moves_rigidly(); });
  if (w == cs.walls.end()) return;
  if (c.r.open_bottom) return;  // refused for every scene (check_open_bottom)
  if (!bottom_inside_vessel(cs, c.r, crosses)) {
    // Measured on cases/drum (4 s, angle of the coarse level's bed against the fully resolved 31.35 deg).
    out.warnings.push_back(fmt::format(
        "{}: the scene has no outlet and wall '{}' moves: the region is a slice through the bed, which the flow "
        "enters and leaves through its sides; no accuracy is promised: the fine flowing layer must develop "
        "along the region, so it must span the layer's length (cases/drum: a slice 5 cm across of the surface's "
        "6.6 cm gave the angle within 0.3 deg and the layer's thickness within 1.3 %, holding 84 % of the bed; "
        "slices 2.5 and 3 cm across gave +8.3 and +21 deg)",
        c.at("min"), w->name));
    return;
  }
  out.errors.push_back(fmt::format(
      "{}: the scene has no outlet and wall '{}' moves (a drum or a belt), so the flow circulates through the "
      "region's faces both ways; the coupling hands over the top and the open sides, not the bottom, and this "
      "region's bottom (z = {:g} m) lies inside the vessel: fine particles leaving downward would stay on the "
      "fine level and coarse ones entering from below would not be counted; reach min z below the walls (a slice "
      "through the bed, entered and left through its sides) or run the scene on one level",
      c.at("min"), w->name, c.r.min.z));
}

// Measured (cases/drum with gravity turned by the angle of repose, so that its surface lies flat, a region
// 1.4 cm deep over the whole surface with open_bottom, 4 s): the coarse level's surface 20.3 deg against the fully
// resolved run's 31.5, its layer at 0.043 m/s against 0.204; with the fine particles over the bottom also drawn
// toward the coarse velocity along it (an experiment, not kept) 19.6 deg. With the coarse level uncorrected the
// fine level's own surface tilts 9 deg toward the downhill end of the region: the fine layer piles up where it
// should leave through the bottom and the downhill side, whose inward traction stands against the outflow.
void check_open_bottom(const Check& c, const std::vector<const Outlet*>& judged, RegionRuleReport& out) {
  if (!c.r.open_bottom) return;
  if (!judged.empty())
    out.errors.push_back(fmt::format(
        "{}: the region holds outlet '{}'; an open bottom hands back to the coarse level what sinks through it, "
        "so the outlet's discharge would be handed back instead of leaving; leave the bottom closed (the "
        "default) for a region around an outlet",
        c.at("open_bottom"), judged.front()->name));
  out.errors.push_back(fmt::format(
      "{}: an open bottom is not supported yet: a fine layer over it does not flow as it should (a drum's surface "
      "measured 11 deg flatter than the fully resolved run's, its layer at a fifth of the speed); leave the bottom "
      "closed, and reach min z below the walls for a region a drum's bulk crosses (a slice through the bed)",
      c.at("open_bottom")));
}

RegionRuleReport check_region_rules(const CaseSpec& cs, const OutletScan& scan, const WallCrossing& crosses) {
  RegionRuleReport out;
  if (!cs.coupling) return out;
  if (scan.outlets.empty())
    out.notes.push_back(cs.path + ": no outlet found (no opening in the walls, none under a removed lid, no "
                                  "[orifice]); the outlet rules of the coupling regions are skipped; give [orifice] "
                                  "or [[orifices]] to check them");
  check_probes(cs, out);
  const double r_max = largest_radius(cs);
  if (r_max <= 0.0) {
    out.notes.push_back(cs.path + ": no [[insertion]] or [[particles]] radius; the region rules are skipped");
    return out;
  }
  for (size_t i = 0; i < cs.coupling->regions.size(); ++i) {
    const CouplingRegionSpec& r = cs.coupling->regions[i];
    const double alpha = alpha_of(cs, r.coarse);
    const double d = 2.0 * r_max * alpha;
    const Check c{r, fmt::format("coupling.regions[{}]", i), d,
                  fmt::format("level '{}': alpha {:g} x the largest insertion diameter {:g} mm = {:g} mm", r.coarse,
                              alpha, 2e3 * r_max, 1e3 * d)};
    check_cells(c, out);
    check_closed_moving(c, cs, scan, crosses, out);
    const long over_coarse = std::count_if(cs.coupling->regions.begin(), cs.coupling->regions.end(),
                                           [&](const CouplingRegionSpec& q) { return q.coarse == r.coarse; });
    const RegionBox box = region_box(r);
    const std::vector<const Outlet*> judged = judged_outlets(box, scan);
    check_open_bottom(c, judged, out);
    const bool as_alone = check_siblings(c, over_coarse, box, judged, cs.gravity, out);
    for (const Outlet* o : judged) {
      const bool margins = check_lateral(c, box, *o, crosses, out);
      if (leaves_downward(*o, cs.gravity))
        check_top(c, box, *o, as_alone && margins, out);
      else
        check_depth_tilted(c, box, *o, cs.gravity, out);
      check_passage(c, *o, held_over(cs, r.coarse, *o), out);
    }
  }
  return out;
}

}  // namespace mlcg::config
