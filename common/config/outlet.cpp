#include "config/outlet.hpp"

#include <fmt/format.h>

#include <cmath>

namespace mlcg::config {

std::string vec_text(const Vec3& p) {
  auto c = [](double x) { return std::abs(x) < 1e-12 ? 0.0 : x; };
  return fmt::format("[{:.4g}, {:.4g}, {:.4g}]", c(p.x), c(p.y), c(p.z));
}

void across(const Outlet& o, Vec3& a, Vec3& b) {
  const Vec3 n = o.normal;
  const Vec3 helper = std::abs(n.x) <= std::abs(n.y) && std::abs(n.x) <= std::abs(n.z) ? Vec3{1, 0, 0}
                      : std::abs(n.y) <= std::abs(n.z)                             ? Vec3{0, 1, 0}
                                                                                    : Vec3{0, 0, 1};
  a = normalized(cross(n, helper));
  b = cross(n, a);
}

std::string outlet_text(const Outlet& o) {
  const auto v = vec_text;
  const std::string size = o.shape == "circle" ? fmt::format("D0 = {:.4g} m", o.width)
                                               : fmt::format("{:.4g} x {:.4g} m (D0 = its width)", o.width, o.length);
  return fmt::format("{}: {} {} at {}, flow leaves along {}, from {}{}", o.name, o.shape, size, v(o.center),
                     v(o.normal), o.from, o.opened_by.empty() ? ", open from the start" : ", opens with " + o.opened_by);
}

}  // namespace mlcg::config
