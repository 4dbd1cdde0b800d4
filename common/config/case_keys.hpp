#pragma once
// The keys each table of a case file allows, declared once. The reader refuses any other key with
// "unknown key (did you mean ...); allowed keys: ..." from these lists, and tests/test_case_keys.cpp
// fails when cases/README.md documents a key not listed here or leaves out one that is.
// Types, defaults and bounds are still written where each key is read (case_parser*.cpp).
#include <string>
#include <string_view>
#include <vector>

namespace mlcg::config {

// The message for a key not in `allowed`, the same in every file MLCG reads (case, study file, hostfile):
// "unknown key (did you mean 'dt'?); allowed keys[ for KIND]: name, alpha, dt, ...".
std::string unknown_key(std::string_view key, const std::vector<std::string>& allowed, std::string_view kind = {});

}  // namespace mlcg::config

namespace mlcg::config::keys {

using List = std::vector<std::string>;

// The top level: `base` (a variant's base, read before anything else) and the tables.
inline const List kTop{"base",      "title",    "seed",   "gravity", "materials", "interactions", "contact",
                       "levels",    "domain",   "walls",  "insertion", "particles", "initial",    "events",
                       "probes",    "grids",    "output", "stability", "time",      "orifice",    "coupling",
                       "launcher",  "swap",     "limits"};

inline const List kMaterial{"name", "youngs_modulus", "poisson_ratio", "density"};
inline const List kInteraction{"between", "restitution", "friction", "rolling_friction"};
inline const List kContact{"normal", "tangential", "rolling", "clamp_normal"};
inline const List kLevel{"name", "alpha", "dt", "dt_alpha1", "dt_rayleigh", "ranks", "skin", "processors", "balance"};
inline const List kDomain{"min", "max"};

// [[walls]]: every wall, then the keys of each type.
inline const List kWall{"name", "type", "material"};
inline const List kPlane{"point", "normal"};
inline const List kCylinder{"center", "axis", "radius", "bottom", "top", "rims"};
inline const List kCone{"center", "axis", "radius_bottom", "radius_top", "bottom", "top", "rims"};
inline const List kDisk{"center", "axis", "radius", "inner_radius"};
inline const List kMesh{"file", "scale", "offset"};

// [[insertion]], its region (one list per shape) and a radius distribution.
inline const List kInsertion{"name",  "material",    "region", "radius",   "count",      "count_alpha1",
                             "mass",  "rate",        "rate_alpha1", "mass_rate", "start", "interval",
                             "velocity", "follow_gap", "follow_height", "max_attempts"};
inline const List kBoxRegion{"type", "min", "max"};
inline const List kCylinderRegion{"type", "center", "radius", "zmin", "zmax"};
inline const List kRadiusDistribution{"uniform", "values", "fractions"};

inline const List kParticle{"material", "radius", "position", "velocity", "omega"};
inline const List kInitial{"file", "material"};
inline const List kOrifice{"center", "diameter", "width", "length"};
inline const List kEvent{"name", "at", "after_insertion", "mean_speed_below", "check_interval", "latest", "remove_walls"};
inline const List kProbe{"name", "point", "normal", "radius", "sample_rate", "window", "window_relative_to"};
inline const List kGrid{"name", "min", "max", "cell_size", "sample_interval", "output_interval"};
inline const List kOutput{"snapshot_interval", "checkpoint_interval", "stats_interval", "energy_interval"};
inline const List kStability{"rayleigh_fraction", "min_steps_per_contact", "max_overlap_fraction", "max_impact_speed",
                             "dt_override_reason"};
inline const List kLimits{"max_steps", "max_output_files", "max_memory_gb"};
inline const List kTime{"end", "progress_interval"};
inline const List kEndAfterEvent{"event", "plus"};  // end = { event = "open", plus = 0.6 }

// Multi-level cases.
inline const List kCoupling{"interval", "endpoint", "heartbeat", "timeout", "checkpoint_every", "regions"};
inline const List kCouplingRegion{"coarse",        "fine",    "min",           "max",           "cell_size",
                                  "inside",        "insert_depth", "fade",     "kp",            "ki",
                                  "traction_limit", "correct", "velocity_gain", "velocity_ki",  "acceleration_limit",
                                  "velocity_only_below", "radius_bins"};
inline const List kLauncher{"restart_on_failure"};
inline const List kSwap{"level", "at", "binary"};

// A study file (`mlcg study`, launcher/study_file.cpp).
inline const List kStudy{"title", "folder", "reference", "probe", "variants", "sweep"};
inline const List kStudyVariant{"name", "case", "run", "label", "replicas"};
inline const List kStudySweep{"name", "base", "key", "values", "label"};

// A hostfile line's KEY=VALUE entries (and `coupler`), launcher/hosts.cpp.
inline const List kHostEntry{"slots", "address", "coupler", "levels"};

}  // namespace mlcg::config::keys
