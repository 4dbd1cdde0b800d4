#include "scene/beverloo.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace mlcg {

namespace {
constexpr double kCircle = 0.58, kSlot = 1.03, kShrink = 1.5;
}

bool faces_down(const config::Outlet& o) { return o.normal.z <= -kFloorCos; }

std::optional<BeverlooEstimate> beverloo(const config::CaseSpec& cs, const config::Outlet& o) {
  if (cs.insertions.empty() || cs.levels.empty() || !faces_down(o)) return std::nullopt;
  double finest = cs.levels.front().alpha, d = 0.0;
  for (const auto& l : cs.levels) finest = std::min(finest, l.alpha);
  for (const auto& in : cs.insertions) d += 2.0 * in.radius.mean();
  d *= finest / static_cast<double>(cs.insertions.size());
  double rho_p = 0.0;
  for (const auto& m : cs.materials)
    if (m.name == cs.insertions.front().material) rho_p = m.density;
  const double rho_b = kBeverlooPhi * rho_p, sqrt_g = std::sqrt(norm(cs.gravity));
  if (o.shape == "slot") {
    const double rate = kSlot * rho_b * sqrt_g * std::pow(std::max(o.width - kShrink * d, 0.0), 1.5) *
                        std::max(o.length - kShrink * d, 0.0);
    return BeverlooEstimate{rate, d, rho_b, o.width};
  }
  const double d0 = o.shape == "rectangle" ? 2.0 * std::sqrt(o.width * o.length / std::numbers::pi) : o.width;
  return BeverlooEstimate{kCircle * rho_b * sqrt_g * std::pow(std::max(d0 - kShrink * d, 0.0), 2.5), d, rho_b, d0};
}

}  // namespace mlcg
