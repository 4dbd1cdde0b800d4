#include "scene/materials_from_case.hpp"

namespace mlcg {

MaterialTable materials_of_case(const config::CaseSpec& cs) {
  std::vector<Material> mats;
  for (const auto& m : cs.materials) mats.push_back({m.name, m.youngs_modulus, m.poisson_ratio, m.density});
  MaterialTable mt(std::move(mats));
  for (const auto& in : cs.interactions)
    mt.set_interaction(mt.index_of(in.a), mt.index_of(in.b), {in.restitution, in.friction, in.rolling_friction});
  return mt;
}

}  // namespace mlcg
