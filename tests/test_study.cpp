// `mlcg study` on a copy of cases/quickstart (discharge shortened to 0.2 s so the
// whole suite takes well under a minute): one row per variant whose error and
// speedups follow from each run's summary.json, reuse of completed runs on an
// unchanged case, --rerun, a sweep, refused study files, and the plots.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <sys/wait.h>
#include <unistd.h>

#include <nlohmann/json.hpp>

namespace fs = std::filesystem;

namespace {
const std::string kBin = MLCG_BIN_DIR;
const std::string kSrc = MLCG_SOURCE_DIR;
const fs::path kDir = fs::temp_directory_path() / ("mlcg_study_" + std::to_string(::getpid()));

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

void replace(std::string& text, const std::string& from, const std::string& to) {
  const size_t at = text.find(from);
  ASSERT_NE(at, std::string::npos) << from;
  text.replace(at, from.size(), to);
}

// Runs `mlcg study ARGS`; returns the exit code, the output in `out`.
int study(const std::string& args, std::string* out = nullptr, const std::string& env = "") {
  const fs::path log = kDir / "study.out";
  const int s = std::system((env + " " + kBin + "/mlcg study " + args + " --quiet > " + log.string() + " 2>&1").c_str());
  if (out) *out = slurp(log);
  return WIFEXITED(s) ? WEXITSTATUS(s) : -1;
}

// study.csv as one map per row, keyed by the header (quoted cells allowed).
std::vector<std::map<std::string, std::string>> read_csv(const fs::path& p) {
  std::ifstream in(p);
  auto split = [](const std::string& line) {
    std::vector<std::string> cells(1);
    bool quoted = false;
    for (size_t i = 0; i < line.size(); ++i) {
      const char c = line[i];
      if (c == '"' && quoted && i + 1 < line.size() && line[i + 1] == '"') cells.back() += c, ++i;
      else if (c == '"') quoted = !quoted;
      else if (c == ',' && !quoted) cells.emplace_back();
      else cells.back() += c;
    }
    return cells;
  };
  std::string line;
  std::getline(in, line);
  const auto header = split(line);
  std::vector<std::map<std::string, std::string>> rows;
  while (std::getline(in, line)) {
    const auto cells = split(line);
    EXPECT_EQ(cells.size(), header.size()) << line;
    std::map<std::string, std::string> r;
    for (size_t i = 0; i < header.size() && i < cells.size(); ++i) r[header[i]] = cells[i];
    rows.push_back(r);
  }
  return rows;
}

nlohmann::json summary(const std::string& run) {
  std::ifstream in(fs::path(run) / "summary.json");
  return nlohmann::json::parse(in);
}

bool has_matplotlib() { return std::system("/usr/bin/python3 -c 'import matplotlib' > /dev/null 2>&1") == 0; }

// Every test gets the quickstart folder with a 0.2 s discharge (and its study.toml) in its own
// folder; ctest runs each test in its own process.
class Study : public ::testing::Test {
 protected:
  void SetUp() override {
    fs::remove_all(kDir);
    fs::create_directories(kDir / "cases");
    for (const std::string f : {"case.toml", "cg2.toml", "mlcg.toml", "study.toml"}) {
      std::string text = slurp(kSrc + "/cases/quickstart/" + f);
      if (f != "study.toml") replace(text, "window = [0.1, 0.5]", "window = [0.05, 0.2]");
      if (f == "mlcg.toml") replace(text, "end = 0.6", "end = 0.5");
      if (f == "case.toml" || f == "cg2.toml") replace(text, "plus = 0.5 }", "plus = 0.2 }");
      std::ofstream(kDir / "cases" / f) << text;
    }
  }
  void TearDown() override {
    if (!HasFailure()) fs::remove_all(kDir);
  }
  // The study of cases/ (its study.toml) into main/.
  int main_study(std::string* out, const std::string& env = "") {
    return study((kDir / "cases").string() + " --out " + (kDir / "main").string(), out, env);
  }
  // A study of the coarse-grain case alone (cheap) into `folder`.
  std::string cg2_only(const std::string& case_file, const std::string& folder) {
    const fs::path file = kDir / "cases" / (folder + ".toml");
    std::ofstream(file) << "[[variants]]\nname = \"cg2\"\ncase = \"" << case_file << "\"\n";
    return (kDir / "cases").string() + " --no-plots --study " + file.string() + " --out " + (kDir / folder).string();
  }
};

void check_rows() {
  const auto rows = read_csv(kDir / "main" / "study.csv");
  ASSERT_EQ(rows.size(), 3u);
  EXPECT_EQ(rows[0].at("name"), "reference");
  EXPECT_EQ(rows[1].at("name"), "cg2");
  EXPECT_EQ(rows[2].at("name"), "mlcg");
  const auto ref = summary(rows[0].at("run"));
  const double m_ref = ref["probes"][0]["mean_kg_per_s"], wall_ref = ref["wall_seconds"];
  ASSERT_GT(m_ref, 0.0);
  EXPECT_EQ(std::stod(rows[0].at("error_pct")), 0.0);
  for (const auto& r : rows) {
    const auto s = summary(r.at("run"));
    EXPECT_EQ(s["status"], "completed");
    const double m = s["probes"][0]["mean_kg_per_s"], wall = s["wall_seconds"];
    EXPECT_NEAR(std::stod(r.at("mdot_kg_per_s")), m, 1e-8 * m);
    EXPECT_NEAR(std::stod(r.at("error_pct")), 100.0 * (m - m_ref) / m_ref, 1e-6) << r.at("name");
    EXPECT_NEAR(std::stod(r.at("speedup_wall")), wall_ref / wall, 1e-6 * wall_ref / wall) << r.at("name");
    double steps = 0.0;
    long long particles = 0;
    for (const auto& l : s["levels"]) {
      steps += l["particle_steps"].get<double>();
      particles += l["particles_max"].get<long long>();
    }
    EXPECT_NEAR(std::stod(r.at("particle_steps")), steps, 1e-6 * steps);
    EXPECT_EQ(std::stoll(r.at("particles")), particles);
    // The CPU time the launcher measured for the run's processes (user + system).
    ASSERT_TRUE(s.contains("cpu_seconds")) << r.at("name");
    const double cpu = s["cpu_seconds"];
    EXPECT_NEAR(std::stod(r.at("cpu_s")), cpu, 1e-6 * cpu) << r.at("name");
    EXPECT_GT(cpu, 0.2 * wall) << "the run's processes used no CPU?";
  }
  // The plain coarse grain is much cheaper in particle-steps; the hierarchy's probe is its fine level's.
  EXPECT_GT(std::stod(rows[1].at("particle_step_ratio")), 2.0);
  EXPECT_EQ(summary(rows[2].at("run"))["probes_from_level"], "fine");
  EXPECT_NE(std::stod(rows[1].at("error_pct")), 0.0);
  const std::string md = slurp(kDir / "main" / "study.md");
  for (const auto& r : rows) EXPECT_NE(md.find(r.at("label")), std::string::npos) << r.at("label");
}

void check_plots() {
  if (!has_matplotlib()) {
    std::printf("no matplotlib: plots not checked\n");
    return;
  }
  // The scene has a fine region and a grid over its top layer: pressure.png too.
  for (const char* f : {"error_vs_time.png", "discharge.png", "pressure.png"}) {
    const fs::path p = kDir / "main" / f;
    ASSERT_TRUE(fs::exists(p)) << f;
    EXPECT_GT(fs::file_size(p), 10000u) << f;
    EXPECT_EQ(slurp(p).substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8)) << f;
  }
}

