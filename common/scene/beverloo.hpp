#pragma once
// Beverloo's discharge rate through an outlet of the scene: a sanity line beside a measured <m_dot>, printed
// by `mlcg check` for every outlet. Not the answer (the fully resolved run is): the law is for flat-bottomed
// bins, hoppers discharge faster (silo_small's 30 degree cone: 1.45x), and its constants carry ~10 %.
//
//   circle of diameter D0 (Beverloo, Leniger & van de Velde, Chem. Eng. Sci. 15, 260, 1961):
//       W = C rho_b sqrt(g) (D0 - k d)^(5/2),             C = 0.58, k = 1.5
//   slot W0 x L (the slot form, as quoted by Nedderman, Statics and Kinematics of Granular Materials, 1992,
//   ch. 10; for L well above W0):
//       W = C' rho_b sqrt(g) (W0 - k d)^(3/2) (L - k d),   C' = 1.03
//   rectangle W0 x L: the circle law on the circle of the same area, D0 = 2 sqrt(W0 L / pi) (the slot form
//   gives a square 1.4x a circle's rate; cases/outlets' 3 and 2 cm squares measured 0.88x and 0.82x this);
//   a polygon: the circle of its width.
// rho_b = phi rho_p (phi = 0.6), d = the number-mean diameter of the case's insertions at alpha = 1 times the
// alpha of its finest level (the particles that pass the outlet), rho_p the first insertion's material,
// g = |gravity|. A case without insertions has no estimate, nor has an outlet that does not face down within
// 45 degrees (the law is for outlets in a floor: side_outlet's 3 cm hole in a wall measured 0.43x it).
#include <optional>

#include "config/case_spec.hpp"
#include "config/outlet.hpp"

namespace mlcg {

struct BeverlooEstimate {
  double kg_per_s;
  double d;      // particle diameter used [m]
  double rho_b;  // bulk density used [kg/m^3]
  double size;   // the D0 (or a slot's W0) used [m]
};

inline constexpr double kBeverlooPhi = 0.6;
inline constexpr double kFloorCos = 0.7071;  // cos 45 degrees

bool faces_down(const config::Outlet& o);

std::optional<BeverlooEstimate> beverloo(const config::CaseSpec& cs, const config::Outlet& o);

}  // namespace mlcg
