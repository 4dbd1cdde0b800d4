#pragma once
// Checks on the run folder of a finished hierarchy, shared by the launcher
// tests that run one locally (test_launcher) and across hosts (netns).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace run_checks {
namespace fs = std::filesystem;

inline nlohmann::json read_json(const fs::path& p) {
  std::ifstream in(p);
  return nlohmann::json::parse(in);
}

inline std::vector<std::vector<std::string>> read_csv(const fs::path& p) {
  std::ifstream in(p);
  std::vector<std::vector<std::string>> rows;
  std::string line;
  std::getline(in, line);  // header
  while (std::getline(in, line)) {
    std::vector<std::string> cells;
    std::stringstream ss(line);
    std::string c;
    while (std::getline(ss, c, ',')) cells.push_back(c);
    rows.push_back(cells);
  }
  return rows;
}

// Checks region r of a finished hierarchy run whose fine level is `fine`: per face, coarse mass crossed =
// fine mass inserted + remainder to 1e-12; the fine level inserted exactly what the coupler placed, with
// no overlap above 1 % of a diameter, and its balance is exact. Returns the inserted mass.
inline double check_region(const fs::path& dir, const nlohmann::json& s, int r, const std::string& fine_name) {
  const auto faces = read_csv(dir / "coupling" / ("faces_region" + std::to_string(r) + ".csv"));
  EXPECT_FALSE(faces.empty());
  double crossed = 0.0, inserted = 0.0;
  for (const auto& f : faces) {
    const double c = std::stod(f[3]), i = std::stod(f[4]), rem = std::stod(f[5]);
    EXPECT_LE(std::fabs(c - i - rem), 1e-12 * std::max(std::fabs(c), 1e-30)) << "region " << r << " face " << f[0];
    crossed += c;
    inserted += i;
  }
  EXPECT_GT(inserted, 0.5 * crossed) << "most of the crossed mass must be placed (region " << r << ")";
  const auto fine = read_json(dir / "levels" / fine_name / "summary.json");
  const auto& b = fine["mass_balance"];
  EXPECT_EQ(b["inserted"].get<int64_t>(), b["present"].get<int64_t>() + b["removed"].get<int64_t>() +
                                              b["failed_to_place"].get<int64_t>());
  EXPECT_NEAR(b["inserted_mass_kg"].get<double>(), inserted, 1e-12 * inserted);
  EXPECT_EQ(b["inserted"].get<int64_t>(), s["coupling"]["regions"][r]["inserted_particles"].get<int64_t>());
  const double overlap = fine["levels"][0]["coupling"]["largest_insert_overlap_of_diameter"].get<double>();
  EXPECT_LE(overlap, 0.01);
  std::printf("region %d: %.6g kg crossed, %.6g kg inserted as %lld particles of level '%s' (largest overlap %.3g "
              "of a diameter)\n", r, crossed, inserted, static_cast<long long>(b["inserted"].get<int64_t>()),
              fine_name.c_str(), overlap);
  return inserted;
}

}  // namespace run_checks
