#pragma once
// The keys of the top level and of the physics, output and time tables of a case file (case_schema.hpp
// says what a KeySpec is and what follows from it). The type, default and allowed texts are those of
// cases/README.md's key tables, verbatim: tests/test_case_keys.cpp fails when they differ.
#include "config/case_schema.hpp"

namespace mlcg::config::schema {

// The top level: `base` (a variant's base, read before anything else), four keys, and the tables.
inline constexpr KeySpec kTop[] = {
    {"base", "string", "none", "", "the case this file varies, relative to this file's folder"},
    {"title", "string", "`\"\"`", "", "a free-text title for logs and reports"},
    {"seed", "integer ≥ 0", "`1`", "", "the seed of every random choice (an integer >= 0)", kNonNegative},
    {"gravity", "vector", "`[0, 0, -9.81]`", "", "the gravitational acceleration [x, y, z] in m/s^2"},
    {"materials", "array of tables", "*required*", "", "one [[materials]] entry per material"},
    {"interactions", "array of tables", "*required*", "", "one [[interactions]] entry per pair of materials"},
    {"contact", "table", "", "", "the contact model"},
    {"levels", "array of tables", "*required*", "", "one [[levels]] entry per coarse-grain level"},
    {"domain", "table", "*required*", "", "the simulation box"},
    {"walls", "array of tables", "", "", "one [[walls]] entry per wall"},
    {"insertion", "array of tables", "", "", "one [[insertion]] entry per pouring source"},
    {"particles", "array of tables", "", "", "one [[particles]] entry per explicitly placed particle"},
    {"initial", "table", "", "", "particles from a snapshot file"},
    {"events", "array of tables", "", "", "one [[events]] entry per event"},
    {"probes", "array of tables", "", "", "one [[probes]] entry per mass-flow probe"},
    {"grids", "array of tables", "", "", "one [[grids]] entry per statistics grid"},
    {"output", "table", "", "", "what is written and how often"},
    {"stability", "table", "", "", "the guards of the time step"},
    {"time", "table", "*required*", "", "when the run ends"},
    {"orifice", "table", "", "", "the scene's outlet"},
    {"orifices", "array of tables", "", "", "one [[orifices]] entry per outlet"},
    {"coupling", "table", "", "", "the coupling of a multi-level case"},
    {"launcher", "table", "", "", "how mlcg run supervises a multi-level run"},
    {"swap", "array of tables", "", "", "one [[swap]] entry per binary swap"},
    {"limits", "table", "", "", "what a run may ask of the machine"},
};

inline constexpr KeySpec kMaterial[] = {
    {"name", "string", "*required*", "unique, non-empty", "the material's name, e.g. name = \"glass\""},
    // Diamond has 1.2e12 Pa; far above, the Hertz coefficients overflow and the guard asks for dt = 0.
    {"youngs_modulus", "number", "*required*", "(0, 1e14]", "Young's modulus in Pa (> 0)",
     {0.0, 1e14, true, false}, "Pa", "no solid is stiffer than about 1.2e12 Pa (diamond)"},
    {"poisson_ratio", "number", "*required*", "[0, 0.5)", "Poisson's ratio in [0, 0.5)", {0.0, 0.5, false, true}},
    {"density", "number", "*required*", "> 0", "the particle density in kg/m^3 (> 0)", kPositive, "kg/m^3"},
};

inline constexpr KeySpec kInteraction[] = {
    {"between", "array of 2 strings", "*required*", "names of `[[materials]]`",
     "the two materials, e.g. between = [\"glass\", \"steel\"]"},
    {"restitution", "number", "*required*", "(0, 1]", "the coefficient of restitution in (0, 1]",
     {0.0, 1.0, true, false}},
    {"friction", "number", "*required*", "≥ 0", "the Coulomb friction coefficient (>= 0)", kNonNegative},
    {"rolling_friction", "number", "`0`", "≥ 0", "the rolling friction coefficient (>= 0)", kNonNegative},
};

inline constexpr KeySpec kContact[] = {
    {"normal", "string", "`\"hertz\"`", "`\"hertz\"`", "the normal force law"},
    {"tangential", "string", "`\"history\"`", "`\"history\"`, `\"none\"`", "the tangential force law"},
    {"rolling", "string", "`\"none\"`", "`\"none\"`, `\"cdt\"`", "the rolling resistance model"},
    {"clamp_normal", "boolean", "`false`", "", "whether the normal force is clamped at zero"},
};

inline constexpr KeySpec kLevel[] = {
    {"name", "string", "`\"level0\"` (`\"level<i>\"` for entry i)", "unique", "the level's name"},
    {"alpha", "number", "`1`", "≥ 1", "the coarse-grain ratio alpha (>= 1)", at_least(1.0)},
    {"dt", "number", "*required* unless `dt_alpha1` or `dt_rayleigh`", "> 0",
     "the time step in s (> 0), or dt_alpha1, or dt_rayleigh", kPositive, "s"},
    {"dt_alpha1", "number", "—", "> 0; not with `dt`", "the time step at alpha = 1 in s (> 0)", kPositive, "s"},
    {"dt_rayleigh", "number", "—", "(0, 1]; not with `dt` or `dt_alpha1`, nor with `[initial]`",
     "a share of the Rayleigh time in (0, 1]", {0.0, 1.0, true, false}},
    {"ranks", "integer", "`1`", "1 to 1e6", "the MPI processes of this level (1 to 1e6)", closed(1.0, 1e6), "",
     "the number of MPI processes of this level"},
    {"skin", "number", "`0`", "≥ 0", "the neighbour-list skin in m (>= 0)", kNonNegative, "m (0 = automatic)"},
    {"processors", "array of 3 integers", "automatic", "product = `ranks`", "the process grid [px, py, pz]"},
    {"balance", "boolean", "`true`", "", "whether the rank boundaries move to even out the particles"},
};

inline constexpr KeySpec kDomain[] = {
    {"min", "vector", "*required*", "", "the lower corner, e.g. min = [-0.1, -0.1, 0.0] (m)"},
    {"max", "vector", "*required*", "`max > min` in every axis", "the upper corner, e.g. max = [0.1, 0.1, 0.5] (m)"},
};

inline constexpr KeySpec kOutput[] = {
    {"snapshot_interval", "number", "`0`", "≥ 0", "how often particle snapshots are written, in s", kNonNegative,
     "s (0 = only the final state)"},
    {"checkpoint_interval", "number", "`0`", "≥ 0", "how often checkpoints are written, in s", kNonNegative,
     "s (0 = only at the end)"},
    {"stats_interval", "number", "`0.01`", "> 0", "how often rows of series.csv are written, in s", kPositive, "s"},
    {"energy_interval", "number", "`0`", "≥ 0", "how often rows of energy.csv are written, in s", kNonNegative,
     "s (0 = no energy account)"},
};

inline constexpr KeySpec kStability[] = {
    {"rayleigh_fraction", "number", "`0.2`", "(0, 1]", "the largest share of the Rayleigh time dt may be",
     {0.0, 1.0, true, false}},
    {"min_steps_per_contact", "number", "`10`", "≥ 1", "the fewest time steps a Hertz contact may last",
     at_least(1.0), "", "the fewest time steps a Hertz contact may last"},
    {"max_overlap_fraction", "number", "`0.3`", "(0, 1]", "the largest overlap, a share of the smaller radius",
     {0.0, 1.0, true, false}},
    {"max_impact_speed", "number", "`-1`", "≠ 0", "the impact speed in m/s of the contact-time guard"},
    {"dt_override_reason", "string", "`\"\"`", "", "why a dt above the guards is accepted"},
};

inline constexpr KeySpec kLimits[] = {
    {"max_steps", "integer", "`1000000000`", "≥ 1", "the most time steps a level may take to reach the end",
     at_least(1.0), "", "the most time steps a level may take to reach the end"},
    {"max_output_files", "integer", "`20000`", "≥ 1", "the most files a run may write", at_least(1.0), "",
     "the most files a run may write"},
    {"max_memory_gb", "number", "`16`", "> 0", "the most memory a run may hold, in GB", kPositive, "GB"},
};

inline constexpr KeySpec kTime[] = {
    {"end", "number or table", "*required*", "number > 0, or `{ event = \"<name>\", plus = <s> }`",
     "end = <seconds> or end = { event = \"<event name>\", plus = <seconds> }", kPositive, "s"},
    // More often, the log grows by a line a step.
    {"progress_interval", "number", "`2`", "≥ 0.1", "the wall-clock seconds between progress lines", at_least(0.1),
     "s of wall time", "progress lines more often would fill the log"},
};

// end = { event = "open", plus = 0.6 }
inline constexpr KeySpec kEndAfterEvent[] = {
    {"event", "string", "*required*", "an `[[events]]` name", "the name of an [[events]] entry"},
    {"plus", "number", "`0`", "≥ 0", "the seconds after the event fires", kNonNegative, "s"},
};

}  // namespace mlcg::config::schema
