#include "from_case.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <set>
#include <stdexcept>

#include "config/region_rules.hpp"
#include "scene/materials_from_case.hpp"
#include "scene/walls_from_case.hpp"

namespace mlcg::coupling {
namespace {

// Cells with any of n^3 sample points reachable from `inside` without crossing a wall.
std::vector<uint32_t> clipped_cells(const WallSet& walls, const Vec3& origin, double h, uint32_t nx, uint32_t ny,
                                    uint32_t nz, const Vec3& inside) {
  constexpr int n = 4;
  std::vector<uint32_t> cells;
  for (uint32_t k = 0; k < nz; ++k)
    for (uint32_t j = 0; j < ny; ++j)
      for (uint32_t i = 0; i < nx; ++i) {
        bool open = false;
        for (int q = 0; q < n * n * n && !open; ++q) {
          const Vec3 p = origin + h * Vec3{i + (q % n + 0.5) / n, j + ((q / n) % n + 0.5) / n, k + (q / (n * n) + 0.5) / n};
          open = !walls.crosses(inside, p);
        }
        if (open) cells.push_back(i + nx * (j + ny * k));
      }
  return cells;
}

constexpr int kFaceSamples = 8;  // per side of a face

// Share of the n^2 sample points of side s of active cell c, moved `out` along the outward normal,
// reachable from `inside`.
double open_share(const WallSet& walls, const bus::CouplingGeometry& geo, size_t c, bus::Side s, const Vec3& inside,
                  double out) {
  constexpr int n = kFaceSamples;
  Vec3 lo, hi;
  geo.cell_slab(c, s, 0.0, lo, hi);
  const Vec3 shift = -out * bus::CouplingGeometry::inward(s);
  int in = 0;
  for (int q = 0; q < n * n; ++q) {
    const double u = (q % n + 0.5) / n, v = (q / n + 0.5) / n;
    Vec3 x = lo;  // u, v across the face's two in-plane axes
    if (s == bus::Side::Top || s == bus::Side::Bottom) x += Vec3{u * (hi.x - lo.x), v * (hi.y - lo.y), 0.0};
    else if (lo.x == hi.x) x += Vec3{0.0, u * (hi.y - lo.y), v * (hi.z - lo.z)};
    else x += Vec3{u * (hi.x - lo.x), 0.0, v * (hi.z - lo.z)};
    in += !walls.crosses(inside, x + shift);
  }
  return static_cast<double>(in) / (n * n);
}

// The box sides through which the geometry goes on beyond the region (a region that does not span
// the vessel): any sample point just outside the face reachable from `inside` makes it a boundary face. The
// bottom only when the case opens it (open_bottom): below a region lies the outflow under an outlet, unless
// the region sits on the bulk of a drum or a belt.
void open_sides(const WallSet& walls, bus::CouplingGrid& gr, const Vec3& inside, bool bottom) {
  const bus::CouplingGeometry geo(gr);
  const double eps = 1e-6 * geo.cell_size();
  for (size_t c = 0; c < geo.cells(); ++c) {
    const uint32_t flat = geo.flat(c), i = flat % gr.nx(), j = (flat / gr.nx()) % gr.ny();
    const bool on[4] = {i == 0, i == gr.nx() - 1, j == 0, j == gr.ny() - 1};
    for (uint32_t d = 0; d < 4; ++d) {
      if (on[d] && open_share(walls, geo, c, static_cast<bus::Side>(d + 1), inside, eps) > 0.0)
        gr.add_side_faces(static_cast<uint32_t>(4 * c + d));
    }
  }
  if (!bottom) return;
  for (size_t c = 0; c < geo.cells() && geo.flat(c) < gr.nx() * gr.ny(); ++c)
    if (open_share(walls, geo, c, bus::Side::Bottom, inside, eps) > 0.0) gr.add_bottom_faces(static_cast<uint32_t>(c));
}

// Fractions of each active cell's volume and of each boundary face's area that
// are reachable from `inside` (inside the walls), from n^3 / n^2 sample points.
void inside_fractions(const WallSet& walls, bus::CouplingGrid& gr, const Vec3& inside) {
  constexpr int n = config::kWallSamplesPerCell;
  const bus::CouplingGeometry geo(gr);
  const double h = geo.cell_size(), floor = 1.0 / (n * n * n);
  for (size_t c = 0; c < geo.cells(); ++c) {
    const Vec3 lo = geo.cell_lo(c);
    int in = 0;
    for (int q = 0; q < n * n * n; ++q)
      in += !walls.crosses(inside, lo + h * Vec3{(q % n + 0.5) / n, ((q / n) % n + 0.5) / n, (q / (n * n) + 0.5) / n});
    gr.add_cell_inside(std::max(floor, static_cast<double>(in) / (n * n * n)));
  }
  for (size_t f = 0; f < geo.faces(); ++f)  // just inside a top face, just outside a side face (both open)
    gr.add_face_inside(std::max(floor, open_share(walls, geo, geo.cell_of_face(f), geo.side_of_face(f), inside,
                                                          (geo.is_top(f) ? -1e-6 : 1e-6) * h)));
}

// The sizes and density the coupler plans with: alpha = 1 radii of the case's insertions and particles, the
// density of the first insertion's material.
struct ParticleSizes {
  double r_min = 1e300, r_max = 0.0, density = 0.0;
};

ParticleSizes particle_sizes(const config::CaseSpec& cs, const MaterialTable& mt) {
  ParticleSizes s;
  for (const auto& in : cs.insertions) {
    s.r_min = std::min(s.r_min, in.radius.smallest());
    s.r_max = std::max(s.r_max, in.radius.largest());
    if (s.density == 0.0) s.density = mt.material(mt.index_of(in.material)).density;
  }
  for (const auto& p : cs.particles) {
    s.r_min = std::min(s.r_min, p.radius);
    s.r_max = std::max(s.r_max, p.radius);
  }
  if (s.r_max <= 0.0 || s.density <= 0.0)
    throw std::invalid_argument(cs.path + ": a coupled case needs an [[insertion]] (it sets the particle sizes)");
  return s;
}

// The point the grid's cells must be reached from without crossing a wall: `inside` when given. Otherwise
// the centre of the box half a cell under its top, unless a vertical line from it up to the insertions' top
// crosses a wall: then it lies outside the vessel (a region wider than a wedge hopper's neck: the box's
// centre beside the wedge), and the point is the middle of the top layer's cell centres that the fill
// reaches (under an insertion's box, the vertical line up to that box's top crossing no wall: the
// inserter's own test), or the one of them nearest to that middle. Without insertions (an initial file)
// the centre.
Vec3 inside_point(const config::CouplingRegionSpec& rs, const WallSet& walls, const bus::CouplingGrid& gr,
                  const Vec3& centre, const std::vector<config::RegionSpec>& fills) {
  if (rs.inside) return *rs.inside;
  const double h = rs.cell_size;
  const auto filled = [&](const Vec3& p) {
    return !walls.touches(p, 0.0) && std::any_of(fills.begin(), fills.end(), [&](const config::RegionSpec& f) {
             return p.x >= f.min.x && p.x <= f.max.x && p.y >= f.min.y && p.y <= f.max.y && p.z <= f.max.z &&
                    !walls.crosses(p, {p.x, p.y, f.max.z});
           });
  };
  double fill_top = centre.z;
  for (const auto& f : fills) fill_top = std::max(fill_top, f.max.z);
  if (fills.empty() || (!walls.touches(centre, 0.0) && !walls.crosses(centre, {centre.x, centre.y, fill_top})))
    return centre;
  std::vector<Vec3> under;
  Vec3 mid;
  for (uint32_t j = 0; j < gr.ny(); ++j)
    for (uint32_t i = 0; i < gr.nx(); ++i) {
      const Vec3 p{rs.min.x + (i + 0.5) * h, rs.min.y + (j + 0.5) * h, centre.z};
      if (filled(p)) under.push_back(p), mid += p;
    }
  if (under.empty())
    throw std::invalid_argument(rs.loc.str() + ": no cell of the region's top layer lies under the fill (a vertical "
                                "line from each cell's centre up to an insertion's top crosses a wall, or no "
                                "insertion lies over it); give `inside` = a point inside the vessel within the region");
  // The middle of the vessel's section (the cells cut by the walls see less of it from their centres).
  mid = (1.0 / static_cast<double>(under.size())) * mid;
  if (filled(mid)) return mid;
  return *std::min_element(under.begin(), under.end(),
                           [&](const Vec3& a, const Vec3& b) { return norm2(a - mid) < norm2(b - mid); });
}

// The region's grid: cells clipped to the geometry, open sides, insertion and fade depths, radius bins.
void fill_grid(bus::CouplingGrid& gr, const config::CouplingRegionSpec& rs, const WallSet& walls,
               const WallSet& lids_closed, int lc, int lf,
               double ac, double af, const ParticleSizes& sizes, const std::vector<config::RegionSpec>& fills) {
  const double h = rs.cell_size;
  const Vec3 ext = rs.max - rs.min;
  const auto cells_along = [h](double e) { return static_cast<uint32_t>(std::max(1.0, std::ceil(e / h - 1e-9))); };
  gr.set_coarse_level(static_cast<uint32_t>(lc));
  gr.set_fine_level(static_cast<uint32_t>(lf));
  gr.set_ox(rs.min.x);
  gr.set_oy(rs.min.y);
  gr.set_oz(rs.min.z);
  gr.set_cell_size(h);
  gr.set_nx(cells_along(ext.x));
  gr.set_ny(cells_along(ext.y));
  gr.set_nz(cells_along(ext.z));
  const double top = rs.min.z + gr.nz() * h;
  const Vec3 centre{rs.min.x + 0.5 * gr.nx() * h, rs.min.y + 0.5 * gr.ny() * h, top - 0.5 * h};
  const Vec3 inside = inside_point(rs, walls, gr, centre, fills);
  const auto cells = clipped_cells(walls, rs.min, h, gr.nx(), gr.ny(), gr.nz(), inside);
  const uint32_t top_layer = gr.nx() * gr.ny() * (gr.nz() - 1);
  if (std::none_of(cells.begin(), cells.end(), [&](uint32_t c) { return c >= top_layer; }))
    throw std::invalid_argument(rs.loc.str() + ": no cell of the region's top layer lies inside the geometry "
                                "(check min/max, or give `inside` = a point inside the walls)");
  for (uint32_t c : cells) gr.add_cells(c);
  // The vessel goes on beyond a side where the walls with the outlets' lids in place let one reach it: beyond an
  // opened lid lies the outflow (a side-wall hole's stream), which the coarse level does not feed the region from.
  open_sides(lids_closed, gr, inside, rs.open_bottom);
  inside_fractions(walls, gr, inside);
  for (double v : {inside.x, inside.y, inside.z}) gr.add_inside_point(v);
  const double d_coarse = 2.0 * sizes.r_max * ac, d_fine = 2.0 * sizes.r_max * af;
  gr.set_insert_depth(rs.insert_depth > 0.0 ? rs.insert_depth : std::min(2.0 * d_coarse, h));
  gr.set_fade_depth(rs.fade * d_fine);
  const int bins = sizes.r_min == sizes.r_max ? 1 : rs.radius_bins;
  for (int b = 0; b <= bins; ++b) gr.add_radius_bins(ac * (sizes.r_min + (sizes.r_max - sizes.r_min) * b / bins));
}

// One region's grid, insertion planner and controllers; `index` is its place among the case's regions.
RegionConfig region_config(const config::CaseSpec& cs, const config::CouplingRegionSpec& rs, const WallSet& walls,
                           const WallSet& lids_closed,
                           const ParticleSizes& sizes, size_t index) {
  const auto index_of = [&](const std::string& name) {
    for (size_t l = 0; l < cs.levels.size(); ++l)
      if (cs.levels[l].name == name) return static_cast<int>(l);
    return -1;
  };
  const int lc = index_of(rs.coarse), lf = index_of(rs.fine);
  if (lc < 0 || lf < 0) throw std::invalid_argument(rs.loc.str() + ": coupling region names an unknown level");
  const double ac = cs.levels[static_cast<size_t>(lc)].alpha, af = cs.levels[static_cast<size_t>(lf)].alpha;
  const double g = norm(cs.gravity), height = cs.domain.max.z - cs.domain.min.z;
  RegionConfig rc;
  std::vector<config::RegionSpec> fills;
  for (const auto& in : cs.insertions) fills.push_back(in.region);
  fill_grid(rc.grid, rs, walls, lids_closed, lc, lf, ac, af, sizes, fills);
  rc.planner.ratio = ac / af;
  rc.planner.density = sizes.density;
  rc.planner.insert_depth = rc.grid.insert_depth();
  rc.planner.radius_bins.assign(rc.grid.radius_bins().begin(), rc.grid.radius_bins().end());
  rc.planner.seed = cs.seed ^ (0x51ed2701ULL * (index + 1));
  rc.planner.retry_full_every = static_cast<uint64_t>(cs.coupling->retry_full_every);
  rc.pi.kp = rs.kp;
  rc.pi.ki = rs.ki;
  rc.pi.limit = rs.traction_limit > 0.0 ? rs.traction_limit : sizes.density * g * height;
  rc.velocity.gain = rs.velocity_gain;
  rc.velocity.ki = rs.velocity_ki;
  rc.velocity.limit = rs.acceleration_limit > 0.0 ? rs.acceleration_limit : 5.0 * g;
  rc.correct = rs.correct == "none"       ? RegionConfig::Correct::None
               : rs.correct == "velocity" ? RegionConfig::Correct::Velocity
                                          : RegionConfig::Correct::MassFlow;
  rc.velocity_only_below = rs.velocity_only_below;
  return rc;
}

// A region's cells, open sides and inside fractions are found once, with the walls where they stand at t = 0.
// A mesh moving as a whole may take part in a hierarchy only where that holds as it moves: the grid found with
// the walls at later poses must be the same cells and faces, every fraction within kPoseTolerance of the start's.
constexpr double kPoseTolerance = 0.05;
// A translating mesh is posed each quarter of the smallest cell its farthest point moves, up to this many poses.
constexpr size_t kMaxPoses = 400;

// The latest time the run reaches: [time] end, or its event's time (a hierarchy's events fire at `at`) plus
// `plus`; infinity when neither is known.
double run_end(const config::CaseSpec& cs) {
  if (cs.time.end >= 0.0) return cs.time.end;
  for (const auto& e : cs.events)
    if (e.name == cs.time.end_event && e.at >= 0.0) return e.at + cs.time.end_plus;
  return std::numeric_limits<double>::infinity();
}

double box_distance(const Vec3& p, const Vec3& lo, const Vec3& hi) {
  const Vec3 d{std::max({lo.x - p.x, 0.0, p.x - hi.x}), std::max({lo.y - p.y, 0.0, p.y - hi.y}),
               std::max({lo.z - p.z, 0.0, p.z - hi.z})};
  return norm(d);
}

// The times at which the regions are found again: eight poses over each turning mesh's revolution; for a mesh
// that translates, every quarter cell its farthest point moves while it lies within a cell of a region's box
// (a mesh that never comes near a region cannot change it).
std::vector<double> pose_times(const config::CaseSpec& cs, const WallSet& walls) {
  double h = std::numeric_limits<double>::infinity();
  for (const auto& rs : cs.coupling->regions) h = std::min(h, rs.cell_size);
  std::vector<double> times;
  for (size_t w = 0; w < walls.walls(); ++w) {
    const auto& in = walls.info(w);
    const double spin = norm(in.move_spin), speed = norm(in.move_velocity);
    if (!in.rigid) continue;
    if (spin > 0.0 && speed == 0.0)
      for (int j = 1; j < 8; ++j) times.push_back(j * 2.0 * std::numbers::pi / spin / 8.0);
    if (speed == 0.0) continue;
    const double end = run_end(cs);
    if (!std::isfinite(end))
      throw std::invalid_argument(cs.path + ": wall '" + in.name + "' travels (move_velocity) in a case of several "
                                  "levels whose end is not a time: give [time] end in s, or an end event with `at`");
    const double step = 0.25 * h / (speed + spin * in.reach);
    std::vector<double> near;
    for (double t = step; t < end + step; t += step) {
      const Vec3 centre = in.move_center + std::min(t, end) * in.move_velocity;
      for (const auto& rs : cs.coupling->regions)
        if (box_distance(centre, rs.min, rs.max) <= in.reach + rs.cell_size) {
          near.push_back(std::min(t, end));
          break;
        }
      if (near.size() > kMaxPoses)
        throw std::invalid_argument(
            cs.path + ": wall '" + in.name + "' travels (move_velocity) near a coupling region for longer than " +
            std::to_string(kMaxPoses) + " poses of a quarter cell each (to t = " + std::to_string(t) +
            " s); the regions' cells are found once at the start, so a mesh may travel only where it stays away "
            "from every region, or the same to it; or run the scene on one level");
    }
    times.insert(times.end(), near.begin(), near.end());
  }
  return times;
}

void check_moving_meshes(const config::CaseSpec& cs, const WallSet& walls, const WallSet& lids_closed,
                         const ParticleSizes& sizes, const std::vector<RegionConfig>& regions) {
  WallSet posed = walls, lids = lids_closed;
  for (const double t : pose_times(cs, walls)) {
    posed.set_time(t);
    lids.set_time(t);
    for (size_t i = 0; i < regions.size(); ++i) {
      const auto& rs = cs.coupling->regions[i];
      const bus::CouplingGrid g = region_config(cs, rs, posed, lids, sizes, i).grid, &g0 = regions[i].grid;
      const auto same = [](const auto& a, const auto& b, double tol) {
        if (a.size() != b.size()) return false;
        for (int k = 0; k < a.size(); ++k)
          if (std::fabs(static_cast<double>(a[k]) - static_cast<double>(b[k])) > tol) return false;
        return true;
      };
      if (!same(g.cells(), g0.cells(), 0.0) || !same(g.side_faces(), g0.side_faces(), 0.0) ||
          !same(g.cell_inside(), g0.cell_inside(), kPoseTolerance) ||
          !same(g.face_inside(), g0.face_inside(), kPoseTolerance))
        throw std::invalid_argument(
            rs.loc.str() + ": a mesh moving as a whole changes this region's cells as it moves (at t = " +
            std::to_string(t) + " s its cells, open sides or their fractions inside the walls differ by more than " +
            std::to_string(kPoseTolerance) + " from the start's), which the coupling takes once at the start; a "
            "mesh may move in a hierarchy where it is the same to every region as it moves (a drum turning about "
            "its axis, a part travelling away from the regions), or run the scene on one level");
    }
  }
}

}  // namespace

CaseCoupling coupling_from_case(const config::CaseSpec& cs) {
  if (!cs.coupling) throw std::invalid_argument(cs.path + ": no [coupling] section (a single-level case needs no coupler)");
  const config::CouplingSpec& cp = *cs.coupling;
  CaseCoupling out;
  CouplerConfig& cfg = out.cfg;
  cfg.interval = cp.interval;
  cfg.seed = cs.seed;
  cfg.heartbeat = cp.heartbeat;
  cfg.timeout = cp.timeout;
  for (const auto& l : cs.levels) cfg.levels.push_back({l.name, l.alpha, l.dt, static_cast<uint32_t>(l.ranks)});

  // Walls an event removes (an orifice lid) do not clip the grid or block insertion; they do close the vessel
  // where the region's open sides are found.
  const MaterialTable mt = materials_of_case(cs);
  const WallSet lids_closed = walls_from_case(cs, mt);
  auto walls = std::make_shared<WallSet>(lids_closed);
  std::set<std::string> removed;
  for (const auto& e : cs.events) removed.insert(e.remove_walls.begin(), e.remove_walls.end());
  for (size_t w = 0; w < walls->walls(); ++w)
    if (removed.count(walls->info(w).name)) walls->set_active(w, false);
  out.walls = walls;
  out.fits = [walls](const Vec3& anchor, const Vec3& x, double r) {
    return !walls->touches(x, r) && !walls->crosses(anchor, x);
  };
  if (walls->has_rigid()) out.pose = [walls](double t) { walls->set_time(t); };
  const ParticleSizes sizes = particle_sizes(cs, mt);
  for (const auto& rs : cp.regions)
    cfg.regions.push_back(region_config(cs, rs, *walls, lids_closed, sizes, cfg.regions.size()));
  if (walls->has_rigid()) check_moving_meshes(cs, *walls, lids_closed, sizes, cfg.regions);
  return out;
}

uint64_t checkpoint_intervals(const config::CaseSpec& cs) {
  double every = cs.coupling->checkpoint_every;
  if (every <= 0.0) every = kDefaultCheckpointEvery;
  return std::max<uint64_t>(1, static_cast<uint64_t>(std::llround(every / cs.coupling->interval)));
}

}  // namespace mlcg::coupling
