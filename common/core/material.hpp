#pragma once
// Materials and the per-pair contact coefficients derived from them
// (DESIGN.md §2). The table is built once per run; the hot loops read
// precomputed effective values by material index, never recompute them.
#include <string>
#include <vector>

namespace mlcg {

struct Material {
  std::string name;
  double youngs_modulus = 0.0;  // E [Pa]
  double poisson_ratio = 0.0;   // nu [-]
  double density = 0.0;         // rho [kg/m^3]
};

// What the case states for a pair of materials.
struct InteractionSpec {
  double restitution = 1.0;       // e in (0,1]
  double friction = 0.0;          // mu (Coulomb)
  double rolling_friction = 0.0;  // mu_r (only used by a rolling model)
};

// Effective values a contact needs, for one ordered pair of materials.
struct PairCoeffs {
  double e_star = 0.0;   // 1/E* = (1-nu1^2)/E1 + (1-nu2^2)/E2
  double g_star = 0.0;   // 1/G* = 2(2-nu1)(1+nu1)/E1 + 2(2-nu2)(1+nu2)/E2
  double beta = 0.0;     // ln e / sqrt(ln^2 e + pi^2)  (<= 0)
  double mu = 0.0;
  double mu_roll = 0.0;
  // Damping prefactors: gamma_n = gn * q and gamma_t = gt * q with
  // q = sqrt(m* sqrt(R* delta)), since sqrt(5 m* k_n) = sqrt(20/3 E*) q and
  // sqrt(10/3 m* k_t) = sqrt(80/3 G*) q; one square root serves both.
  double gn = 0.0;  // -beta sqrt(20/3 E*)
  double gt = 0.0;  // -beta sqrt(80/3 G*)
  bool defined = false;  // false: no interaction given for this pair
};

double effective_modulus(const Material& a, const Material& b);
double effective_shear_modulus(const Material& a, const Material& b);
double damping_beta(double restitution);

class MaterialTable {
 public:
  MaterialTable() = default;
  explicit MaterialTable(std::vector<Material> materials);

  void set_interaction(int a, int b, const InteractionSpec& spec);
  int size() const { return static_cast<int>(materials_.size()); }
  const Material& material(int i) const { return materials_[static_cast<size_t>(i)]; }
  const PairCoeffs& pair(int a, int b) const { return pairs_[static_cast<size_t>(a * size() + b)]; }
  const std::vector<PairCoeffs>& pairs() const { return pairs_; }
  int index_of(const std::string& name) const;  // -1 if absent

 private:
  std::vector<Material> materials_;
  std::vector<PairCoeffs> pairs_;
};

// Rayleigh time of a sphere of radius r (Li et al. 2005 fit, as LIGGGHTS uses).
double rayleigh_time(double radius, const Material& m);
// Duration of a Hertz contact (undamped) at normal impact speed v.
double hertz_contact_time(double m_eff, double r_eff, double e_star, double speed);
// Largest Hertz overlap (undamped) at normal impact speed v.
double hertz_max_overlap(double m_eff, double r_eff, double e_star, double speed);

}  // namespace mlcg
