#pragma once
// The keys of the scene tables of a case file: walls (every wall, then each type's own), insertion with
// its region and radius distribution, particles, initial, orifice, events, probes and grids
// (case_schema.hpp says what a KeySpec is). The type, default and allowed texts are those of
// cases/README.md's key tables, verbatim: tests/test_case_keys.cpp fails when they differ.
#include "config/case_schema.hpp"

namespace mlcg::config::schema {

// [[walls]]: every wall, then the keys of each type.
inline constexpr KeySpec kWall[] = {
    {"name", "string", "*required*", "unique", "the wall's name, e.g. name = \"silo\""},
    {"type", "string", "*required*", "`\"plane\"`, `\"cylinder\"`, `\"cone\"`, `\"disk\"`, `\"mesh\"`",
     "the wall's type"},
    {"material", "string", "*required*", "a `[[materials]]` name", "the name of a [[materials]] entry"},
    // The geometry stays in place; only what a particle touching the surface feels moves.
    {"surface_velocity", "vector", "`[0, 0, 0]`", "plane, mesh: along the surface",
     "the velocity of the wall's surface in m/s, the geometry staying in place (a conveyor belt)"},
    {"angular_velocity", "number", "`0`", "cylinder, cone, disk",
     "the rate the wall turns about its own axis in rad/s, right-handed about axis (a drum)", kAny, "rad/s"},
    // The whole mesh moves (its geometry too), from t = 0.
    {"move_velocity", "vector", "`[0, 0, 0]`", "mesh",
     "the velocity the whole mesh moves at in m/s, from t = 0 (a pusher, a piston)"},
    {"move_angular_velocity", "vector", "`[0, 0, 0]`", "mesh",
     "the rate the whole mesh turns at in rad/s, a vector along the axis (right-handed), from t = 0"},
    {"move_center", "vector", "`[0, 0, 0]`", "", "where the axis of move_angular_velocity passes at t = 0 (m)"},
};

inline constexpr KeySpec kPlane[] = {
    {"point", "vector", "`[0, 0, 0]`", "", "a point on the plane (m)"},
    {"normal", "vector", "`[0, 0, 1]`", "non-zero", "the direction towards the particles"},
};

// The keys cylinder, cone and disk walls share, and their radii and extent along the axis.
inline constexpr KeySpec kWallCenter{"center", "vector", "`[0, 0, 0]`", "", "a point on the axis (m)"};
inline constexpr KeySpec kWallAxis{"axis", "vector", "`[0, 0, 1]`", "non-zero", "the axis direction"};
inline constexpr KeySpec kWallRadius{"radius", "number", "*required*", "> 0", "the radius in m (> 0)", kPositive, "m"};
inline constexpr KeySpec kWallBottom{"bottom", "number", "*required*", "< `top`",
                                     "the lower end along the axis, measured from center (m)"};
inline constexpr KeySpec kWallTop{"top", "number", "*required*", "> `bottom`",
                                  "the upper end along the axis, measured from center (m)"};
inline constexpr KeySpec kWallRims{"rims", "string", "`\"none\"`", "`\"none\"`, `\"bottom\"`, `\"top\"`, `\"both\"`",
                                   "which end circles particles can also touch"};

inline constexpr KeySpec kCylinder[] = {kWallCenter, kWallAxis, kWallRadius, kWallBottom, kWallTop, kWallRims};
inline constexpr KeySpec kCone[] = {
    kWallCenter,
    kWallAxis,
    {"radius_bottom", "number", "*required*", "≥ 0", "the radius at bottom in m (>= 0)", kNonNegative, "m"},
    {"radius_top", "number", "*required*", "≥ 0, not both radii 0", "the radius at top in m (>= 0)", kNonNegative, "m"},
    kWallBottom,
    kWallTop,
    kWallRims,
};
inline constexpr KeySpec kDisk[] = {
    kWallCenter,
    kWallAxis,
    kWallRadius,
    {"inner_radius", "number", "`0`", "[0, `radius`)", "the radius of the disk's hole in m (0 = a full disk)"},
};
inline constexpr KeySpec kMesh[] = {
    {"file", "string", "*required*", "an existing file", "the STL file, relative to the case file's folder"},
    {"scale", "number", "`1`", "> 0", "the factor on the file's coordinates (> 0)", kPositive},
    {"offset", "vector", "`[0, 0, 0]`", "", "the shift added after scaling (m)"},
};

inline constexpr KeySpec kInsertion[] = {
    {"name", "string", "`\"insertion<i>\"`", "unique", "the insertion's name"},
    {"material", "string", "*required*", "a `[[materials]]` name", "the name of a [[materials]] entry"},
    {"region", "table", "*required*", "see below; inside the domain",
     "region = { type = \"box\", min = [...], max = [...] } or region = { type = \"cylinder\", center = [x, y], "
     "radius = r, zmin = z0, zmax = z1 }"},
    {"radius", "number or table", "*required*", "see below",
     "radius = <m>, radius = { uniform = [min, max] } or radius = { values = [...], fractions = [...] }", kPositive,
     "m"},
    {"count", "integer", "—", "≥ 1", "the number of particles to insert (>= 1)", at_least(1.0), "",
     "the number of particles to insert"},
    {"count_alpha1", "integer", "—", "1 … 2⁵³; ≥ α³ / 2", "the number of particles at alpha = 1"},
    {"mass", "number", "—", "> 0", "the total mass to insert in kg (> 0)", kPositive, "kg"},
    {"rate", "number", "—", "> 0", "the insertion rate in particles/s (> 0)", kPositive, "particles/s"},
    {"rate_alpha1", "number", "—", "> 0", "the insertion rate at alpha = 1 in particles/s (> 0)", kPositive,
     "particles/s at alpha = 1"},
    {"mass_rate", "number", "—", "> 0", "the insertion rate in kg/s (> 0)", kPositive, "kg/s"},
    {"start", "number", "`0`", "≥ 0", "the time of the first batch in s (>= 0)", kNonNegative, "s"},
    {"interval", "number", "`0`", "≥ 0", "the batch period in s (>= 0)", kNonNegative, "s (0 = automatic)"},
    {"velocity", "vector", "`[0, 0, 0]`", "", "the initial velocity of inserted particles (m/s)"},
    {"follow_gap", "number", "off", "≥ 0", "the height of the slab's bottom above the heap in m (>= 0)", kNonNegative,
     "m"},
    {"follow_height", "number", "10 largest radii", "> 0; needs `follow_gap`", "the height of the slab in m (> 0)",
     kPositive, "m"},
    {"max_attempts", "integer", "`200`", "≥ 1", "the candidates per particle before it counts as unplaced",
     closed(1.0, 1e9), "", "the candidates per particle before it counts as unplaced"},
};

// An insertion's region = { ... }: a box or a vertical cylinder.
inline constexpr KeySpec kRegionType{"type", "string", "`\"box\"`", "`\"box\"`, `\"cylinder\"`", "the region's shape"};
inline constexpr KeySpec kBoxRegion[] = {
    kRegionType,
    {"min", "vector", "*required*", "`max > min` in every axis", "the lower corner of the region (m)"},
    {"max", "vector", "*required*", "`max > min` in every axis", "the upper corner of the region (m)"},
};
inline constexpr KeySpec kCylinderRegion[] = {
    kRegionType,
    {"center", "array of 2 numbers", "*required*", "", "the axis position [x, y] (m)"},
    {"radius", "number", "*required*", "> 0", "the radius in m (> 0)", kPositive, "m"},
    {"zmin", "number", "*required*", "`zmin < zmax`", "the lower end in m"},
    {"zmax", "number", "*required*", "`zmin < zmax`", "the upper end in m"},
};

// radius = { uniform = [min, max] } or radius = { values = [...], fractions = [...] }
inline constexpr KeySpec kRadiusDistribution[] = {
    {"uniform", "array of 2 numbers", "", "0 < min < max", "the smallest and largest radius [min, max] (m)"},
    {"values", "array of numbers", "", "values > 0", "the radii (m)"},
    {"fractions", "array of numbers", "", "each ≥ 0, summing to 1", "the number fraction of each value, summing to 1"},
};

inline constexpr KeySpec kParticle[] = {
    {"material", "string", "*required*", "a `[[materials]]` name", "the name of a [[materials]] entry"},
    {"radius", "number", "*required*", "> 0", "the particle radius in m (> 0)", kPositive, "m"},
    {"position", "vector", "*required*", "inside the domain", "the particle centre [x, y, z] in m, inside the domain"},
    {"velocity", "vector", "`[0, 0, 0]`", "", "the initial velocity (m/s)"},
    {"omega", "vector", "`[0, 0, 0]`", "", "the initial angular velocity (rad/s)"},
};

inline constexpr KeySpec kInitial[] = {
    {"file", "string", "*required*", "an existing file, relative to the case",
     "an HDF5 particle snapshot (e.g. a run's particles/particles_000010.h5)"},
    {"material", "string", "*required*", "a `[[materials]]` name", "the name of a [[materials]] entry"},
};

inline constexpr KeySpec kOrifice[] = {
    {"name", "string", "`\"orifice\"` (`\"orifice<i>\"` for entry i)", "unique", "the outlet's name in messages"},
    {"center", "vector", "*required*", "inside the domain", "the centre of the orifice [m], e.g. center = [0, 0, 0]"},
    {"normal", "vector", "`[0, 0, -1]`", "non-zero", "the direction the flow leaves through it"},
    {"diameter", "number", "—", "> 0", "a circular orifice's diameter in m (> 0)", kPositive, "m"},
    {"width", "number", "—", "> 0", "the slot's width in m (its narrow side)", kPositive, "m"},
    {"length", "number", "—", "≥ `width`", "the slot's length in m"},
};

inline constexpr KeySpec kEvent[] = {
    {"name", "string", "*required*", "unique", "the event's name, e.g. name = \"open\""},
    {"at", "number", "—", "≥ 0", "the time the event fires in s (>= 0)", kNonNegative, "s"},
    {"after_insertion", "boolean", "`false`", "", "whether the event waits for every insertion to finish"},
    {"mean_speed_below", "number", "—", "> 0", "the mean speed in m/s below which the event fires", kPositive, "m/s"},
    {"check_interval", "number", "`0.01`", "> 0", "how often a condition is evaluated, in s", kPositive, "s"},
    {"latest", "number", "`inf`", "≥ 0, only with a condition", "the latest time the event fires in s",
     {0.0, kInf, false, false}, "s"},
    {"remove_walls", "array of strings", "`[]`", "`[[walls]]` names", "the names of the walls the event removes"},
};

inline constexpr KeySpec kProbe[] = {
    {"name", "string", "*required*", "unique", "the probe's name, e.g. name = \"orifice\""},
    {"point", "vector", "*required*", "inside the domain", "the centre of the probe disk (m), inside the domain"},
    {"normal", "vector", "`[0, 0, -1]`", "non-zero", "the positive flow direction"},
    {"radius", "number", "*required*", "> 0", "the probe disk's radius in m (> 0)", kPositive, "m"},
    {"sample_rate", "number", "`100`", "> 0", "the samples per simulated second (Hz)", kPositive, "Hz"},
    {"window", "array of 2 numbers", "`[0, inf]`", "0 ≤ t0 < t1; t1 may be `inf`", "the time window [t0, t1] (s)"},
    {"window_relative_to", "string", "—", "an `[[events]]` name", "the name of the event the window counts from"},
};

inline constexpr KeySpec kGrid[] = {
    {"name", "string", "*required*", "unique", "the grid's name, e.g. name = \"bed\""},
    {"min", "vector", "*required*", "`max > min` in every axis; inside the domain", "the lower corner of the box (m)"},
    {"max", "vector", "*required*", "`max > min` in every axis; inside the domain", "the upper corner of the box (m)"},
    {"cell_size", "number", "*required*", "> 0, not larger than the box in any axis",
     "the cubic cell's edge in m (> 0)", kPositive, "m"},
    {"sample_interval", "number", "`0`", "≥ 0, ≤ `output_interval`", "the sampling period of the averages in s",
     kNonNegative, "s (0 = every output_interval)"},
    {"output_interval", "number", "*required*", "> 0", "how often averages are written, in s (> 0)", kPositive, "s"},
};

}  // namespace mlcg::config::schema
