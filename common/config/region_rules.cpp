#include "config/region_rules.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <set>

namespace mlcg::config {
namespace {

// A circular opening the walls leave: a cone's or cylinder's bottom circle, a disk's hole.
struct Opening {
  Vec3 center;
  double radius = 0.0;
  std::string what;  // "cone 'cone'"
};

std::set<std::string> removed_walls(const CaseSpec& cs) {
  std::set<std::string> out;
  for (const EventSpec& e : cs.events) out.insert(e.remove_walls.begin(), e.remove_walls.end());
  return out;
}

Vec3 unit(const Vec3& a) { return a / norm(a); }

std::vector<Opening> openings(const CaseSpec& cs, const std::set<std::string>& removed) {
  std::vector<Opening> out;
  for (const WallSpec& w : cs.walls) {
    if (removed.count(w.name)) continue;
    const Vec3 bottom = w.center + w.bottom * unit(w.axis);
    if (w.type == WallType::Cone && w.radius_bottom > 0.0)
      out.push_back({bottom, w.radius_bottom, "cone '" + w.name + "'"});
    else if (w.type == WallType::Cylinder)
      out.push_back({bottom, w.radius, "cylinder '" + w.name + "'"});
    else if (w.type == WallType::Disk && w.inner_radius > 0.0)
      out.push_back({w.center, w.inner_radius, "the hole of disk '" + w.name + "'"});
  }
  return out;
}

// The narrowest opening a removed disk (a lid) covers, or the lid itself.
std::optional<Orifice> orifice_under_lid(const CaseSpec& cs, const std::set<std::string>& removed) {
  const auto holes = openings(cs, removed);
  for (const WallSpec& lid : cs.walls) {
    if (lid.type != WallType::Disk || !removed.count(lid.name)) continue;
    const Opening* best = nullptr;
    for (const Opening& o : holes)
      if (norm(o.center - lid.center) <= lid.radius && o.radius <= lid.radius && (!best || o.radius < best->radius))
        best = &o;
    if (best) return Orifice{best->center, 2.0 * best->radius, "lid '" + lid.name + "' over " + best->what};
    return Orifice{lid.center, 2.0 * lid.radius, "lid '" + lid.name + "' (no opening under it: its own diameter)"};
  }
  return std::nullopt;
}

double largest_radius(const CaseSpec& cs) {
  double r = 0.0;
  for (const InsertionSpec& in : cs.insertions) r = std::max(r, in.radius.largest());
  for (const ParticleSpec& p : cs.particles) r = std::max(r, p.radius);
  return r;
}

double alpha_of(const CaseSpec& cs, const std::string& level) {
  for (const LevelSpec& l : cs.levels)
    if (l.name == level) return l.alpha;
  return 1.0;
}

// The region's box as the coupler builds it: rounded outward (up) to whole cells from min.
struct Box {
  Vec3 lo, hi;
  bool contains(const Vec3& p) const {
    return p.x >= lo.x && p.x <= hi.x && p.y >= lo.y && p.y <= hi.y && p.z >= lo.z && p.z <= hi.z;
  }
};

Box cell_box(const CouplingRegionSpec& r) {
  Box b{r.min, r.min};
  for (int a = 0; a < 3; ++a) {
    const double n = std::max(1.0, std::ceil((r.max[a] - r.min[a]) / r.cell_size - 1e-9));
    b.hi[a] = r.min[a] + n * r.cell_size;
  }
  return b;
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
  if (ratio >= kAdvisedCellDiameters) return;
  const std::string what =
      fmt::format("{}: cell_size = {:g} m is {:.2f} coarse diameters of {}; ", c.at("cell_size"), c.r.cell_size, ratio,
                  c.d_text);
  if (ratio < kMinCellDiameters) {
    out.errors.push_back(what + fmt::format(
        "a cell that small holds fewer than about 9 coarse particles when packed (one particle moves its volume "
        "fraction by more than 10 %), so the coarse statistics the coupler controls on are noise; give cell_size "
        ">= {:.3g} m ({:g} coarse diameters; {:g}-10 advised, the paper's 2 cm cells are 3.6)",
        kMinCellDiameters * c.d_coarse, kMinCellDiameters, kAdvisedCellDiameters));
    return;
  }
  out.warnings.push_back(what + fmt::format(
      "below the advised {:g}-10 (about 31 coarse particles per packed cell); the cell statistics are noisy, "
      "cell_size >= {:.3g} m would be within the advised range",
      kAdvisedCellDiameters, kAdvisedCellDiameters * c.d_coarse));
}

void check_top(const Check& c, const Box& box, const Orifice& o, RegionRuleReport& out) {
  const double above = (box.hi.z - o.center.z) / o.size;
  if (above >= kOnePercentTopAboveOrifice) return;
  if (above >= kAdvisedTopAboveOrifice) {
    out.notes.push_back(fmt::format(
        "{}: the region's top is z = {:g} m, {:.2f} orifice diameters above the orifice (D0 = {:g} m, from {}): "
        "expect the discharge within about 3 % of a fully resolved run; for about 1 % raise max z to {:g} m "
        "({:g} D0; silo_small: +1.2 % at 1.5 D0, +0.4 % at 2 D0), at the cost of more fine particles",
        c.at("max"), box.hi.z, above, o.size, o.from, o.center.z + kOnePercentTopAboveOrifice * o.size,
        kOnePercentTopAboveOrifice));
    return;
  }
  if (above >= kMinTopAboveOrifice) {
    out.warnings.push_back(fmt::format(
        "{}: the region's top is z = {:g} m, {:.2f} orifice diameters above the orifice (D0 = {:g} m, from {}), "
        "below the advised {:g}, the lowest height measured within 3 % of the reference (seven hoppers with their "
        "tops at 1.13-1.5 D0, cases/hoppers/README.md); max z >= {:g} m is advised",
        c.at("max"), box.hi.z, above, o.size, o.from, kAdvisedTopAboveOrifice,
        o.center.z + kAdvisedTopAboveOrifice * o.size));
    return;
  }
  out.errors.push_back(fmt::format(
      "{}: the region's top (its boundary surface, max z rounded up to whole {:g} m cells) is z = {:g} m, {:.2f} "
      "orifice diameters above the orifice (z = {:g} m, D0 = {:g} m, from {}); at least {:g} D0 is needed: with the "
      "boundary surface 0.6 D0 above the orifice the discharge was more than 10 % off the reference, at 1.1 D0 "
      "within 3 %; raise max z to at least {:g} m, or give [orifice] if the orifice is another one",
      c.at("max"), c.r.cell_size, box.hi.z, above, o.center.z, o.size, o.from, kMinTopAboveOrifice,
      o.center.z + kMinTopAboveOrifice * o.size));
}

void check_passage(const Check& c, const Box& box, const Orifice& o, RegionRuleReport& out) {
  const double ratio = o.size / c.d_coarse;
  if (ratio >= kJammingRatio) return;
  const std::string what = fmt::format(
      "{}: the orifice (D0 = {:g} m, from {}) is only {:.2f} coarse diameters wide ({}), below the jamming ratio "
      "D0 / d = {:g} for spheres through a circular orifice (Zuriguel et al., Phys. Rev. E 71, 051303, 2005)",
      c.at("coarse"), o.size, o.from, ratio, c.d_text, kJammingRatio);
  if (box.contains(o.center)) {
    out.warnings.push_back(what + "; the fine region contains the orifice, so the coarse level's flow through it "
                                  "relies on the correction cells");
    return;
  }
  out.errors.push_back(what + fmt::format(
      " and the fine region (cells from {:g} to {:g} m in z) does not contain it, so the coarse level would jam; "
      "extend the region over the orifice at [{:g}, {:g}, {:g}], or couple a coarse level with D0 / d >= {:g}",
      box.lo.z, box.hi.z, o.center.x, o.center.y, o.center.z, kJammingRatio));
}

}  // namespace

std::optional<Orifice> find_orifice(const CaseSpec& cs) {
  if (cs.orifice) return Orifice{cs.orifice->center, cs.orifice->size(), "[orifice] (" + cs.orifice->loc.str() + ")"};
  const auto removed = removed_walls(cs);
  if (auto o = orifice_under_lid(cs, removed)) return o;
  const WallSpec* low = nullptr;  // no lid: the lowest cone narrowing downward to an opening
  for (const WallSpec& w : cs.walls)
    if (w.type == WallType::Cone && !removed.count(w.name) && w.radius_bottom > 0.0 && w.radius_bottom < w.radius_top &&
        (!low || (w.center + w.bottom * unit(w.axis)).z < (low->center + low->bottom * unit(low->axis)).z))
      low = &w;
  if (low)
    return Orifice{low->center + low->bottom * unit(low->axis), 2.0 * low->radius_bottom,
                   "the bottom of cone '" + low->name + "'"};
  return std::nullopt;
}

RegionRuleReport check_region_rules(const CaseSpec& cs) {
  RegionRuleReport out;
  if (!cs.coupling) return out;
  const auto orifice = find_orifice(cs);
  if (orifice)
    out.notes.push_back(fmt::format("{}: orifice at [{:g}, {:g}, {:g}], D0 = {:g} m, from {} (the region rules' "
                                    "reference; [orifice] sets another)",
                                    cs.path, orifice->center.x, orifice->center.y, orifice->center.z, orifice->size,
                                    orifice->from));
  else
    out.notes.push_back(cs.path + ": no orifice found (no removed lid, no cone narrowing to an opening, no [orifice]); "
                                  "the orifice rules of the coupling regions are skipped; give [orifice] to check them");
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
    if (!orifice) continue;
    const Box box = cell_box(r);
    check_top(c, box, *orifice, out);
    check_passage(c, box, *orifice, out);
  }
  return out;
}

}  // namespace mlcg::config