void check_reuse() {
  std::map<fs::path, fs::file_time_type> before;
  for (const auto& e : fs::directory_iterator(kDir / "main"))
    if (e.is_directory()) before[e.path()] = fs::last_write_time(e.path() / "summary.json");
  ASSERT_EQ(before.size(), 3u);
  fs::remove(kDir / "main" / "study.csv");
  std::string out;
  ASSERT_EQ(study((kDir / "cases").string() + " --out " + (kDir / "main").string(), &out, "MLCG_PYTHON=/nonexistent"),
            0)
      << out;
  EXPECT_EQ(out.find("running"), std::string::npos) << out;
  EXPECT_NE(out.find("warning: no plots"), std::string::npos) << out;
  size_t dirs = 0;
  for (const auto& e : fs::directory_iterator(kDir / "main"))
    if (e.is_directory()) {
      ++dirs;
      ASSERT_TRUE(before.count(e.path())) << "new run folder " << e.path();
      EXPECT_EQ(fs::last_write_time(e.path() / "summary.json"), before[e.path()]) << e.path();
    }
  EXPECT_EQ(dirs, 3u);
  const auto rows = read_csv(kDir / "main" / "study.csv");
  ASSERT_EQ(rows.size(), 3u);
  for (const auto& r : rows) EXPECT_EQ(r.at("reused"), "1");
}

// The shipped quickstart study: one row per variant whose error and speedups follow from each run's
// summary.json; plots; a second invocation reuses every run, and without python it still writes the csv.
TEST_F(Study, QuickstartRowsFollowFromTheSummariesAndASecondInvocationReusesTheRuns) {
  std::string out;
  ASSERT_EQ(main_study(&out), 0) << out;
  check_rows();
  check_plots();
  check_reuse();
}

// A cheap study of the coarse-grain case alone: reused, rerun with --rerun, and rerun when its case changes.
TEST_F(Study, RerunAndAChangedCaseRunAgain) {
  const std::string args = cg2_only("cg2.toml", "cg2_only");
  const fs::path s = kDir / "cg2_only" / "cg2" / "summary.json";
  std::string out;
  ASSERT_EQ(study(args, &out), 0) << out;
  const auto t0 = fs::last_write_time(s);
  ASSERT_EQ(study(args, &out), 0) << out;
  EXPECT_EQ(fs::last_write_time(s), t0) << "an unchanged completed run is reused";
  ASSERT_EQ(study(args + " --rerun", &out), 0) << out;
  const auto t1 = fs::last_write_time(s);
  EXPECT_GT(t1, t0) << "--rerun runs it again";
  EXPECT_NE(out.find("running 'cg2' (--rerun)"), std::string::npos) << out;
  std::string text = slurp(kDir / "cases" / "cg2.toml");
  replace(text, "seed = 42", "seed = 43");
  std::ofstream(kDir / "cases" / "cg2_changed.toml") << text;
  ASSERT_EQ(study(cg2_only("cg2_changed.toml", "cg2_only"), &out), 0) << out;
  EXPECT_GT(fs::last_write_time(s), t1) << "a run of another case is not reused";
  EXPECT_NE(out.find("the case changed"), std::string::npos) << out;
}

