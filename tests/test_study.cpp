// `mlcg study` on a copy of cases/quickstart (discharge shortened to 0.2 s so the
// whole suite takes well under a minute): one row per variant whose error, its
// 95 % interval and speedups follow from each run's summary.json, reuse of
// completed runs on an unchanged case, --rerun, a sweep, an older run without
// intervals, replicas, refused study files, and the plots.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <utility>

#include <nlohmann/json.hpp>

#include "files.hpp"
#include "shell.hpp"
#include "stats/series_stats.hpp"

namespace fs = std::filesystem;
using mlcg::test::read_json;
using mlcg::test::slurp;

namespace {
const std::string kBin = MLCG_BIN_DIR;
const std::string kSrc = MLCG_SOURCE_DIR;
const fs::path kDir = mlcg::test::temp_path("study");

void replace(std::string& text, const std::string& from, const std::string& to) {
  const size_t at = text.find(from);
  ASSERT_NE(at, std::string::npos) << from;
  text.replace(at, from.size(), to);
}

// Runs `mlcg study ARGS`; returns the exit code, the output in `out`.
int study(const std::string& args, std::string* out = nullptr, const std::string& env = "") {
  const fs::path log = kDir / "study.out";
  const int rc = mlcg::test::run(env + " " + kBin + "/mlcg study " + args + " --quiet > " + log.string() + " 2>&1");
  if (out) *out = slurp(log);
  return rc;
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

nlohmann::json summary(const std::string& run) { return read_json(fs::path(run) / "summary.json"); }

// The half-width of a run's ⟨ṁ⟩ interval recomputed from its probe csv: the window's samples, the last
// B x b of them cut into the batches summary.json names, t_{0.975, B-1} s_B / sqrt(B).
double ci_from_probe_csv(const fs::path& run, const nlohmann::json& probe) {
  unsigned batches = 0, size = 0;
  EXPECT_EQ(std::sscanf(probe["ci_method"].get<std::string>().c_str(), "batch means, %u batches of %u samples",
                        &batches, &size), 2) << probe["ci_method"];
  const double t0 = probe["window"][0], t1 = probe["window"][1], dt = 0.01;  // 100 Hz: the default sample_rate
  std::vector<double> x;
  std::ifstream in(run / probe["file"].get<std::string>());
  std::string line;
  std::getline(in, line);
  while (std::getline(in, line)) {
    const double t = std::stod(line.substr(0, line.find(','))), v = std::stod(line.substr(line.find(',') + 1));
    if (t - dt > t0 - 1e-6 && t < t1 + 1e-6) x.push_back(v);
  }
  EXPECT_EQ(x.size(), probe["samples_in_window"].get<size_t>());
  if (batches < 2 || batches * size > x.size()) return -1.0;
  std::vector<double> m(batches, 0.0);
  const size_t skip = x.size() - batches * size;
  for (size_t i = 0; i < batches * size; ++i) m[i / size] += x[skip + i] / size;
  double mean = 0.0, ss = 0.0;
  for (double v : m) mean += v / batches;
  for (double v : m) ss += (v - mean) * (v - mean);
  return mlcg::stats::student_t_quantile(0.975, batches - 1) * std::sqrt(ss / (batches - 1) / batches);
}

bool has_matplotlib() { return std::system("/usr/bin/python3 -c 'import matplotlib' > /dev/null 2>&1") == 0; }

// Every test gets the quickstart folder with a 0.2 s discharge (and its study.toml) in its own
// folder; ctest runs each test in its own process.
class Study : public ::testing::Test {
 protected:
  const mlcg::test::TempDir tmp{"study"};  // kDir, kept when the test fails
  void SetUp() override {
    fs::create_directories(kDir / "cases");
    for (const std::string f : {"case.toml", "cg2.toml", "mlcg.toml", "study.toml"}) {
      std::string text = slurp(kSrc + "/cases/quickstart/" + f);
      // case.toml is the scene; cg2.toml and mlcg.toml are variants of it (cases/README.md, "Variants")
      if (f == "case.toml") replace(text, "window = [0.1, 0.5]", "window = [0.05, 0.2]");
      if (f == "case.toml") replace(text, "plus = 0.5 }", "plus = 0.2 }");
      // a second probe, wider and lower: the per-probe table compares it too
      if (f == "case.toml")
        replace(text, "[[grids]]", "[[probes]]\nname = \"wide\"\npoint = [0.0, 0.0, -0.03]\nnormal = [0.0, 0.0, -1.0]\n"
                                   "radius = 0.05\nwindow = [0.05, 0.2]\nwindow_relative_to = \"open\"\n\n[[grids]]");
      if (f == "mlcg.toml") replace(text, "end = 0.6", "end = 0.5");
      std::ofstream(kDir / "cases" / f) << text;
    }
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

// Every run records its ⟨ṁ⟩ interval (the hierarchy's summary the fine level's), and the error's interval
// in study.json / study.csv is the two runs' intervals propagated: recomputed here from the summaries.
void check_intervals(const std::vector<std::map<std::string, std::string>>& rows) {
  const auto study = read_json(kDir / "main" / "study.json");
  ASSERT_EQ(study["variants"].size(), rows.size());
  const auto ref = summary(rows[0].at("run"))["probes"][0];
  const double m_ref = ref["mean_kg_per_s"], ci_ref = ref["ci95_kg_per_s"];
  for (size_t i = 0; i < rows.size(); ++i) {
    const auto p = summary(rows[i].at("run"))["probes"][0];
    ASSERT_TRUE(p["ci95_kg_per_s"].is_number()) << rows[i].at("name");
    const double m = p["mean_kg_per_s"], ci = p["ci95_kg_per_s"];
    EXPECT_GT(ci, 0.0) << rows[i].at("name");
    EXPECT_GT(p["std_kg_per_s"].get<double>(), ci) << "the window's fluctuation exceeds the mean's uncertainty";
    const double expect = i == 0 ? 0.0 : 100.0 * std::abs(m / m_ref) * std::sqrt(std::pow(ci / m, 2) +
                                                                                 std::pow(ci_ref / m_ref, 2));
    const auto& v = study["variants"][i];
    EXPECT_NEAR(v["ci95_kg_per_s"].get<double>(), ci, 1e-12 * ci) << rows[i].at("name");
    EXPECT_NEAR(v["error_ci_pct"].get<double>(), expect, 1e-9 * (1.0 + expect)) << rows[i].at("name");
    EXPECT_NEAR(std::stod(rows[i].at("error_ci_pct")), expect, 1e-6 * (1.0 + expect)) << rows[i].at("name");
  }
  EXPECT_GT(std::stod(rows[1].at("error_ci_pct")), 0.0);
  // The reference's interval from its probe csv, by hand.
  EXPECT_NEAR(ci_from_probe_csv(rows[0].at("run"), ref), ci_ref, 1e-6 * ci_ref);
  // A hierarchy reports its finest level's probe, interval included.
  const fs::path mlcg = rows[2].at("run");
  const auto fine = read_json(mlcg / "levels" / "fine" / "summary.json")["probes"][0];
  const auto top = summary(mlcg.string())["probes"][0];
  EXPECT_EQ(top["ci95_kg_per_s"], fine["ci95_kg_per_s"]);
  EXPECT_EQ(top["ci_method"], fine["ci_method"]);
  EXPECT_NEAR(ci_from_probe_csv(mlcg / "levels" / "fine", fine), fine["ci95_kg_per_s"].get<double>(),
              1e-6 * fine["ci95_kg_per_s"].get<double>());
}

// What a run cost by its own summary.json: the CPU seconds the launcher measured and the particle-steps
// summed over its levels, coarsest first.
std::pair<double, double> cost(const std::string& run) {
  const auto s = summary(run);
  double steps = 0.0;
  for (const auto& l : s["levels"]) steps += l["particle_steps"].get<double>();
  return {s["cpu_seconds"].get<double>(), steps};
}

// The csv's 9 significant digits of x, as the study prints them.
std::string digits9(double x) {
  char b[32];
  std::snprintf(b, sizeof b, "%.9g", x);
  return b;
}

// speedup_cpu and particle_step_ratio of every row equal the reference's cost over the row's, recomputed from
// the runs' own summaries, to every digit the csv prints.
void check_ratios(const std::vector<std::map<std::string, std::string>>& rows) {
  const auto [cpu_ref, steps_ref] = cost(rows[0].at("run"));
  for (const auto& r : rows) {
    const auto [cpu, steps] = cost(r.at("run"));
    EXPECT_EQ(r.at("speedup_cpu"), digits9(cpu_ref / cpu)) << r.at("name");
    EXPECT_EQ(r.at("particle_step_ratio"), digits9(steps_ref / steps)) << r.at("name");
  }
  EXPECT_EQ(rows[0].at("speedup_cpu"), "1");
  EXPECT_EQ(rows[0].at("particle_step_ratio"), "1");
}

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
  check_ratios(rows);
  // The plain coarse grain is much cheaper in particle-steps; the hierarchy's probe is its fine level's.
  EXPECT_GT(std::stod(rows[1].at("particle_step_ratio")), 2.0);
  EXPECT_EQ(summary(rows[2].at("run"))["probes_from_level"], "fine");
  EXPECT_NE(std::stod(rows[1].at("error_pct")), 0.0);
  const std::string md = slurp(kDir / "main" / "study.md");
  for (const auto& r : rows) EXPECT_NE(md.find(r.at("label")), std::string::npos) << r.at("label");
  check_intervals(rows);
  // Every probe of the reference, per variant, against the reference's same probe, read from the level each
  // run's summary names for it
  const auto every = read_json(kDir / "main" / "study.json")["probes"];
  ASSERT_EQ(every.size(), 2u);
  EXPECT_NE(md.find("## Every probe"), std::string::npos);
  for (size_t p = 0; p < 2; ++p) {
    EXPECT_EQ(every[p]["probe"], p == 0 ? "outlet" : "wide");
    const double ref_p = summary(rows[0].at("run"))["probes"][p]["mean_kg_per_s"];
    ASSERT_EQ(every[p]["variants"].size(), rows.size());
    for (size_t v = 0; v < rows.size(); ++v) {
      const auto got = every[p]["variants"][v];
      const auto want = summary(rows[v].at("run"))["probes"][p];
      EXPECT_EQ(got["name"], rows[v].at("name"));
      EXPECT_DOUBLE_EQ(got["mdot_kg_per_s"].get<double>(), want["mean_kg_per_s"].get<double>()) << p << " " << v;
      EXPECT_NEAR(got["error_pct"].get<double>(), 100.0 * (want["mean_kg_per_s"].get<double>() - ref_p) / ref_p, 1e-9);
      EXPECT_EQ(got["level"].get<std::string>(), want.value("level", std::string())) << p << " " << v;
    }
  }
  // The coupling's cost beside the error: the hierarchy's overhead and its parts, none for the single levels.
  EXPECT_NE(md.find("## Coupling cost"), std::string::npos);
  const auto variants = read_json(kDir / "main" / "study.json")["variants"];
  for (size_t v = 0; v < rows.size(); ++v) {
    const auto c = variants[v]["coupling_cost"];
    const auto sc = summary(rows[v].at("run")).value("coupling", nlohmann::json::object());
    EXPECT_EQ(c.is_null(), !sc.contains("overhead_share")) << rows[v].at("name");
    if (c.is_null()) continue;
    EXPECT_DOUBLE_EQ(c["overhead_share"].get<double>(), sc["overhead_share"].get<double>());
    EXPECT_GT(c["level_coupling_parts"]["samples"].get<double>(), 0.0);
  }
}

void check_plots() {
  // scripts/setup.sh installs matplotlib: without it the plots are missing, a failure, not a pass.
  ASSERT_TRUE(has_matplotlib()) << "/usr/bin/python3 cannot import matplotlib: run scripts/setup.sh "
                                   "(it installs python3-matplotlib)";
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
  replace(text, "base = \"case.toml\"", "base = \"case.toml\"\nseed = 43");
  std::ofstream(kDir / "cases" / "cg2_changed.toml") << text;
  ASSERT_EQ(study(cg2_only("cg2_changed.toml", "cg2_only"), &out), 0) << out;
  const auto t2 = fs::last_write_time(s);
  EXPECT_GT(t2, t1) << "a run of another case is not reused";
  EXPECT_NE(out.find("the case changed"), std::string::npos) << out;
  // cg2.toml is a variant of case.toml: an edit of the base alone is a change of the case too.
  ASSERT_EQ(study(cg2_only("cg2.toml", "cg2_only"), &out), 0) << out;
  const auto t3 = fs::last_write_time(s);
  EXPECT_GT(t3, t2) << "back to cg2.toml, after cg2_changed.toml ran in its place";
  std::string scene = slurp(kDir / "cases" / "case.toml");
  replace(scene, "seed = 42", "seed = 44");
  std::ofstream(kDir / "cases" / "case.toml") << scene;
  ASSERT_EQ(study(cg2_only("cg2.toml", "cg2_only"), &out), 0) << out;
  EXPECT_GT(fs::last_write_time(s), t3) << "an edited base must not reuse the variant's run";
  EXPECT_NE(out.find("the case changed"), std::string::npos) << out;
  // A launcher that died before writing anything leaves its lock alone in the folder: that folder is run again,
  // not refused as "not a run folder"; a folder of the user's beside it still is refused.
  fs::remove_all(kDir / "cg2_only" / "cg2");
  fs::create_directories(kDir / "cg2_only" / "cg2");
  std::ofstream(kDir / "cg2_only" / "cg2" / "launcher.lock") << "12345\n";
  ASSERT_EQ(study(cg2_only("cg2.toml", "cg2_only"), &out), 0) << out;
  EXPECT_TRUE(fs::exists(s)) << out;
  fs::remove_all(kDir / "cg2_only" / "cg2");
  fs::create_directories(kDir / "cg2_only" / "cg2");
  std::ofstream(kDir / "cg2_only" / "cg2" / "notes.txt") << "mine\n";
  EXPECT_EQ(study(cg2_only("cg2.toml", "cg2_only"), &out), 2) << out;
  EXPECT_NE(out.find("is not a run folder; not replacing it"), std::string::npos) << out;
}

// The reference is an earlier run (`run = ...`, here the plain coarse grain); a sweep derives one case per value.
TEST_F(Study, ASweepOverTwoValuesGivesTwoRowsWithTheSweptValue) {
  std::string out;
  ASSERT_EQ(study(cg2_only("cg2.toml", "earlier"), &out), 0) << out;
  const fs::path ref_run = kDir / "earlier" / "cg2";
  // An older run folder, written before intervals were recorded: the study takes the interval from the
  // probe's series (the same batch-means rule), and says n/a where the series is gone too.
  auto old = summary(ref_run.string());
  const double ci_recorded = old["probes"][0]["ci95_kg_per_s"].get<double>();
  for (auto& p : old["probes"]) p.erase("ci95_kg_per_s"), p.erase("ci_method"), p.erase("effective_samples");
  std::ofstream(ref_run / "summary.json") << old.dump(2);
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
    EXPECT_NEAR(std::stod(rows[i].at("ci95_kg_per_s")), s["probes"][0]["ci95_kg_per_s"].get<double>(), 1e-8);
    EXPECT_FALSE(rows[i].at("error_ci_pct").empty()) << "the reference's interval came from its series";
  }
  EXPECT_NEAR(std::stod(rows[0].at("ci95_kg_per_s")), ci_recorded, 1e-6 * ci_recorded);
  EXPECT_EQ(fs::last_write_time(ref_run / "summary.json"), ref_time) << "a given run is never rerun";

  fs::rename(ref_run / "probes", ref_run / "probes.hidden");  // no series either: n/a
  ASSERT_EQ(study((kDir / "cases").string() + " --no-plots --study " + file.string() + " --out " +
                      (kDir / "sweep").string(), &out),
            0)
      << out;
  const auto rows2 = read_csv(kDir / "sweep" / "study.csv");
  EXPECT_EQ(rows2[0].at("ci95_kg_per_s"), "");
  EXPECT_EQ(rows2[1].at("error_ci_pct"), "") << "no interval of the reference: none for the error";
  EXPECT_NE(slurp(kDir / "sweep" / "study.md").find("± n/a"), std::string::npos);
  EXPECT_TRUE(read_json(kDir / "sweep" / "study.json")["variants"][1]["error_ci_pct"].is_null());
  fs::rename(ref_run / "probes.hidden", ref_run / "probes");
}

// `replicas = 2` on the cheap coarse-grain case: two runs with seeds 42 and 43 (derived cases), one row
// whose ⟨ṁ⟩ is their mean, spread their sample std and interval t_{0.975,1} spread / sqrt(2).
TEST_F(Study, ReplicasRunTheVariantWithSuccessiveSeedsAndReportTheirSpread) {
  const fs::path file = kDir / "cases" / "replicas.toml";
  std::ofstream(file) << "[[variants]]\nname = \"cg2\"\ncase = \"cg2.toml\"\nreplicas = 2\n";
  const std::string args =
      (kDir / "cases").string() + " --no-plots --study " + file.string() + " --out " + (kDir / "rep").string();
  std::string out;
  ASSERT_EQ(study(args, &out), 0) << out;
  std::vector<double> m;
  for (int k = 1; k <= 2; ++k) {
    const fs::path run = kDir / "rep" / ("cg2-r" + std::to_string(k));
    const std::string copied = slurp(run / "case.toml");
    EXPECT_NE(copied.find("seed = " + std::to_string(41 + k)), std::string::npos) << copied.substr(0, 300);
    EXPECT_TRUE(fs::exists(kDir / "rep" / "cases" / ("cg2-r" + std::to_string(k) + ".toml")));
    const auto s = summary(run.string());
    EXPECT_EQ(s["status"], "completed");
    m.push_back(s["probes"][0]["mean_kg_per_s"].get<double>());
  }
  EXPECT_NE(m[0], m[1]) << "another seed, another discharge";
  const auto rows = read_csv(kDir / "rep" / "study.csv");
  ASSERT_EQ(rows.size(), 1u);
  const double mean = 0.5 * (m[0] + m[1]), spread = std::abs(m[0] - m[1]) / std::sqrt(2.0);
  EXPECT_EQ(rows[0].at("replicas"), "2");
  EXPECT_NEAR(std::stod(rows[0].at("mdot_kg_per_s")), mean, 1e-8 * mean);
  EXPECT_NEAR(std::stod(rows[0].at("spread_kg_per_s")), spread, 1e-6 * spread);
  EXPECT_NEAR(std::stod(rows[0].at("ci95_kg_per_s")), 12.7062 * spread / std::sqrt(2.0), 1e-4 * spread);
  const auto v = read_json(kDir / "rep" / "study.json")["variants"][0];
  ASSERT_EQ(v["runs"].size(), 2u);
  EXPECT_EQ(v["runs"][0]["seed"], 42);
  EXPECT_EQ(v["runs"][1]["seed"], 43);
  EXPECT_NE(out.find("(2 replicas, spread"), std::string::npos) << out;
  ASSERT_EQ(study(args, &out), 0) << out;
  EXPECT_EQ(out.find("running"), std::string::npos) << "both replicas are reused: " << out;
}

TEST_F(Study, RefusesBadStudyFilesNamingFileLineAndKey) {
  struct Bad {
    std::string text, expect;
  };
  const std::string sweep = "[[variants]]\nname = \"r\"\ncase = \"cg2.toml\"\n\n[[sweep]]\nbase = \"mlcg.toml\"\n";
  // A table header of 100,000 parts overflowed the TOML reader's stack (found by fuzzing, tests/fuzz/fuzz_study).
  std::string deep = "a";
  for (int k = 1; k < 100000; ++k) deep += ".a";
  const Bad bad[] = {
      {sweep + "key = \"coupling.intervall\"\nvalues = [1e-4]\n", "bad.toml:7: sweep[0].key"},
      {sweep + "key = \"levels.nosuch.alpha\"\nvalues = [2.0]\n", "'nosuch' selects no entry of levels"},
      {"[[variants]]\nname = \"r\"\ncase = \"cg2.toml\"\nrefrence = \"x\"\n", "bad.toml:4: variants[0].refrence: unknown key; allowed keys: name, case, run, label, replicas"},
      {"[[variants]]\nname = \"r\"\ncase = \"cg2.toml\"\nlable = \"x\"\n",
       "bad.toml:4: variants[0].lable: unknown key (did you mean 'label'?)"},
      {"[[variants]]\nname = \"r\"\ncase = \"nothere.toml\"\n", "bad.toml:3: variants[0].case: file not found"},
      {"[[variants]]\nname = \"r\"\ncase = \"cg2.toml\"\nreplicas = 0\n",
       "bad.toml:4: variants[0].replicas: 0 is out of range; allowed 1..20"},
      {"[[variants]]\nname = \"r\"\ncase = \"cg2.toml\"\n\nreplicas = 21\n",
       "bad.toml:5: variants[0].replicas: 21 is out of range; allowed 1..20"},
      {"[[variants]]\nname = \"r\"\nreplicas = \"x\"\ncase = \"cg2.toml\"\n",
       "bad.toml:3: variants[0].replicas: 'x' is not a number; allowed 1..20"},
      {"[[variants]]\nname = \"r\"\ncase = \"cg2.toml\"\nreplicas = 2.5\n",
       "bad.toml:4: variants[0].replicas: 2.5 is not a whole number; allowed 1..20"},
      // the region rules, before anything runs: a region top 0.83 orifice diameters above the orifice
      {sweep + "key = \"coupling.regions[0].max\"\nvalues = [[0.04, 0.04, 0.02]]\n",
       "coupling.regions[0].max: the region's top is z = 0.02 m, 0.83 orifice diameters above the orifice"},
      {"[[variants]]\nname = \"r\"\ncase = \"cg2.toml\"\n[" + deep + "]\n",
       "bad.toml:4: a dotted key or table header of more than 64 parts"},
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
