#pragma once
// The case's walls as a config::WallCrossing for the region rules' lateral margins: whether a segment leaves
// the vessel through a wall. Every wall of the case counts, lids too (a lid lies under or beside its outlet,
// not across the vessel the margins are measured in).
//
// Contract: reads the case's STL files once (throws std::runtime_error naming an unreadable one, as
// walls_from_case does); the returned function owns its walls and is cheap to copy.
#include "config/case_spec.hpp"
#include "config/region_rules.hpp"

namespace mlcg {

config::WallCrossing vessel_crossing(const config::CaseSpec& cs);

}  // namespace mlcg
