#pragma once
// The outlets of a scene, found once from its walls and events:
//   - openings: a cone's or cylinder's end circle, a disk's hole, and every loop of boundary edges of an
//     STL mesh (walls/mesh_openings.hpp), in a floor or in a side wall;
//   - a cylinder's bottom over a cone's top of the same circle (and any such pair whose walls continue
//     on opposite sides) is a junction inside the vessel, not an opening;
//   - an opening with a smaller one in its plane (a barrel's bottom around a floor's hole) is narrowed
//     to that one;
//   - the outward normal: away from the side the wall continues to (a funnel's bottom opens downward,
//     its top upward); for a hole in a flat plate, away from the fill (the first insertion region's
//     centre, else the first placed particle, else the domain's centre);
//   - an opening facing upward (its normal more than 15 degrees above the horizontal) is an inlet;
//   - an opening a wall covers (a disk over it, a plane or another mesh through its centre) is closed,
//     unless an event removes that wall: then it is an outlet that opens with the event;
//   - a removed disk over no opening is an outlet of its own diameter (the lid is all the scene says).
// [orifice] / [[orifices]] replace the found outlets (the scan's notes still say what the walls show).
//
// Contract: reads the case's STL files (throws std::runtime_error naming an unreadable one, as
// walls_from_case does); never changes the case. Outlets are named outlet0, outlet1... in the order of
// the walls they come from.
#include "config/case_spec.hpp"
#include "config/outlet.hpp"

namespace mlcg {

config::OutletScan find_outlets(const config::CaseSpec& cs);

}  // namespace mlcg