// The reference is an earlier run (`run = ...`, here the plain coarse grain); a sweep derives one case per value.
TEST_F(Study, ASweepOverTwoValuesGivesTwoRowsWithTheSweptValue) {
  std::string out;
  ASSERT_EQ(study(cg2_only("cg2.toml", "earlier"), &out), 0) << out;
  const fs::path ref_run = kDir / "earlier" / "cg2";
  const auto ref_time = fs::last_write_time(ref_run / "summary.json");
  const fs::path file = kDir / "cases" / "sweep.toml";
  std::ofstream(file) << "[[variants]]\nname = \"ref\"\nrun = \"" << ref_run.string()
                      << "\"\n\n[[sweep]]\nbase = \"cg2.toml\"\nkey = \"levels.coarse.dt_alpha1\"\n"
                         "values = [1.2e-5, 1e-5]\n";
  ASSERT_EQ(study((kDir / "cases").string() + " --no-plots --study " + file.string() + " --out " +
                      (kDir / "sweep").string(), &out),
            0)
      << out;
  const auto rows = read_csv(kDir / "sweep" / "study.csv");
  ASSERT_EQ(rows.size(), 3u);
  EXPECT_EQ(rows[0].at("sweep_value"), "");
  const double m_ref = summary(ref_run.string())["probes"][0]["mean_kg_per_s"];
  const char* values[] = {"1.2e-05", "1e-05"};
  for (int i = 1; i <= 2; ++i) {
    EXPECT_EQ(rows[i].at("sweep_key"), "levels.coarse.dt_alpha1");
    EXPECT_EQ(rows[i].at("sweep_value"), values[i - 1]);
    const auto s = summary(rows[i].at("run"));
    EXPECT_DOUBLE_EQ(s["levels"][0]["dt"].get<double>(), 2.0 * std::stod(values[i - 1])) << "dt = alpha x dt_alpha1";
    const double m = s["probes"][0]["mean_kg_per_s"];
    EXPECT_NEAR(std::stod(rows[i].at("error_pct")), 100.0 * (m - m_ref) / m_ref, 1e-6);
  }
  EXPECT_EQ(fs::last_write_time(ref_run / "summary.json"), ref_time) << "a given run is never rerun";
}

TEST_F(Study, RefusesBadStudyFilesNamingFileLineAndKey) {
  struct Bad {
    std::string text, expect;
  };
  const std::string sweep = "[[variants]]\nname = \"r\"\ncase = \"cg2.toml\"\n\n[[sweep]]\nbase = \"mlcg.toml\"\n";
  const Bad bad[] = {
      {sweep + "key = \"coupling.intervall\"\nvalues = [1e-4]\n", "bad.toml:7: sweep[0].key"},
      {sweep + "key = \"levels.nosuch.alpha\"\nvalues = [2.0]\n", "'nosuch' selects no entry of levels"},
      {"[[variants]]\nname = \"r\"\ncase = \"cg2.toml\"\nrefrence = \"x\"\n", "bad.toml:4: variants[0].refrence: unknown key"},
      {"[[variants]]\nname = \"r\"\ncase = \"nothere.toml\"\n", "bad.toml:3: variants[0].case: file not found"},
      // the region rules, before anything runs: a region top 0.83 orifice diameters above the orifice
      {sweep + "key = \"coupling.regions[0].max\"\nvalues = [[0.04, 0.04, 0.02]]\n",
       "coupling.regions[0].max: the region's top (its boundary surface"},
  };
  for (const auto& b : bad) {
    std::ofstream(kDir / "cases" / "bad.toml") << b.text;
    std::string out;
    EXPECT_EQ(study((kDir / "cases").string() + " --study " + (kDir / "cases" / "bad.toml").string() + " --out " +
                        (kDir / "bad").string(), &out),
              2);
    EXPECT_NE(out.find(b.expect), std::string::npos) << out;
    EXPECT_FALSE(fs::exists(kDir / "bad")) << "a refused study runs nothing";
  }
  // The case parser's own message names the misspelt key and the right one.
  std::ofstream(kDir / "cases" / "bad.toml") << bad[0].text;
  std::string out;
  study((kDir / "cases").string() + " --study " + (kDir / "cases" / "bad.toml").string(), &out);
  EXPECT_NE(out.find("intervall"), std::string::npos) << out;
  EXPECT_NE(out.find("interval'"), std::string::npos) << out;
}

}  // namespace
