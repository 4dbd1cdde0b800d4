#include "coupler.hpp"

#include <cmath>
#include <stdexcept>

#include <fmt/format.h>

#include "core/time_steps.hpp"

namespace mlcg::coupling {
namespace {

Vec3 vec_at(const google::protobuf::RepeatedField<double>& a, size_t i) {
  return {a[static_cast<int>(3 * i)], a[static_cast<int>(3 * i + 1)], a[static_cast<int>(3 * i + 2)]};
}

std::vector<double> to_vector(const google::protobuf::RepeatedField<double>& a) { return {a.begin(), a.end()}; }

}  // namespace

Coupler::Region::Region(const RegionConfig& c, const FitsGeometry& fits)
    : cfg(c), geo(c.grid), planner(geo, c.planner, fits), pi(geo.faces(), c.pi), vint(geo.cells()) {}

Coupler::Coupler(CouplerConfig cfg, FitsGeometry fits, PoseWalls pose) : cfg_(std::move(cfg)), pose_(std::move(pose)) {
  if (cfg_.levels.size() < 2) throw std::invalid_argument("coupler: a hierarchy needs at least two levels");
  if (!(cfg_.interval > 0.0)) throw std::invalid_argument("coupler: the coupling interval must be positive");
  for (const auto& l : cfg_.levels) {
    if (whole_steps(cfg_.interval, l.dt) == 0)
      throw std::invalid_argument("coupler: level '" + l.name + "' dt " + std::to_string(l.dt) +
                                  " s does not divide the coupling interval " + std::to_string(cfg_.interval) + " s");
  }
  for (size_t r = 0; r < cfg_.regions.size(); ++r) {
    const auto& g = cfg_.regions[r].grid;
    if (g.coarse_level() >= cfg_.levels.size() || g.fine_level() >= cfg_.levels.size() ||
        g.coarse_level() == g.fine_level())
      throw std::invalid_argument("coupler: region " + std::to_string(r) + " names unknown or equal levels");
    regions_.push_back(std::make_unique<Region>(cfg_.regions[r], fits));
  }
}

void Coupler::cancel_last_insertions() {
  for (auto& r : regions_) {
    for (const auto& p : r->last) r->planner.unplace(p);
    r->last.clear();
  }
}

int Coupler::level_index(const std::string& name) const {
  for (size_t l = 0; l < cfg_.levels.size(); ++l)
    if (cfg_.levels[l].name == name) return static_cast<int>(l);
  return -1;
}

bus::Welcome Coupler::welcome(size_t level, uint64_t start_interval) const {
  bus::Welcome w;
  w.set_level_index(static_cast<uint32_t>(level));
  w.set_level_count(static_cast<uint32_t>(cfg_.levels.size()));
  w.set_coupling_interval(cfg_.interval);
  w.set_seed(cfg_.seed);
  w.set_start_interval(start_interval);
  w.set_heartbeat_seconds(cfg_.heartbeat);
  w.set_timeout_seconds(cfg_.timeout);
  for (const auto& r : regions_) *w.add_grids() = r->cfg.grid;
  return w;
}

std::vector<bus::IntervalCommands> Coupler::initial_commands() const {
  std::vector<bus::IntervalCommands> out(cfg_.levels.size());
  for (auto& c : out) c.set_interval(0);
  return out;
}

const bus::GridStats& Coupler::grid_stats(const bus::IntervalStats& s, size_t region, size_t level) const {
  for (const auto& g : s.grids())
    if (g.grid() == region) return g;
  throw std::invalid_argument("coupler: level '" + cfg_.levels[level].name + "' sent no statistics for region " +
                              std::to_string(region));
}

void Coupler::check(const bus::GridStats& g, const Region& r, bool coarse, size_t level) const {
  const auto bad = [&](const char* field, size_t got, size_t want) {
    if (got != want)
      throw std::invalid_argument("coupler: level '" + cfg_.levels[level].name + "' region " +
                                  std::to_string(g.grid()) + ": " + field + " has " + std::to_string(got) +
                                  " values, expected " + std::to_string(want));
  };
  const size_t nc = r.geo.cells(), nf = r.geo.faces(), nb = r.cfg.planner.radius_bins.size() - 1;
  bad("cell_stress", g.cell_stress_size(), 6 * nc);
  bad("cell_volume_fraction", g.cell_volume_fraction_size(), nc);
  bad("cell_velocity", g.cell_velocity_size(), 3 * nc);
  bad("cell_max_speed", g.cell_max_speed_size(), nc);
  check_values(g, r, level);
  if (coarse) {
    bad("face_mass", g.face_mass_size(), nf);
    bad("face_momentum", g.face_momentum_size(), 3 * nf);
    bad("face_moment", g.face_moment_size(), 3 * nf);
    bad("face_histogram", g.face_histogram_size(), nb * nf);
    if (g.face_gross_mass_size() != 0 || g.face_speed_mass_size() != 0) {  // both or neither
      bad("face_gross_mass", g.face_gross_mass_size(), nf);
      bad("face_speed_mass", g.face_speed_mass_size(), nf);
    }
  } else {
    if (g.occupants_size() % 4 != 0) bad("occupants", g.occupants_size(), g.occupants_size() / 4 * 4);
    if (g.face_returned_mass_size() != 0) bad("face_returned_mass", g.face_returned_mass_size(), nf);
    for (int i = 0; i < g.occupant_faces_size(); ++i)
      if (g.occupant_faces(i) >= nf || (i > 0 && g.occupant_faces(i) <= g.occupant_faces(i - 1)))
        throw std::invalid_argument(fmt::format("coupler: level '{}' region {}: occupant_faces[{}] = {}; the faces "
                                                "are ascending numbers below the grid's {}",
                                                cfg_.levels[level].name, g.grid(), i, g.occupant_faces(i), nf));
  }
}

void Coupler::check_values(const bus::GridStats& g, const Region& r, size_t level) const {
  const auto refuse = [&](const std::string& what) {
    throw std::invalid_argument(
        fmt::format("coupler: level '{}' region {}: {}", cfg_.levels[level].name, g.grid(), what));
  };
  const auto finite = [&](const char* field, const google::protobuf::RepeatedField<double>& a) {
    for (int i = 0; i < a.size(); ++i)
      if (!std::isfinite(a[i])) refuse(fmt::format("{}[{}] is {}; statistics are finite numbers", field, i, a[i]));
  };
  finite("face_mass", g.face_mass());
  finite("face_momentum", g.face_momentum());
  finite("face_moment", g.face_moment());
  finite("cell_stress", g.cell_stress());
  finite("cell_volume_fraction", g.cell_volume_fraction());
  finite("cell_velocity", g.cell_velocity());
  finite("cell_max_speed", g.cell_max_speed());
  finite("occupants", g.occupants());
  finite("face_gross_mass", g.face_gross_mass());
  finite("face_speed_mass", g.face_speed_mass());
  finite("face_returned_mass", g.face_returned_mass());
  if (!std::isfinite(g.mass_in_region()) || !std::isfinite(g.mass_leaving()))
    refuse(fmt::format("mass_in_region {} kg, mass_leaving {} kg; statistics are finite numbers", g.mass_in_region(),
                       g.mass_leaving()));
  for (int i = 0; i < g.face_histogram_size(); ++i)
    if (g.face_histogram(i) > kMaxCrossings || g.face_histogram(i) < -kMaxCrossings)
      refuse(fmt::format("face_histogram[{}] counts {} crossings in one interval; at most {} either way", i,
                         g.face_histogram(i), kMaxCrossings));
  // The planner's overlap test searches the hash cells within the largest occupant radius: a radius beyond
  // a coupling cell is no fine particle, and a huge one would make that search endless.
  const double h = r.geo.cell_size();
  for (int i = 3; i < g.occupants_size(); i += 4)
    if (!(g.occupants(i) > 0.0 && g.occupants(i) <= h))
      refuse(fmt::format("occupant {} has radius {} m; occupants are fine particles, of a radius > 0 and up to the "
                         "cell size ({} m)",
                         i / 4, g.occupants(i), h));
}

void Coupler::plan_insertions(Region& r, const bus::GridStats& cs, const bus::GridStats& fs, uint64_t k,
                              bus::GridCommands& fine) const {
  r.planner.add_crossings(to_vector(cs.face_mass()), to_vector(cs.face_momentum()), to_vector(cs.face_moment()),
                          {cs.face_histogram().begin(), cs.face_histogram().end()}, to_vector(cs.face_gross_mass()),
                          to_vector(cs.face_speed_mass()));
  r.planner.add_returned(to_vector(fs.face_returned_mass()));
  r.log.returned_mass = 0.0;
  for (double m : fs.face_returned_mass()) r.log.returned_mass += m;
  r.log.coarse_mass = cs.mass_in_region();
  r.log.fine_mass = fs.mass_in_region();
  r.log.fine_leaving = fs.mass_leaving();
  // Placing needs the fine particles in the slabs; without them the mass waits an interval.
  std::vector<Insert> ins;
  if (fs.occupants_sent()) {
    std::vector<Sphere> occ;
    occ.reserve(static_cast<size_t>(fs.occupants_size() / 4));
    for (int i = 0; i + 3 < fs.occupants_size(); i += 4)
      occ.push_back({{fs.occupants(i), fs.occupants(i + 1), fs.occupants(i + 2)}, fs.occupants(i + 3)});
    ins = r.planner.plan(k + 1, occ, {fs.occupant_faces().begin(), fs.occupant_faces().end()});
  }
  fine.set_want_occupants(r.planner.wants_occupants(k + 1));
  for (const uint32_t f : r.planner.occupant_faces(k + 1)) fine.add_occupant_faces(f);
  r.last = ins;
  r.log.inserted = ins.size();
  r.log.inserted_mass = 0.0;
  for (const auto& p : ins) {
    for (double v : {p.x.x, p.x.y, p.x.z, p.r, p.v.x, p.v.y, p.v.z}) fine.add_insert(v);
    fine.add_insert_face(p.face);
    r.log.inserted_mass += r.planner.mass_of(p.r);
  }
}

// PI on the normal stress across each boundary face (sigma_zz under the top, sigma_xx / sigma_yy inside an
// open side), traction and speed limit for the fine level.
void Coupler::transition_layer(Region& r, const bus::GridStats& cs, const bus::GridStats& fs,
                               bus::GridCommands& fine) const {
  const size_t nf = r.geo.faces(), nt = r.geo.top_faces();
  r.log.setpoint.assign(nt, 0.0);
  r.log.measured.assign(nt, 0.0);
  r.log.traction.assign(nt, 0.0);
  for (size_t f = 0; f < nf; ++f) {
    const int c = static_cast<int>(r.geo.cell_of_face(f));
    const int nn = r.geo.normal_axis(f);  // xx yy zz
    const double set = cs.cell_stress(6 * c + nn), pv = fs.cell_stress(6 * c + nn);
    const bool active = cs.cell_volume_fraction(c) >= r.cfg.phi_min && fs.cell_volume_fraction(c) >= r.cfg.phi_min;
    if (active) r.pi[f].update(set, pv, cfg_.interval);
    else r.pi[f].hold();
    if (f < nt) {
      r.log.setpoint[f] = set;
      r.log.measured[f] = pv;
      r.log.traction[f] = r.pi[f].output;
    }
    fine.add_traction(r.pi[f].output);
    fine.add_speed_limit(cs.cell_max_speed(c));
  }
}

// Correction cells: PI controller toward the fine velocity, for the coarse level.
void Coupler::correct_coarse(Region& r, const bus::GridStats& cs, const bus::GridStats& fs,
                             bus::GridCommands& coarse) const {
  const size_t nc = r.geo.cells();
  r.log.acceleration.assign(nc, Vec3{});
  for (size_t c = 0; c < nc; ++c) {
    Vec3 a{};
    const double phi_c = cs.cell_volume_fraction(static_cast<int>(c)),
                 phi_f = fs.cell_volume_fraction(static_cast<int>(c));
    if (!r.geo.is_transition(c) && r.cfg.correct != RegionConfig::Correct::None && phi_c >= r.cfg.phi_min &&
        phi_f >= r.cfg.phi_min) {
      const bool mass_flow = r.cfg.correct == RegionConfig::Correct::MassFlow &&
                             r.geo.cell_centre(c).z >= r.cfg.velocity_only_below;
      const Vec3 target = correction_target(vec_at(fs.cell_velocity(), c), phi_f, phi_c, mass_flow);
      a = r.cfg.velocity.update(target, vec_at(cs.cell_velocity(), c), r.vint[c], cfg_.interval);
    } else {
      r.vint[c] = Vec3{};  // an uncorrected cell starts afresh
    }
    r.log.acceleration[c] = a;
    coarse.add_acceleration(a.x);
    coarse.add_acceleration(a.y);
    coarse.add_acceleration(a.z);
  }
}

std::vector<bus::IntervalCommands> Coupler::advance(uint64_t k, const std::vector<bus::IntervalStats>& stats) {
  if (stats.size() != cfg_.levels.size()) throw std::invalid_argument("coupler: statistics of every level needed");
  for (size_t l = 0; l < stats.size(); ++l)
    if (stats[l].interval() != k)
      throw std::invalid_argument("coupler: level '" + cfg_.levels[l].name + "' sent interval " +
                                  std::to_string(stats[l].interval()) + " while the coupler is at " +
                                  std::to_string(k));
  std::vector<bus::IntervalCommands> out(cfg_.levels.size());
  for (auto& c : out) c.set_interval(k + 1);
  // The fine level inserts at the start of interval k + 1: the walls are placed where they stand then.
  if (pose_) pose_(static_cast<double>(k + 1) * cfg_.interval);

  for (size_t ri = 0; ri < regions_.size(); ++ri) {
    Region& r = *regions_[ri];
    const size_t lc = r.cfg.grid.coarse_level(), lf = r.cfg.grid.fine_level();
    const bus::GridStats& cs = grid_stats(stats[lc], ri, lc);
    const bus::GridStats& fs = grid_stats(stats[lf], ri, lf);
    check(cs, r, true, lc);
    check(fs, r, false, lf);
    bus::GridCommands& fine = *out[lf].add_grids();
    fine.set_grid(static_cast<uint32_t>(ri));
    plan_insertions(r, cs, fs, k, fine);
    transition_layer(r, cs, fs, fine);
    bus::GridCommands& coarse = *out[lc].add_grids();
    coarse.set_grid(static_cast<uint32_t>(ri));
    correct_coarse(r, cs, fs, coarse);
  }
  return out;
}

}  // namespace mlcg::coupling
