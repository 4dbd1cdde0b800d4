// mlcg_bench's pour scene without running it: the case it generates (read by the real case parser) and
// what its table takes from a run's summary.json. The fixture tests/data/bench/pour_r2/summary.json is
// dem_level's own summary of the pour case cut to 4 ms on 2 ranks (800 particles in 4 batches).
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "config/case_parser.hpp"
#include "files.hpp"
#include "pour.hpp"
#include "scenes.hpp"

namespace {

using namespace mlcg::bench;
namespace fs = std::filesystem;

const fs::path kFixture = fs::path(MLCG_TEST_DATA) / "bench" / "pour_r2";

RunMetrics parse_fixture(const fs::path& dir) { return parse_mlcg(dir, dir / "console.txt", 0, Count::Grows); }

// The bench's silo and lid in `dir`: the case parser reads the meshes a case names.
Files silo_files(const BenchParams& p, const fs::path& dir) {
  const Files files{dir / "silo.stl", dir / "lid.stl"};
  write_stl(files.silo_stl, "silo", silo_wall_triangles(p.geometry));
  write_stl(files.lid_stl, "lid", lid_triangles(p.geometry));
  return files;
}

TEST(BenchPour, CaseFillsTheEmptySiloAtTheBenchStep) {
  const BenchParams p;
  mlcg::test::TempDir dir("bench_pour_case");
  const auto spec = mlcg::config::parse_case(pour_case(p, silo_files(p, dir.path()), 2), (dir / "pour.toml").string());
  EXPECT_FALSE(spec.initial.has_value());  // from the empty silo
  ASSERT_EQ(spec.levels.size(), 1u);
  EXPECT_EQ(spec.levels[0].dt, p.dt);
  EXPECT_EQ(spec.levels[0].skin, p.skin);
  EXPECT_EQ(spec.levels[0].ranks, 2);
  ASSERT_EQ(spec.walls.size(), 2u);  // the lid stays closed
  EXPECT_EQ(spec.walls[1].name, "lid");
  ASSERT_EQ(spec.insertions.size(), 1u);
  const auto& in = spec.insertions[0];
  EXPECT_EQ(in.count, std::lround(p.pour_rate * p.pour_time));
  EXPECT_EQ(in.rate, p.pour_rate);
  EXPECT_EQ(in.interval, p.pour_interval);
  EXPECT_GE(in.follow_gap, 0.0);  // close above the heap, as the bed's preparation pours
  EXPECT_EQ(spec.time.end, p.pour_time);
  EXPECT_EQ(spec.seed, static_cast<uint64_t>(p.seed));
}

// The pour shares its insertion with the bed's preparation; the cached beds assume the preparation
// still pours in automatic batches at the rate they were made with.
TEST(BenchPour, BedPreparationKeepsItsInsertion) {
  const BenchParams p;
  mlcg::test::TempDir dir("bench_pour_prepare");
  const auto spec = mlcg::config::parse_case(prepare_case(p, silo_files(p, dir.path())),
                                             (dir / "prepare.toml").string());
  ASSERT_EQ(spec.insertions.size(), 1u);
  EXPECT_EQ(spec.insertions[0].count, p.particles);
  EXPECT_EQ(spec.insertions[0].rate, 200000.0);
  EXPECT_EQ(spec.insertions[0].interval, 0.0);
  EXPECT_EQ(spec.levels[0].dt, p.prepare_dt);
  EXPECT_EQ(spec.time.end_event, "settled");
}

TEST(BenchPour, SharesAndRateFromTheSummary) {
  const auto j = mlcg::test::read_json(kFixture / "summary.json");
  const auto& sec = j["levels"][0]["performance"]["seconds"];
  const double loop = j["wall_seconds"].get<double>() - sec["output"].get<double>();
  const RunMetrics m = parse_fixture(kFixture);
  ASSERT_TRUE(m.ok) << m.error;
  EXPECT_EQ(m.ranks, 2);
  // A filling run has fewer particle-steps than its final count x steps: on 2 ranks that must not be
  // taken for a per-rank count and replaced.
  EXPECT_DOUBLE_EQ(m.rate, j["levels"][0]["particle_steps"].get<double>() / loop);
  EXPECT_TRUE(m.warnings.empty()) << m.warnings.front();
  EXPECT_DOUBLE_EQ(m.share[1], sec["neighbor"].get<double>() / loop);
  EXPECT_DOUBLE_EQ(m.insert_share, sec["insert"].get<double>() / loop);
  EXPECT_EQ(m.inserted, 800);
  EXPECT_EQ(m.particles_end, m.inserted);
  EXPECT_TRUE(pour_problems(m, 4000).empty());
  EXPECT_EQ(pour_problems(m, 5000).size(), 1u);
}

TEST(BenchPour, ParticlesLostFromTheClosedSiloAreReported) {
  mlcg::test::TempDir dir("bench_pour_lost");
  auto j = mlcg::test::read_json(kFixture / "summary.json");
  j["levels"][0]["particles_final"] = 790;
  std::ofstream(dir / "summary.json") << j.dump(2);
  const RunMetrics m = parse_fixture(dir.path());
  ASSERT_TRUE(m.ok) << m.error;
  const auto problems = pour_problems(m, 4000);
  ASSERT_EQ(problems.size(), 1u);
  EXPECT_NE(problems[0].find("790 particles at the end, but 800 inserted"), std::string::npos) << problems[0];
}

TEST(BenchPour, TableRowAndLineAreTheMedians) {
  RunMetrics a = parse_fixture(kFixture), b = a, c = a;
  b.rate *= 2.0, b.share[1] = 0.5, b.particles_end = 1;
  c.rate *= 4.0, c.share[1] = 0.9;
  const PourRow row = summarise_pour({a, c, b});
  EXPECT_DOUBLE_EQ(row.per_core, b.rate / 2);  // per core, 2 ranks
  EXPECT_DOUBLE_EQ(row.rebuild_share, 0.5);
  EXPECT_EQ(row.particles_end, 1);             // from the median-rate run
  EXPECT_DOUBLE_EQ(row.spread, (c.rate - a.rate) / b.rate);
  PourRows rows{{2, row}};
  rows[1].error = "mpirun not found";
  EXPECT_EQ(pour_line(rows, {1, 2}),
            fmt::format("pour rank1=na rank2={:.4g} rebuild_share1=na rebuild_share2=0.500", b.rate / 2));
  EXPECT_FALSE(summarise_pour({}).error.empty());
}

}  // namespace
