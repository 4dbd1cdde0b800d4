// A whole two-level run through `mlcg run` (coupler + two dem_level
// processes) on the small quickstart hopper: the mass handed from the coarse
// to the fine level is exact per face, the fine level's balance is exact,
// nothing overlaps on insertion beyond the guard, and the fine level carries
// the discharge.
#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>

namespace fs = std::filesystem;

namespace {
int run(const std::string& cmd) {
  const int s = std::system(cmd.c_str());
  return WIFEXITED(s) ? WEXITSTATUS(s) : -1;
}
const std::string kBin = MLCG_BIN_DIR;
const std::string kSrc = MLCG_SOURCE_DIR;

nlohmann::json read_json(const fs::path& p) {
  std::ifstream in(p);
  return nlohmann::json::parse(in);
}

std::vector<std::vector<std::string>> read_csv(const fs::path& p) {
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
}  // namespace

TEST(MlcgRun, TwoLevelHopperHandsMassOverExactlyAndDischargesThroughTheFineLevel) {
  const fs::path dir = fs::temp_directory_path() / ("mlcg_2lvl_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  ASSERT_EQ(run(kBin + "/mlcg run " + kSrc + "/cases/quickstart/mlcg.toml --out " + dir.string() + " --quiet > " +
                dir.string() + ".out 2>&1"),
            0)
      << "see " << dir.string() << ".out";
  const auto s = read_json(dir / "summary.json");
  EXPECT_EQ(s["status"], "completed");
  ASSERT_EQ(s["levels"].size(), 2u);
  EXPECT_EQ(s["probes_from_level"], "fine");

  // Per face: coarse mass crossed = fine mass inserted + remainder, to 1e-12.
  const auto faces = read_csv(dir / "coupling" / "faces_region0.csv");
  ASSERT_FALSE(faces.empty());
  double crossed = 0.0, inserted = 0.0;
  for (const auto& f : faces) {
    const double c = std::stod(f[3]), i = std::stod(f[4]), r = std::stod(f[5]);
    EXPECT_LE(std::fabs(c - i - r), 1e-12 * std::max(std::fabs(c), 1e-30)) << "face " << f[0];
    crossed += c;
    inserted += i;
  }
  EXPECT_GT(inserted, 0.5 * crossed) << "most of the crossed mass must be placed";

  // The fine level inserted exactly what the coupler placed; its balance is exact.
  const auto fine = read_json(dir / "levels" / "fine" / "summary.json");
  const auto& b = fine["mass_balance"];
  EXPECT_EQ(b["inserted"].get<int64_t>(), b["present"].get<int64_t>() + b["removed"].get<int64_t>() +
                                              b["failed_to_place"].get<int64_t>());
  EXPECT_NEAR(b["inserted_mass_kg"].get<double>(), inserted, 1e-12 * inserted);
  EXPECT_EQ(b["inserted"].get<int64_t>(), s["coupling"]["regions"][0]["inserted_particles"].get<int64_t>());
  EXPECT_GT(b["inserted"].get<int64_t>(), 500);
  // Insertion quality: no inserted particle overlaps another by more than 1 % of its diameter.
  const double overlap = fine["levels"][0]["coupling"]["largest_insert_overlap_of_diameter"].get<double>();
  EXPECT_LE(overlap, 0.01);

  // The fine level discharges: its probe saw mass, and the coarse level kept its particles' mass.
  EXPECT_GT(s["probes"][0]["total_mass_kg"].get<double>(), 0.1 * inserted);
  const auto coarse = read_json(dir / "levels" / "coarse" / "summary.json");
  EXPECT_EQ(coarse["mass_balance"]["inserted"].get<int64_t>(), 313);
  EXPECT_GE(s["coupling"]["overhead_share"].get<double>(), 0.0);
  std::printf("two-level hopper: %.6g kg crossed, %.6g kg inserted as %lld fine particles (largest overlap %.3g of "
              "a diameter), coupling overhead %.1f %%\n",
              crossed, inserted, static_cast<long long>(b["inserted"].get<int64_t>()), overlap,
              100.0 * s["coupling"]["overhead_share"].get<double>());
  fs::remove_all(dir);
  fs::remove(dir.string() + ".out");
}
