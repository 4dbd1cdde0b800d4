#pragma once
// Checks on the run folder of a finished hierarchy, shared by the launcher
// tests that run one locally (test_launcher) and across hosts (netns).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "files.hpp"
#include "io/h5.hpp"

namespace run_checks {
namespace fs = std::filesystem;
using mlcg::test::read_json;

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

inline double num(const std::vector<std::string>& row, size_t col) { return std::stod(row.at(col)); }

// Time the first event of a level's run fired (the lid opening), or +inf.
inline double first_event(const nlohmann::json& summary) {
  double t = INFINITY;
  for (const auto& e : summary.value("events", nlohmann::json::array()))
    if (e.value("fired", false)) t = std::min(t, e.value("time", static_cast<double>(INFINITY)));
  return t;
}

// A level's mass balance as the README defines it (requested = inserted + pending + failed, inserted = present +
// removed), its present particles counted from the level's final checkpoint instead of taken from the balance:
// every particle inserted is in the checkpoint or was removed through one of the exits, by count and by mass, and
// the ids present are distinct and were issued (ids are issued in insertion order, from 0).
inline void check_balance(const fs::path& level_dir, const nlohmann::json& b) {
  const auto& by = b["removed_by"];
  int64_t removed = 0;
  double removed_mass = 0.0;
  for (const char* exit : {"outlet", "boundary_surface", "wall"}) {
    removed += by[exit]["count"].get<int64_t>();
    removed_mass += by[exit]["mass_kg"].get<double>();
  }
  const int64_t inserted = b["inserted"].get<int64_t>();
  EXPECT_EQ(b["requested"].get<int64_t>(),
            inserted + b["pending"].get<int64_t>() + b["failed_to_place"].get<int64_t>());

  const mlcg::io::H5Reader cp(level_dir / "checkpoint.h5");
  const auto ids = cp.read<int64_t>("particles/id");
  const auto mass = cp.read<double>("particles/mass");
  double m = 0.0;
  for (const double x : mass) m += x;
  EXPECT_EQ(inserted, static_cast<int64_t>(ids.size()) + removed)
      << "inserted is not the final checkpoint's particles plus those removed through an exit";
  const double in_mass = b["inserted_mass_kg"].get<double>();
  EXPECT_NEAR(in_mass, m + removed_mass, 1e-9 * in_mass)
      << "the inserted mass is not the final checkpoint's plus the mass removed through an exit";
  std::set<int64_t> distinct(ids.begin(), ids.end());
  EXPECT_EQ(distinct.size(), ids.size()) << "a particle id is present twice";
  if (!ids.empty()) {
    EXPECT_GE(*distinct.begin(), 0) << "a present particle has an id never issued";
    EXPECT_LT(*distinct.rbegin(), inserted) << "a present particle has an id never issued";
  }
}

// A particle the fine level received from the coupler, as its inserted.csv records it.
struct Received {
  uint64_t interval;
  int grid, face;
  double x, y, z, r, mass;
};

inline std::vector<Received> read_received(const fs::path& level_dir) {
  std::vector<Received> out;
  for (const auto& c : read_csv(level_dir / "inserted.csv"))
    out.push_back({std::stoull(c.at(0)), std::stoi(c.at(1)), std::stoi(c.at(2)), num(c, 4), num(c, 5), num(c, 6),
                   num(c, 7), num(c, 8)});
  return out;
}

// Per face of region r: the coupler booked as inserted exactly the mass the fine level received there (its
// inserted.csv), and left less than one fine particle's mass of what crossed (and was handed back) unplaced,
// unless the face's slab lacked room at some interval. (An open side's net crossing may fall below what was
// already placed, when coarse mass crosses back out: no lower bound.)
inline void check_faces(const fs::path& dir, int r, const std::string& fine_name,
                        const std::vector<std::vector<std::string>>& faces) {
  std::vector<double> got(faces.size(), 0.0);
  double m_max = 0.0, total = 0.0;  // the largest particle's mass, all of them
  for (const Received& p : read_received(dir / "levels" / fine_name)) {
    if (p.grid != r) continue;
    ASSERT_TRUE(p.face >= 0 && static_cast<size_t>(p.face) < faces.size()) << "particle of no face: " << p.face;
    got[static_cast<size_t>(p.face)] += p.mass;
    m_max = std::max(m_max, p.mass);
    total += p.mass;
  }
  EXPECT_GT(total, 0.0) << "level '" << fine_name << "' received nothing in region " << r;
  for (size_t f = 0; f < faces.size(); ++f) {
    const double booked = num(faces[f], 4), owed = num(faces[f], 3) + num(faces[f], 8);
    EXPECT_NEAR(got[f], booked, 1e-12 * total) << "region " << r << " face " << f << ": the coupler booked " << booked
                                               << " kg inserted, level '" << fine_name << "' received " << got[f];
    if (num(faces[f], 7) == 0.0) {
      EXPECT_LT(owed - got[f], m_max * (1.0 + 1e-9))
          << "region " << r << " face " << f << ": " << owed - got[f] << " kg crossed but never placed";
    }
  }
}

// Checks region r of a finished hierarchy run whose fine level is `fine`, each quantity against an
// independent measurement of it (issue 11, item 8):
// - per interval while nothing can leave downward (before the first event), the coarse level's mass in
//   the region's cells, summed over its particles, equals the mass the coupler booked as crossing the
//   boundary faces (counted at the faces); the fine level's equals what it was sent less what it handed
//   back;
// - the fine level inserted exactly what the coupler placed (its own count and mass against the
//   coupler's ledger) and its particles are all accounted for (check_balance);
// - per face, the coupler's ledger against what the fine level received at that face (check_faces);
// - what the fine level removed through the boundary surface equals what the coupler was handed back;
// - no inserted particle overlaps another by more than 1 % of a diameter, none overlaps a wall, none
//   lies outside the walls.
// Returns the inserted mass.
inline double check_region(const fs::path& dir, const nlohmann::json& s, int r, const std::string& fine_name) {
  const auto faces = read_csv(dir / "coupling" / ("faces_region" + std::to_string(r) + ".csv"));
  EXPECT_FALSE(faces.empty());
  double crossed = 0.0, inserted = 0.0, returned = 0.0;
  for (const auto& f : faces) {
    crossed += num(f, 3);
    inserted += num(f, 4);
    returned += num(f, 8);
  }
  check_faces(dir, r, fine_name, faces);
  const auto fine = read_json(dir / "levels" / fine_name / "summary.json");
  const auto& b = fine["mass_balance"];
  const auto& by = b["removed_by"];
  check_balance(dir / "levels" / fine_name, b);
  EXPECT_EQ(by["wall"]["count"].get<int64_t>(), 0) << "fine particles left the domain through or over a wall";
  EXPECT_NEAR(b["inserted_mass_kg"].get<double>(), inserted, 1e-12 * inserted);
  EXPECT_EQ(b["inserted"].get<int64_t>(), s["coupling"]["regions"][r]["inserted_particles"].get<int64_t>());
  // A middle level of three also hands mass back through the region it feeds: compare only a finest level.
  if (fine_name == s.value("probes_from_level", fine_name)) {
    EXPECT_NEAR(by["boundary_surface"]["mass_kg"].get<double>(), returned, 1e-12 * std::max(returned, 1e-30));
  }

  const double t_open = first_event(fine);
  const auto log = read_csv(dir / "coupling" / ("region" + std::to_string(r) + ".csv"));
  size_t compared = 0;
  double sent = 0.0;  // inserted by the end of interval k: the lists planned up to the row before
  for (const auto& row : log) {
    if (num(row, 1) >= t_open) break;
    const double booked = num(row, 2), coarse_in = num(row, 14), fine_in = num(row, 15);
    EXPECT_NEAR(coarse_in, booked, 1e-9 * std::max(booked, 1e-30)) << "region " << r << " interval " << row[0];
    // A fine particle that left is removed (and handed back) at the level's next neighbour-list
    // rebuild: until then it counts as leaving.
    EXPECT_NEAR(fine_in + num(row, 16), sent - num(row, 12), 1e-9 * sent) << "interval " << row[0];
    sent = num(row, 3);
    ++compared;
  }
  EXPECT_GT(compared, 10u);
  const auto& cp = fine["levels"][0]["coupling"];
  const double overlap = cp["largest_insert_overlap_of_diameter"].get<double>();
  EXPECT_LE(overlap, 0.01);
  EXPECT_LE(cp["largest_insert_wall_overlap_of_diameter"].get<double>(), 1e-9);
  EXPECT_EQ(cp["inserted_outside_walls"].get<uint64_t>(), 0u);
  std::printf("region %d: %.6g kg crossed, %.6g kg inserted as %lld particles of level '%s', %.6g kg handed back "
              "(largest overlap %.3g of a diameter); %zu intervals before t = %.3g s balanced\n", r, crossed, inserted,
              static_cast<long long>(b["inserted"].get<int64_t>()), fine_name.c_str(), returned, overlap, compared,
              t_open);
  return inserted;
}

}  // namespace run_checks
