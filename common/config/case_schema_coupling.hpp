#pragma once
// The keys of a multi-level case ([coupling], [[coupling.regions]], [launcher], [[swap]]), of a study
// file (`mlcg study`, launcher/study/study_file.cpp) and of a hostfile line (launcher/hosts/hosts.cpp)
// (case_schema.hpp says what a KeySpec is). The type, default and allowed texts are those of
// cases/README.md's key tables, verbatim: tests/test_case_keys.cpp fails when they differ.
#include "config/case_schema.hpp"

namespace mlcg::config::schema {

inline constexpr KeySpec kCoupling[] = {
    {"interval", "number", "`0`", "≥ 0; every level's `dt` divides it", "the coupling interval in s (>= 0)",
     kNonNegative, "s (0 = automatic)"},
    {"endpoint", "string", "`\"\"`", "`\"\"`, `\"tcp://HOST:PORT\"`, `\"ipc://PATH\"`",
     "the coupler's endpoint, tcp://HOST:PORT or ipc://PATH"},
    // Faster, the bus would carry little but heartbeats.
    {"heartbeat", "number", "`1`", "≥ 0.01", "the period of the heartbeats in s of wall time", at_least(0.01),
     "s of wall time"},
    {"timeout", "number", "`60`", "> `heartbeat`", "how long a level may be silent, in s of wall time"},
    {"checkpoint_every", "number", "`0`", "≥ 0", "the simulated time between consistent checkpoints in s",
     kNonNegative, "s of simulated time (0 = automatic)"},
    // The statistics' window moves by `lead`: results depend on it (never on timing).
    {"lead", "number", "`0.5`", "0 to 0.5", "the share of each interval by which a level sends its statistics early",
     closed(0.0, 0.5), "of the interval"},
    // Each sample is a pass over the level's particles in the region and a stress-accumulating force step.
    {"samples", "integer", "`2`", "1 to 64", "the cell samples per coupling interval", closed(1.0, 64.0), "",
     "the number of cell samples per interval"},
    // The plan moves with it: a full slab's mass waits for its next try.
    {"retry_full_every", "integer", "`1`", "1 to 64",
     "the intervals between the insertion tries of a boundary face whose slab was full", closed(1.0, 64.0), "",
     "intervals between a full slab's insertion tries"},
    {"regions", "array of tables", "*required*", "at least one", "one [[coupling.regions]] entry per finer level"},
};

inline constexpr KeySpec kCouplingRegion[] = {
    {"coarse", "string", "*required*", "a `[[levels]]` name",
     "the name of the coarser [[levels]] entry, e.g. coarse = \"cg2\""},
    {"fine", "string", "*required*",
     "a `[[levels]]` name with `alpha` below the coarse level's; the fine level of no other region",
     "the name of the finer [[levels]] entry (smaller alpha), e.g. fine = \"fine\""},
    {"min", "vector", "*required*", "`max > min` in every axis; inside the domain", "the lower corner (m)"},
    {"max", "vector", "*required*", "`max > min` in every axis; inside the domain", "the upper corner (m)"},
    {"cell_size", "number", "`0.02`", "> 0", "the edge of the cubic coupling cells in m (> 0)", kPositive, "m"},
    {"inside", "vector",
     "the box's centre half a cell under its top; where that lies outside the vessel, the middle of the top layer's "
     "cells the fill reaches",
     "inside the box (faces included)",
     "a point inside the geometry and the region's box (m)"},
    {"insert_depth", "number", "`0`", "≥ 0", "the thickness of the insertion slab in m (>= 0)", kNonNegative,
     "m (0 = automatic)"},
    {"fade", "number", "`1.5`", "> 0", "the depth the traction fades out over (> 0)", kPositive,
     "fine particle diameters"},
    {"kp", "number", "`0.5`", "≥ 0", "the PI stress controller's proportional gain (>= 0)", kNonNegative,
     "Pa traction per Pa stress error"},
    {"ki", "number", "`200`", "≥ 0, ki × `interval` ≤ 0.5", "the PI stress controller's integral gain in 1/s",
     kNonNegative, "1/s"},
    {"traction_limit", "number", "`0`", "≥ 0", "the largest traction in Pa (>= 0)", kNonNegative,
     "Pa (0 = automatic)"},
    {"correct", "string", "`\"mass_flow\"`", "`\"mass_flow\"`, `\"velocity\"`, `\"none\"`",
     "how the coarse level is corrected"},
    {"velocity_gain", "number", "`500`", "> 0, and × `interval` ≤ 0.5", "the velocity controller's gain in 1/s",
     kPositive, "1/s"},
    {"velocity_ki", "number", "`velocity_gain`² / 10 (`25000`)", "≥ 0, ≤ `velocity_gain`² / 4",
     "the velocity controller's integral gain in 1/s^2", kNonNegative, "1/s^2"},
    {"acceleration_limit", "number", "`0`", "≥ 0", "the largest correcting acceleration in m/s^2 (>= 0)",
     kNonNegative, "m/s^2 (0 = automatic)"},
    {"velocity_only_below", "number", "`-inf`", "any; `inf` and `-inf` allowed",
     "the height below which cells use pure velocity coupling (m)", {-kInf, kInf, false, false}},
    {"radius_bins", "integer", "`8`", "≥ 1", "the bins of the size histogram (>= 1)", closed(1.0, 1e6), "",
     "the number of size bins"},
    {"open_bottom", "boolean", "`false`", "",
     "whether the region's bottom is a boundary face where the vessel goes on below it (a fine flowing layer over "
     "a coarse bulk): coarse mass rising through it is placed as fine particles, fine particles sinking through it "
     "are handed back; refused for now (measured on a drum: the layer over it does not flow as it should)"},
};

inline constexpr KeySpec kLauncher[] = {
    {"restart_on_failure", "integer", "`0`", "0 to 100", "how many times a failed hierarchy is restarted",
     closed(0.0, 100.0), "", "how many times a failed hierarchy is restarted"},
};

inline constexpr KeySpec kSwap[] = {
    {"level", "string", "*required*", "a `[[levels]]` name", "the name of a [[levels]] entry"},
    {"at", "number", "*required*", "≥ 0", "the simulated time [s] of the swap", kNonNegative, "s of simulated time"},
    {"binary", "string", "*required*", "a file", "the path of the new solver binary"},
};

// A study file (`mlcg study`, launcher/study/study_file.cpp).
inline constexpr KeySpec kStudy[] = {
    {"title", "string", "`\"\"`", "", "the heading of study.md and the error plot"},
    {"folder", "string", "`runs/study-<case dir name>`", "", "the study folder"},
    {"reference", "string", "the first variant", "", "the name of the variant the errors refer to"},
    {"probe", "string", "each run's first probe", "", "the [[probes]] entry whose discharge is compared"},
    {"variants", "array of tables", "", "", "[[variants]] entries, the runs to compare"},
    {"sweep", "table(s)", "", "", "a [sweep] table or [[sweep]] entries"},
};

inline constexpr KeySpec kStudyVariant[] = {
    {"name", "string", "*required*", "", "the variant's name (its run folder's name)"},
    {"case", "string", "", "", "a case file to run"},
    {"run", "string", "", "", "an earlier run folder"},
    {"label", "string", "`name`", "", "the variant's label in the table and plots"},
    {"replicas", "integer", "`1`", "1..20", "runs of the variant, seeds seed, seed + 1, ...", closed(1.0, 20.0)},
};

inline constexpr KeySpec kStudySweep[] = {
    {"name", "string", "the key's last name part", "", "the sweep's name; variants are <name>-1, <name>-2, ..."},
    {"base", "string", "*required*", "", "the case file the sweep starts from"},
    {"key", "string", "*required*", "", "the dotted case key to vary, e.g. \"coupling.interval\""},
    {"values", "array", "*required*", "", "a non-empty array of the values the key takes"},
    {"label", "string", "`name`", "", "a variant's label is <label> = <value>"},
};

// A hostfile line's KEY=VALUE entries (and `coupler`), launcher/hosts/hosts.cpp.
inline constexpr KeySpec kHostEntry[] = {
    {"slots", "integer", "*required*", "≥ 1", "how many processes the host runs", at_least(1.0)},
    {"address", "string", "the name resolved", "an IPv4 address", "the address the coupler binds on that host"},
    {"coupler", "flag", "the first host", "", "the coupler runs on this host"},
    {"levels", "string", "none", "level names, comma-separated", "the levels that run on this host"},
};

}  // namespace mlcg::config::schema
