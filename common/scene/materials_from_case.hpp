#pragma once
// The materials and pair interactions of a case as the MaterialTable every program indexes the same way
// (materials in file order). Shared by the level, `mlcg check` and the coupler.
#include "config/case_spec.hpp"
#include "core/material.hpp"

namespace mlcg {

MaterialTable materials_of_case(const config::CaseSpec& cs);

}  // namespace mlcg
