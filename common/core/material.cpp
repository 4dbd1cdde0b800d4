#include "core/material.hpp"

#include <cmath>
#include <numbers>
#include <stdexcept>

namespace mlcg {

double effective_modulus(const Material& a, const Material& b) {
  const double inv = (1.0 - a.poisson_ratio * a.poisson_ratio) / a.youngs_modulus +
                     (1.0 - b.poisson_ratio * b.poisson_ratio) / b.youngs_modulus;
  return 1.0 / inv;
}

double effective_shear_modulus(const Material& a, const Material& b) {
  const double inv = 2.0 * (2.0 - a.poisson_ratio) * (1.0 + a.poisson_ratio) / a.youngs_modulus +
                     2.0 * (2.0 - b.poisson_ratio) * (1.0 + b.poisson_ratio) / b.youngs_modulus;
  return 1.0 / inv;
}

double damping_beta(double e) {
  if (e >= 1.0) return 0.0;
  const double l = std::log(e);
  return l / std::sqrt(l * l + std::numbers::pi * std::numbers::pi);
}

MaterialTable::MaterialTable(std::vector<Material> materials) : materials_(std::move(materials)) {
  pairs_.assign(materials_.size() * materials_.size(), PairCoeffs{});
}

void MaterialTable::set_interaction(int a, int b, const InteractionSpec& s) {
  PairCoeffs c;
  c.e_star = effective_modulus(material(a), material(b));
  c.g_star = effective_shear_modulus(material(a), material(b));
  c.beta = damping_beta(s.restitution);
  c.mu = s.friction;
  c.mu_roll = s.rolling_friction;
  c.gn = -c.beta * std::sqrt(20.0 / 3.0 * c.e_star);
  c.gt = -c.beta * std::sqrt(80.0 / 3.0 * c.g_star);
  c.defined = true;
  pairs_[static_cast<size_t>(a * size() + b)] = c;
  pairs_[static_cast<size_t>(b * size() + a)] = c;
}

int MaterialTable::index_of(const std::string& name) const {
  for (int i = 0; i < size(); ++i)
    if (materials_[static_cast<size_t>(i)].name == name) return i;
  return -1;
}

double rayleigh_time(double radius, const Material& m) {
  const double g = m.youngs_modulus / (2.0 * (1.0 + m.poisson_ratio));
  return std::numbers::pi * radius * std::sqrt(m.density / g) / (0.1631 * m.poisson_ratio + 0.8766);
}

double hertz_contact_time(double m_eff, double r_eff, double e_star, double v) {
  return 2.868 * std::pow(m_eff * m_eff / (r_eff * e_star * e_star * v), 0.2);
}

double hertz_max_overlap(double m_eff, double r_eff, double e_star, double v) {
  return std::pow(15.0 * m_eff * v * v / (16.0 * e_star * std::sqrt(r_eff)), 0.4);
}

}  // namespace mlcg
