// Input the TOML reader or the run cannot take is refused before step 1, at
// its file, line and key, with the value that fits: absurdly nested keys and
// long lines (toml++ would overflow its stack), and sizes and times that would
// exhaust memory, the disk or the time steps ([limits], which the case may raise).
#include <gtest/gtest.h>

#include <string>

#include "case_parser_support.hpp"

namespace {

using namespace case_parser_test;

std::string parts(const std::string& word, int n) {
  std::string s = word;
  for (int i = 1; i < n; ++i) s += "." + word;
  return s;
}

// The message of parsing `text`, "" when accepted.
std::string refusal(const std::string& text) {
  try {
    parse_case(text, kFixture);
  } catch (const CaseError& e) {
    return e.what();
  }
  return "";
}

std::string with(const std::string& from, const std::string& to) {
  std::string text = base();
  const size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  return text.replace(at, from.size(), to);
}

// ---- text the TOML reader must not see ---------------------------------------

TEST(CaseText, DottedKeyOfAHundredThousandPartsIsRefusedAtItsLine) {
  const std::string text = base() + "\n" + parts("a", 100000) + " = 1\n";
  const std::string msg = refusal(text);
  const std::string where = kFixture + ":" + std::to_string(line_at(text, text.size() - 2)) + ": ";
  EXPECT_EQ(msg.substr(0, where.size()), where) << msg.substr(0, 300);
  EXPECT_NE(msg.find("more than 64 parts"), std::string::npos) << msg.substr(0, 300);
}

TEST(CaseText, TableHeaderOfAHundredThousandPartsIsRefusedAtItsLine) {
  const std::string text = base() + "\n[" + parts("b", 100000) + "]\nx = 1\n";
  const std::string msg = refusal(text);
  EXPECT_EQ(msg.rfind(kFixture + ":" + std::to_string(line_at(text, text.rfind('['))) + ": ", 0), 0u)
      << msg.substr(0, 300);
  EXPECT_NE(msg.find("table header"), std::string::npos) << msg.substr(0, 300);
}

TEST(CaseText, QuotedPartsCountAndStringsDoNot) {
  // "a"."b"... is as deep as a.b...; dots inside a string or a comment are no parts.
  const std::string quoted = base() + "\n" + parts("\"q\"", 65) + " = 1\n";
  EXPECT_NE(refusal(quoted).find("more than 64 parts"), std::string::npos);
  const std::string dots(2000, '.');
  EXPECT_EQ(refusal(with("title = \"small silo\"", "title = \"" + parts("s", 500) + "\" # " + dots)), "");
}

TEST(CaseText, LineLongerThan65536CharactersIsRefusedAtItsLine) {
  const std::string text = with("title = \"small silo\"", "title = \"" + std::string(70000, 'x') + "\"");
  const std::string msg = refusal(text);
  EXPECT_EQ(msg.rfind(kFixture + ":2: ", 0), 0u) << msg.substr(0, 300);
  EXPECT_NE(msg.find("more than 65536 characters"), std::string::npos) << msg.substr(0, 300);
}

// ---- sizes, times and [limits] -------------------------------------------------

TEST(CaseLimits, GridCellSizeOf1e7IsRefusedWithTheMemoryItNeeds) {
  expect_error("cell_size = 0.02", "cell_size = 1e-7", "grids[0].cell_size", "above [limits] max_memory_gb = 16");
  const std::string msg = refusal(with("cell_size = 0.02", "cell_size = 1e-7"));
  EXPECT_NE(msg.find("give cell_size >= "), std::string::npos) << msg;
  EXPECT_NE(msg.find("GB of memory"), std::string::npos) << msg;
}

TEST(CaseLimits, TheMemoryLimitCanBeRaised) {
  // 200 x 200 x 1100 cells: about 18 GB of accumulators.
  const std::string fine = with("cell_size = 0.02", "cell_size = 5e-4");
  EXPECT_NE(refusal(fine).find("max_memory_gb = 16"), std::string::npos);
  EXPECT_EQ(refusal(fine + "\n[limits]\nmax_memory_gb = 32\n"), "");
}

TEST(CaseLimits, TinyTimeStepIsRefusedWithTheStepsItTakes) {
  expect_error("dt = 1e-6", "dt = 1e-300", "levels[0].dt", "above [limits] max_steps = 1000000000");
  const std::string msg = refusal(with("dt = 1e-6", "dt = 1e-300"));
  EXPECT_NE(msg.find("give dt >= 2.6e-09 s"), std::string::npos) << msg;  // end = event at 2 s + 0.6 s
  EXPECT_EQ(refusal(with("dt = 1e-6", "dt = 1e-9") + "\n[limits]\nmax_steps = 10000000000\n"), "");
}

TEST(CaseLimits, SnapshotEveryStepIsRefusedWithTheFilesItWrites) {
  expect_error("snapshot_interval = 0.05", "snapshot_interval = 1e-300", "output.snapshot_interval",
               "above [limits] max_output_files = 20000");
  const std::string many = with("snapshot_interval = 0.05", "snapshot_interval = 1e-4");  // 26,000 snapshots
  EXPECT_NE(refusal(many).find("give snapshot_interval >= 0.000132"), std::string::npos) << refusal(many);
  EXPECT_EQ(refusal(many + "\n[limits]\nmax_output_files = 30000\n"), "");
}

TEST(CaseLimits, ProbeSamplesAndSeriesRowsCountAsMemory) {
  // A row of series.csv every step: 2.6 million rows kept in memory and in every checkpoint.
  expect_error_in(base() + "\n[limits]\nmax_memory_gb = 0.5\n", Edit{"checkpoint_interval = 0.5",
                  "checkpoint_interval = 0.5\nstats_interval = 1e-300", "stats_interval"}, "output.stats_interval",
                  "keeps a row of series.csv at most every step: about 0.666 GB of memory");
  expect_error_in(base() + "\n[limits]\nmax_memory_gb = 0.01\n", Edit{"radius = 0.012\nwindow",
                  "radius = 0.012\nsample_rate = 1e300\nwindow", "sample_rate"}, "probes[0].sample_rate",
                  "keeps a sample of probe 'orifice' at most every step");
}

TEST(CaseLimits, AbsurdYoungsModulusIsRefusedByTheParser) {
  expect_error("youngs_modulus = 5e6", "youngs_modulus = 1e308", "materials[0].youngs_modulus",
               "1e+308 is outside (0, 1e+14] Pa");
  // Stiff enough that the time-step guard needs more steps than the case allows.
  expect_error_in(base() + "\n[limits]\nmax_steps = 100000000\n", "youngs_modulus = 5e6", "youngs_modulus = 1e14",
                  "materials[0].youngs_modulus", "above [limits] max_steps = 100000000; give youngs_modulus <= ");
}

TEST(CaseLimits, TenMillionParticlesInOneBatchAreRefusedWithWhatFits) {
  const std::string one_batch = with("mass = 0.5\nmass_rate = 2.0", "count = 10000000");
  const std::string msg = refusal(one_batch);
  const std::string where = kFixture + ":" + std::to_string(line_at(one_batch, one_batch.find("count = "))) +
                            ": insertion[0].count: ";
  EXPECT_EQ(msg.rfind(where, 0), 0u) << msg;
  EXPECT_NE(msg.find("give a rate or mass_rate"), std::string::npos) << msg;
  EXPECT_NE(msg.find("count <= "), std::string::npos) << msg;
  EXPECT_EQ(refusal(with("mass = 0.5\nmass_rate = 2.0", "count = 1000")), "");
}

TEST(CaseLimits, ParticlesBeyondTheMemoryLimitAreRefusedAtTheirCount) {
  EXPECT_EQ(refusal(with("mass = 0.5\nmass_rate = 2.0", "count = 1000000\nrate = 1e5")), "");
  const std::string msg = refusal(with("mass = 0.5\nmass_rate = 2.0", "count = 20000000\nrate = 1e5"));
  EXPECT_NE(msg.find("insertion[0].count: 2e+07 particles of insertion 'pour'"), std::string::npos) << msg;
  EXPECT_NE(msg.find("give count <= 1"), std::string::npos) << msg;
}

TEST(CaseLimits, ProgressEveryStepIsRefused) {
  expect_error("end = { event", "progress_interval = 1e-300\nend = { event", "time.progress_interval",
               "give progress_interval >= 0.1");
}

TEST(CaseLimits, LimitsTableIsChecked) {
  expect_error_in(base() + "\n[limits]\nmax_stepz = 5\n", "max_stepz = 5", "max_stepz = 5", "limits.max_stepz",
                  "did you mean 'max_steps'?");
  expect_error_in(base() + "\n[limits]\nmax_steps = 0\n", "max_steps = 0", "max_steps = 0", "limits.max_steps",
                  "0 is below 1");
}

}  // namespace
