#include "stability/stability.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>

#include <fmt/format.h>

#include "core/spheres.hpp"

namespace mlcg {

InitialOverlap initial_overlaps(const std::vector<PlacedParticle>& placed, const MaterialTable& mt) {
  InitialOverlap ov;
  if (placed.empty()) return ov;
  double r_max = 0.0;
  for (const auto& q : placed) r_max = std::max(r_max, q.s.r);
  SphereHash hash(2.0 * r_max);
  for (const auto& q : placed) hash.add(q.s);
  for (size_t i = 0; i < placed.size(); ++i) {
    const PlacedParticle& a = placed[i];
    double stored = 0.0;  // Hertz energy of a's overlaps, 8/15 E* sqrt(R*) d^(5/2) each
    hash.find_near(a.s.x, a.s.r, [&](size_t j, const Vec3& x, double r) {
      const double d = a.s.r + r - norm(a.s.x - x);
      if (j == i || d <= 0.0) return false;
      const PairCoeffs& c = mt.pair(a.material, placed[j].material);
      stored += (8.0 / 15.0) * c.e_star * std::sqrt(a.s.r * r / (a.s.r + r) * d) * d * d;
      if (d > ov.ratio * std::min(a.s.r, r)) {
        ov.ratio = d / std::min(a.s.r, r);
        ov.a = std::min(a.id, placed[j].id);
        ov.b = std::max(a.id, placed[j].id);
      }
      return false;
    });
    const double m = sphere_mass(mt.material(a.material).density, a.s.r);
    ov.speed = std::max(ov.speed, std::sqrt(2.0 * stored / m));
  }
  return ov;
}

std::vector<ParticleKind> merge_kinds(const std::vector<ParticleKind>& kinds) {
  std::vector<ParticleKind> out;
  for (const auto& k : kinds) {
    auto it = std::find_if(out.begin(), out.end(), [&](const ParticleKind& o) { return o.material == k.material; });
    if (it == out.end()) {
      out.push_back(k);
      continue;
    }
    it->r_min = std::min(it->r_min, k.r_min);
    it->r_max = std::max(it->r_max, k.r_max);
    it->speed = std::max(it->speed, k.speed);
  }
  return out;
}

namespace {

// The fastest surface of a moving wall (a belt's speed, a drum's rim speed, a moving mesh's speed out to the
// domain's farthest corner from its axis) and its wall's name.
std::pair<double, std::string> fastest_wall_surface(const config::CaseSpec& cs) {
  std::pair<double, std::string> out{0.0, ""};
  for (const auto& w : cs.walls) {
    double v = w.surface_speed();
    if (w.moves_rigidly())
      v = norm(w.move_velocity) +
          norm(w.move_angular_velocity) * farthest_corner(cs.domain.min, cs.domain.max, w.move_center);
    if (v > out.first) out = {v, w.name};
  }
  return out;
}

// Impact speed: given, or the fastest insertion speed plus a free fall over the domain plus the fastest moving
// wall's surface speed; raised to what the initial overlaps can throw a particle at.
void find_impact_speed(StabilityReport& r, const config::CaseSpec& cs, const std::vector<ParticleKind>& kinds,
                       double gravity_height, const InitialOverlap& overlaps) {
  const auto [wall_speed, wall] = fastest_wall_surface(cs);
  if (cs.stability.max_impact_speed >= 0.0) {
    r.impact_speed = cs.stability.max_impact_speed;
    if (wall_speed > r.impact_speed)
      r.lines.push_back(fmt::format("stability: warning: wall '{}' moves its surface at {:.3g} m/s, faster than "
                                    "[stability] max_impact_speed = {:.3g} m/s: a particle it strikes is not covered "
                                    "by the contact checks below",
                                    wall, wall_speed, r.impact_speed));
  } else {
    const double g = std::sqrt(norm2(cs.gravity));
    for (const auto& k : kinds)
      r.impact_speed = std::max(r.impact_speed, std::sqrt(k.speed * k.speed + 2.0 * g * gravity_height));
    if (wall_speed > 0.0) {
      r.impact_speed += wall_speed;
      r.impact_wall = wall;
      r.lines.push_back(fmt::format("stability: wall '{}' moves its surface at up to {:.3g} m/s: added to the impact "
                                    "speed",
                                    wall, wall_speed));
    }
    r.impact_speed_estimated = true;
  }
  if (overlaps.speed > r.impact_speed) {
    r.impact_speed = overlaps.speed;
    r.impact_speed_estimated = true;
    r.impact_speed_from_overlaps = true;
  }
  if (overlaps.ratio > 0.0)
    r.lines.push_back(fmt::format("stability: particles placed overlapping, up to {:.1f} % of the radius (ids {} and "
                                  "{}); the stored energy can throw a particle at {:.3g} m/s{}",
                                  100.0 * overlaps.ratio, overlaps.a, overlaps.b, overlaps.speed,
                                  r.impact_speed_from_overlaps ? " (used as the impact speed)" : ""));
}

// Hertz contact time and overlap of the smallest partners at speed v: particle pairs and particle-wall.
void find_contact_limits(StabilityReport& r, const MaterialTable& mt, const std::vector<ParticleKind>& kinds,
                         const std::vector<int>& wall_materials, double v) {
  r.contact_time = std::numeric_limits<double>::infinity();
  auto consider = [&](double m_eff, double r_eff, double e_star, double r_small) {
    r.contact_time = std::min(r.contact_time, hertz_contact_time(m_eff, r_eff, e_star, v));
    r.overlap_ratio = std::max(r.overlap_ratio, hertz_max_overlap(m_eff, r_eff, e_star, v) / r_small);
  };
  for (const auto& a : kinds) {
    const double ma = sphere_mass(mt.material(a.material).density, a.r_min);
    for (const auto& b : kinds) {
      const auto& c = mt.pair(a.material, b.material);
      if (!c.defined) continue;
      // The smallest partners give the shortest contact; the smallest against the
      // largest the deepest overlap relative to the smaller radius (polydisperse beds).
      for (const double rb : {b.r_min, b.r_max}) {
        const double mb = sphere_mass(mt.material(b.material).density, rb);
        consider(ma * mb / (ma + mb), a.r_min * rb / (a.r_min + rb), c.e_star, std::min(a.r_min, rb));
      }
    }
    for (int wm : wall_materials) {
      const auto& c = mt.pair(a.material, wm);
      if (c.defined) consider(ma, a.r_min, c.e_star, a.r_min);
    }
  }
}

// Refuses a dt above the Rayleigh or Hertz limits (unless overridden with a reason) and impacts that would
// overlap more than allowed; `where` is the level's dt in messages.
void enforce_limits(StabilityReport& r, const config::StabilitySpec& st, double dt, const std::string& where) {
  std::vector<std::string> problems;
  if (dt > st.rayleigh_fraction * r.rayleigh_time)
    problems.push_back(fmt::format("dt = {:.4g} s is above {:.0f} % of the Rayleigh time {:.4g} s of the smallest "
                                   "particle (radius {:.4g} m); use dt <= {:.4g} s",
                                   dt, 100.0 * st.rayleigh_fraction, r.rayleigh_time, r.rayleigh_radius,
                                   st.rayleigh_fraction * r.rayleigh_time));
  if (r.steps_per_contact < st.min_steps_per_contact)
    problems.push_back(fmt::format("dt = {:.4g} s resolves a Hertz contact at {:.3g} m/s with only {:.1f} steps "
                                   "(need {:.0f}); use dt <= {:.4g} s",
                                   dt, r.impact_speed, r.steps_per_contact, st.min_steps_per_contact,
                                   r.contact_time / st.min_steps_per_contact));
  if (!problems.empty()) {
    if (st.dt_override_reason.empty()) {
      std::string msg = where + ": time step refused: " + problems.front();
      for (size_t k = 1; k < problems.size(); ++k) msg += "; and " + problems[k];
      msg += ". To run anyway, set [stability] dt_override_reason = \"why this is safe\".";
      throw StabilityError(msg);
    }
    r.overridden = true;
    for (const auto& p : problems) r.lines.push_back("stability: OVERRIDDEN (" + st.dt_override_reason + "): " + p);
  }
  if (r.overlap_ratio > st.max_overlap_fraction)
    throw StabilityError(fmt::format(
        "{}: impacts at {:.3g} m/s{} would overlap {:.1f} % of the radius, above [stability] max_overlap_fraction = "
        "{:.0f} %; the run would stop at the first such impact. Use a stiffer material, a lower speed, set "
        "[stability] max_impact_speed if the estimate is too pessimistic, or raise max_overlap_fraction",
        where, r.impact_speed,
        r.impact_speed_from_overlaps  ? " (the speed the initial overlaps can give a particle; separate the placed "
                                        "particles)"
        : r.impact_speed_estimated
            ? (r.impact_wall.empty() ? std::string(" (estimated from insertion speed and free fall)")
                                     : " (estimated from insertion speed, free fall and the surface of wall '" +
                                           r.impact_wall + "')")
            : std::string(),
        100.0 * r.overlap_ratio, 100.0 * st.max_overlap_fraction));
}

}  // namespace

StabilityReport check_stability(const config::CaseSpec& cs, const config::LevelSpec& lvl, const MaterialTable& mt,
                                const std::vector<ParticleKind>& kinds, const std::vector<int>& wall_materials,
                                double gravity_height, const InitialOverlap& overlaps) {
  StabilityReport r;
  const auto& st = cs.stability;
  const double dt = lvl.dt;
  if (kinds.empty()) {
    r.lines.push_back("stability: no particles will be inserted; nothing to check");
    return r;
  }
  // Rayleigh time of the smallest particle of every material.
  r.rayleigh_time = std::numeric_limits<double>::infinity();
  for (const auto& k : kinds) {
    const double tr = rayleigh_time(k.r_min, mt.material(k.material));
    if (tr < r.rayleigh_time) { r.rayleigh_time = tr; r.rayleigh_radius = k.r_min; }
  }
  find_impact_speed(r, cs, kinds, gravity_height, overlaps);
  find_contact_limits(r, mt, kinds, wall_materials, std::max(r.impact_speed, 1e-6));
  r.steps_per_contact = r.contact_time / dt;

  r.lines.push_back(fmt::format("stability: Rayleigh time {:.4g} s (radius {:.4g} m); dt = {:.4g} s is {:.1f} % of it "
                                "(limit {:.0f} %)",
                                r.rayleigh_time, r.rayleigh_radius, dt, 100.0 * dt / r.rayleigh_time,
                                100.0 * st.rayleigh_fraction));
  r.lines.push_back(fmt::format("stability: Hertz contact time {:.4g} s at impact speed {:.3g} m/s{} = {:.1f} steps "
                                "(minimum {:.0f}); largest overlap {:.1f} % of the radius (limit {:.0f} %)",
                                r.contact_time, r.impact_speed, r.impact_speed_estimated ? " (estimated)" : "",
                                r.steps_per_contact, st.min_steps_per_contact, 100.0 * r.overlap_ratio,
                                100.0 * st.max_overlap_fraction));
  enforce_limits(r, st, dt, lvl.loc.str() + ": levels[" + lvl.name + "].dt");
  return r;
}

}  // namespace mlcg
