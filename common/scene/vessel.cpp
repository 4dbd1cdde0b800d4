#include "scene/vessel.hpp"

#include <memory>

#include "scene/materials_from_case.hpp"
#include "scene/walls_from_case.hpp"

namespace mlcg {

config::WallCrossing vessel_crossing(const config::CaseSpec& cs) {
  auto walls = std::make_shared<const WallSet>(walls_from_case(cs, materials_of_case(cs)));
  return [walls](const Vec3& a, const Vec3& b) { return walls->crosses(a, b); };
}

}  // namespace mlcg
