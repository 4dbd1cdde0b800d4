#pragma once
// The keys each table of a case file allows, as name lists derived from their declarations
// (case_schema*.hpp: name, type, default, bounds, unit and doc of each key, declared once). The reader
// refuses any other key with "unknown key (did you mean ...); allowed keys: ..." from these lists, the
// study file and the hostfile too, and tests/test_case_keys.cpp fails when cases/README.md documents a
// key otherwise than declared.
#include <string>
#include <string_view>
#include <vector>

#include "config/case_schema_coupling.hpp"
#include "config/case_schema_scene.hpp"
#include "config/case_schema_tables.hpp"

namespace mlcg::config {

// The message for a key not in `allowed`, the same in every file MLCG reads (case, study file, hostfile):
// "unknown key (did you mean 'dt'?); allowed keys[ for KIND]: name, alpha, dt, ...".
std::string unknown_key(std::string_view key, const std::vector<std::string>& allowed, std::string_view kind = {});

}  // namespace mlcg::config

namespace mlcg::config::keys {

using List = std::vector<std::string>;

inline const List kTop = schema::names(schema::kTop);
inline const List kMaterial = schema::names(schema::kMaterial);
inline const List kInteraction = schema::names(schema::kInteraction);
inline const List kContact = schema::names(schema::kContact);
inline const List kLevel = schema::names(schema::kLevel);
inline const List kDomain = schema::names(schema::kDomain);
inline const List kWall = schema::names(schema::kWall);
inline const List kPlane = schema::names(schema::kPlane);
inline const List kCylinder = schema::names(schema::kCylinder);
inline const List kCone = schema::names(schema::kCone);
inline const List kDisk = schema::names(schema::kDisk);
inline const List kMesh = schema::names(schema::kMesh);
inline const List kInsertion = schema::names(schema::kInsertion);
inline const List kBoxRegion = schema::names(schema::kBoxRegion);
inline const List kCylinderRegion = schema::names(schema::kCylinderRegion);
inline const List kRadiusDistribution = schema::names(schema::kRadiusDistribution);
inline const List kParticle = schema::names(schema::kParticle);
inline const List kInitial = schema::names(schema::kInitial);
inline const List kOrifice = schema::names(schema::kOrifice);
inline const List kEvent = schema::names(schema::kEvent);
inline const List kProbe = schema::names(schema::kProbe);
inline const List kGrid = schema::names(schema::kGrid);
inline const List kOutput = schema::names(schema::kOutput);
inline const List kStability = schema::names(schema::kStability);
inline const List kLimits = schema::names(schema::kLimits);
inline const List kTime = schema::names(schema::kTime);
inline const List kEndAfterEvent = schema::names(schema::kEndAfterEvent);
inline const List kCoupling = schema::names(schema::kCoupling);
inline const List kCouplingRegion = schema::names(schema::kCouplingRegion);
inline const List kLauncher = schema::names(schema::kLauncher);
inline const List kSwap = schema::names(schema::kSwap);
inline const List kStudy = schema::names(schema::kStudy);
inline const List kStudyVariant = schema::names(schema::kStudyVariant);
inline const List kStudySweep = schema::names(schema::kStudySweep);
inline const List kHostEntry = schema::names(schema::kHostEntry);

}  // namespace mlcg::config::keys
