#pragma once
// An outlet of the scene: where the flow leaves the vessel. Plain values, found from the walls and
// events (scene/outlets.hpp) or given by [orifice] / [[orifices]]; the region rules, `mlcg check`, the
// run summary and `mlcg plan` read them from one OutletScan.
#include <string>
#include <vector>

#include "core/vec3.hpp"

namespace mlcg::config {

struct Outlet {
  std::string name;        // "outlet0", "outlet1"... in the order found, or the [[orifices]] entry's name
  Vec3 center;             // [m]
  Vec3 normal{0, 0, -1};   // unit, outward: the direction the flow leaves the vessel through it
  std::string shape;       // "circle", "rectangle", "slot", "polygon"
  double width = 0.0;      // a circle's diameter, else the narrow side [m]: the D0 of the rules
  double length = 0.0;     // a circle's diameter, else the long side [m]
  std::string from;        // where it was found, for messages: "lid 'lid' over cone 'cone'", "[orifice] (case.toml:40)"
  std::string opened_by;   // "event 'open' removes wall 'lid'"; empty when open from the start
  double size() const { return width; }
};

struct OutletScan {
  std::vector<Outlet> outlets;
  std::vector<std::string> notes;  // openings seen and not taken as outlets, and why
  bool given = false;              // the outlets are [orifice] / [[orifices]]; notes list what the walls show
};

// "outlet0: circle D0 = 0.04 m at [0, 0, 0], flow leaves along [0, 0, -1], from lid 'lid' over the bottom of
// cone 'cone', opens with event 'open' (removes wall 'lid')"
std::string outlet_text(const Outlet& o);
// Two unit directions across the outlet (in its plane), perpendicular to each other and to its normal; axis-
// aligned when the normal is (a floor's outlet: x and y). The region rules and `mlcg plan` measure margins
// across the outlet along these.
void across(const Outlet& o, Vec3& a, Vec3& b);
// "[0, 0, -1]": a position or direction in messages (4 significant digits, no negative zero).
std::string vec_text(const Vec3& v);

}  // namespace mlcg::config
