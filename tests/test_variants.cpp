// Variants (issue 16): a case written as `base = "other.toml"` plus what differs.
// The shipped variant files must describe exactly the scene their former full copies
// did (kept in tests/data/legacy_cases, which also shows old full files still load);
// a key is named at the file and line it is written in, base or variant; chains,
// cycles and bad bases; count_alpha1 scaled by the coarsest alpha; the resolved text
// a run folder keeps loads back to the same case and changes when its base changes.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "config/case_parser.hpp"
#include "files.hpp"

namespace {

namespace fs = std::filesystem;
using namespace mlcg::config;
using mlcg::test::slurp;
using Folder = mlcg::test::TempDir;  // a fresh temporary folder, removed unless the test failed

void put(const fs::path& p, const std::string& text) {
  fs::create_directories(p.parent_path());
  std::ofstream(p) << text;
}

// The case with everything that says where it was read from cleared: what is left is the scene.
// Mesh files as named from the case's folder (a copy elsewhere names the same mesh), or as absolute paths.
CaseSpec scene_of(CaseSpec c, bool files_relative = true) {
  for (auto& w : c.walls)
    if (!w.file.empty())
      w.file = files_relative ? fs::path(w.file).lexically_relative(c.dir).string()
                              : fs::absolute(w.file).lexically_normal().string();
  c.path.clear();
  c.dir.clear();
  c.bases.clear();
  auto clear = [](auto& v) {
    for (auto& x : v) x.loc = {};
  };
  clear(c.materials), clear(c.interactions), clear(c.levels), clear(c.walls), clear(c.insertions);
  clear(c.particles), clear(c.events), clear(c.probes), clear(c.grids), clear(c.swaps);
  if (c.initial) c.initial->loc = {};
  for (auto& o : c.orifices) o.loc = {};
  if (c.coupling) {
    c.coupling->loc = {};
    for (auto& r : c.coupling->regions) r.loc = {}, r.key_locs.clear();
  }
  c.launcher.loc = {};
  c.limits.loc = {};
  return c;
}

// What differs between two scenes, table by table, so a failure says where to look.
std::string differences(const CaseSpec& a, const CaseSpec& b) {
  std::string d;
  auto note = [&d](const char* what, bool same) {
    if (!same) d += std::string(" ") + what;
  };
  note("title", a.title == b.title), note("seed", a.seed == b.seed), note("gravity", a.gravity == b.gravity);
  note("materials", a.materials == b.materials), note("interactions", a.interactions == b.interactions);
  note("contact", a.contact == b.contact), note("levels", a.levels == b.levels), note("domain", a.domain == b.domain);
  note("walls", a.walls == b.walls), note("insertion", a.insertions == b.insertions);
  note("particles", a.particles == b.particles), note("initial", a.initial == b.initial);
  note("events", a.events == b.events), note("probes", a.probes == b.probes), note("grids", a.grids == b.grids);
  note("output", a.output == b.output), note("stability", a.stability == b.stability), note("time", a.time == b.time);
  note("orifices", a.orifices == b.orifices), note("coupling", a.coupling == b.coupling);
  note("launcher", a.launcher == b.launcher), note("swap", a.swaps == b.swaps), note("limits", a.limits == b.limits);
  return d;
}

const std::vector<std::string> kShipped = {
    "silo_small/reference.toml", "silo_small/cg2.toml",      "silo_small/mlcg.toml",
    "silo_small/mlcg_no_pi.toml", "silo_small/mlcg_tall.toml", "quickstart/case.toml",
    "quickstart/cg2.toml",        "quickstart/mlcg.toml",      "quickstart/mlcg3.toml",
    "hoppers/flat_bin/reference.toml", "hoppers/flat_bin/cg2.toml", "hoppers/flat_bin/mlcg.toml",
    "hoppers/low_friction/reference.toml", "hoppers/low_friction/cg2.toml", "hoppers/low_friction/mlcg.toml",
    "hoppers/offcentre_bin/reference.toml", "hoppers/offcentre_bin/cg2.toml", "hoppers/offcentre_bin/mlcg.toml",
    "hoppers/steep_cone/reference.toml", "hoppers/steep_cone/cg2.toml", "hoppers/steep_cone/mlcg.toml",
    "hoppers/wedge_slot/reference.toml", "hoppers/wedge_slot/cg2.toml", "hoppers/wedge_slot/mlcg.toml",
    "hoppers/wide_cone_junction/reference.toml", "hoppers/wide_cone_junction/cg2.toml", "hoppers/wide_cone_junction/mlcg.toml"};

const std::string kCases = std::string(MLCG_SOURCE_DIR) + "/cases/";
const std::string kLegacy = std::string(MLCG_TEST_DATA) + "/legacy_cases/";

TEST(Variants, ShippedVariantsAreTheirFormerFullFiles) {
  int variants = 0;
  for (const std::string& name : kShipped) {
    const CaseSpec now = load_case(kCases + name);
    const CaseSpec before = load_case(kLegacy + name);
    EXPECT_EQ(scene_of(now), scene_of(before)) << name << " differs in:" << differences(scene_of(now), scene_of(before));
    variants += slurp(kCases + name).find("\nbase = ") != std::string::npos;
  }
  EXPECT_GE(variants, 19) << "the shipped folders should hold one scene each and variants of it";
}

TEST(Variants, ResolvedTextLoadsBackToTheSameScene) {
  Folder f("variants_resolved");
  int variants = 0;
  for (const std::string& name : kShipped) {
    const std::string text = resolved_case_text(kCases + name);
    if (text == slurp(kCases + name)) continue;  // a plain file is kept byte for byte
    ++variants;
    const fs::path copy = f.path() / fs::path(name).filename();
    put(copy, text);
    EXPECT_EQ(scene_of(load_case(copy.string()), false), scene_of(load_case(kCases + name), false)) << name;
    EXPECT_EQ(text.find("\nbase"), std::string::npos) << name << ": the resolved text still names a base";
  }
  EXPECT_GE(variants, 19);
  // A plain file is kept byte for byte, comments and all.
  EXPECT_EQ(resolved_case_text(kCases + "quickstart/case.toml"), slurp(kCases + "quickstart/case.toml"));
}

TEST(Variants, ResolvedTextChangesWhenTheBaseChanges) {
  Folder f("variants_hash");
  put(f.path() / "scene.toml", slurp(kCases + "quickstart/case.toml"));
  put(f.path() / "v.toml", "base = \"scene.toml\"\n[time]\nend = 0.05\n");
  const std::string before = resolved_case_text((f.path() / "v.toml").string());
  std::string scene = slurp(f.path() / "scene.toml");
  const size_t at = scene.find("seed = ");
  ASSERT_NE(at, std::string::npos);
  scene.insert(at, "seed = 7\n#");
  put(f.path() / "scene.toml", scene);
  const std::string after = resolved_case_text((f.path() / "v.toml").string());
  EXPECT_NE(before, after);
  EXPECT_EQ(load_case((f.path() / "v.toml").string()).seed, 7u);
}

// `mlcg run single.toml` in the case's own folder: a path without a folder is in the current one.
TEST(Variants, ACaseNamedWithoutAFolderIsInTheCurrentOne) {
  Folder f("variants_cwd");
  put(f.path() / "scene.toml", slurp(kCases + "quickstart/case.toml"));
  put(f.path() / "v.toml", "base = \"scene.toml\"\n[time]\nend = 0.05\n");
  const fs::path before = fs::current_path();
  fs::current_path(f.path());
  EXPECT_EQ(resolved_case_text("scene.toml"), slurp("scene.toml"));
  EXPECT_NE(resolved_case_text("v.toml").find("end = 0.05"), std::string::npos);
  EXPECT_DOUBLE_EQ(load_case("v.toml").time.end, 0.05);
  EXPECT_EQ(fs::path(load_case("v.toml").dir), f.path().lexically_normal());
  fs::current_path(before);
}

TEST(Variants, SectionsMergeKeyByKeyArraysOfTablesReplaceWhole) {
  Folder f("variants_merge");
  put(f.path() / "scene.toml", slurp(kCases + "quickstart/case.toml"));
  put(f.path() / "v.toml",
      "base = \"scene.toml\"\n"
      "[time]\nend = 0.05\n"
      "[[levels]]\nname = \"coarse\"\nalpha = 2.0\ndt_alpha1 = 1.2e-5\n");
  const CaseSpec base = load_case((f.path() / "scene.toml").string());
  const CaseSpec v = load_case((f.path() / "v.toml").string());
  EXPECT_DOUBLE_EQ(v.time.end, 0.05);
  EXPECT_EQ(v.time.progress_interval, base.time.progress_interval);
  EXPECT_EQ(v.materials, base.materials);
  ASSERT_EQ(v.levels.size(), 1u);
  EXPECT_EQ(v.levels[0].name, "coarse");
  EXPECT_DOUBLE_EQ(v.levels[0].alpha, 2.0);
  EXPECT_EQ(v.walls, base.walls);
  EXPECT_EQ(v.levels[0].loc.file, (f.path() / "v.toml").string());
  EXPECT_EQ(v.levels[0].loc.line, 4);
  EXPECT_EQ(v.walls.at(0).loc.file, (f.path() / "scene.toml").lexically_normal().string());
}

TEST(Variants, ABadKeyInTheBaseIsNamedAtTheBasesLine) {
  Folder f("variants_badbase");
  std::string scene = slurp(kCases + "quickstart/case.toml");
  const size_t at = scene.find("[domain]");
  ASSERT_NE(at, std::string::npos);
  scene.insert(at, "[domian]\nmin = 1\n\n");
  const int line = 1 + static_cast<int>(std::count(scene.begin(), scene.begin() + static_cast<long>(at), '\n'));
  put(f.path() / "scene" / "scene.toml", scene);
  put(f.path() / "study" / "v.toml", "base = \"../scene/scene.toml\"\n[time]\nend = 0.05\n");
  try {
    load_case((f.path() / "study" / "v.toml").string());
    FAIL() << "the misspelt table in the base was accepted";
  } catch (const CaseError& e) {
    const std::string expected = (f.path() / "scene" / "scene.toml").string() + ":" + std::to_string(line) + ": domian";
    EXPECT_EQ(std::string(e.what()).rfind(expected, 0), 0u) << e.what();
  }
}

TEST(Variants, AMeshFileResolvesAgainstTheFileThatNamesIt) {
  Folder f("variants_mesh");
  const std::string stl = slurp(std::string(MLCG_TEST_DATA) + "/mesh/cube_ascii.stl");
  put(f.path() / "scene" / "meshes" / "m.stl", stl);
  std::string scene = slurp(kCases + "quickstart/case.toml");
  scene += "\n[[walls]]\nname = \"mesh\"\ntype = \"mesh\"\nfile = \"meshes/m.stl\"\nmaterial = \"steel\"\nscale = 0.001\n";
  put(f.path() / "scene" / "scene.toml", scene);
  put(f.path() / "study" / "v.toml", "base = \"../scene/scene.toml\"\n[time]\nend = 0.05\n");
  const CaseSpec v = load_case((f.path() / "study" / "v.toml").string());
  ASSERT_FALSE(v.walls.empty());
  EXPECT_EQ(fs::path(v.walls.back().file).lexically_normal(), (f.path() / "scene" / "meshes" / "m.stl").lexically_normal());
  // The resolved text names the mesh absolutely, so a run folder's copy still finds it.
  put(f.path() / "elsewhere" / "case.toml", resolved_case_text((f.path() / "study" / "v.toml").string()));
  EXPECT_EQ(fs::path(load_case((f.path() / "elsewhere" / "case.toml").string()).walls.back().file).lexically_normal(),
            fs::path(v.walls.back().file).lexically_normal());
}

// `variant_text` as v.toml must be refused at `at` (file:1: base: ...) with `phrase`.
void expect_base_error(const std::string& variant_text, const std::string& phrase, const Folder& f,
                       const std::string& at = "v.toml") {
  put(f.path() / "v.toml", variant_text);
  try {
    load_case((f.path() / "v.toml").string());
    FAIL() << "accepted: " << variant_text;
  } catch (const CaseError& e) {
    const std::string msg = e.what();
    EXPECT_EQ(msg.rfind((f.path() / at).string() + ":1: base: ", 0), 0u) << msg;
    EXPECT_NE(msg.find(phrase), std::string::npos) << msg;
  }
}

TEST(Variants, BadBasesAreRefusedWithTheReason) {
  Folder f("variants_bad");
  expect_base_error("base = 3\n", "expected a string", f);
  expect_base_error("base = \"\"\n", "empty string", f);
  expect_base_error("base = \"missing.toml\"\n", "is not a file", f);
  expect_base_error("base = \"v.toml\"\n", "a case cannot vary itself", f);
  put(f.path() / "a.toml", "base = \"v.toml\"\n");
  expect_base_error("base = \"a.toml\"\n", (f.path() / "v.toml").string() + " is already in this chain", f, "a.toml");
}

TEST(Variants, AChainOfBasesLaysEachOverTheOneBefore) {
  Folder f("variants_chain");
  put(f.path() / "scene.toml", slurp(kCases + "quickstart/case.toml"));
  put(f.path() / "a.toml", "base = \"scene.toml\"\nseed = 5\n[time]\nend = 0.05\n");
  put(f.path() / "b.toml", "base = \"a.toml\"\n[time]\nend = 0.07\n");
  const CaseSpec b = load_case((f.path() / "b.toml").string());
  EXPECT_EQ(b.seed, 5u);
  EXPECT_DOUBLE_EQ(b.time.end, 0.07);
  // The chain is kept, nearest base first (`mlcg check` prints it).
  EXPECT_EQ(b.bases, (std::vector<std::string>{fs::weakly_canonical(f.path() / "a.toml").string(),
                                               fs::weakly_canonical(f.path() / "scene.toml").string()}));
  EXPECT_TRUE(load_case((f.path() / "scene.toml").string()).bases.empty());
}

// The insertion of quickstart/case.toml with its amount replaced, as a one-level case at `alpha`.
CaseSpec with_amount(const Folder& f, const std::string& amount, double alpha) {
  std::string scene = slurp(kCases + "quickstart/case.toml");
  const size_t at = scene.find("count_alpha1 = ");
  EXPECT_NE(at, std::string::npos);
  scene.replace(at, scene.find('\n', at) - at, amount);
  put(f.path() / "scene.toml", scene);
  put(f.path() / "v.toml", "base = \"scene.toml\"\n[[levels]]\nname = \"l\"\nalpha = " + std::to_string(alpha) +
                            "\ndt_alpha1 = 1.2e-5\n");
  return load_case((f.path() / "v.toml").string());
}

// A sweep of alpha over a scene written with count_alpha1 pours the same mass at every alpha, to within
// half a particle of that alpha (the rounding to whole particles): |count x alpha^3 - count_alpha1| <= alpha^3 / 2.
TEST(Variants, CountAtAlphaOneKeepsTheMassAtEveryAlpha) {
  Folder f("variants_sweep");
  for (const double alpha : {1.0, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0}) {
    const CaseSpec c = with_amount(f, "count_alpha1 = 2500", alpha);
    const double a3 = alpha * alpha * alpha;
    EXPECT_LE(std::fabs(static_cast<double>(c.insertions.at(0).count) * a3 - 2500.0), 0.5 * a3 + 1e-9) << alpha;
    EXPECT_NEAR(c.insertions.at(0).rate * a3, 20000.0, 1e-9 * 20000.0) << alpha;
  }
}

TEST(Variants, CountAtAlphaOneIsDividedByAlphaCubedAndRounded) {
  Folder f("variants_count");
  EXPECT_EQ(with_amount(f, "count_alpha1 = 2500", 2.0).insertions.at(0).count, 313);  // 312.5 rounds up
  EXPECT_EQ(with_amount(f, "count_alpha1 = 2500", 1.0).insertions.at(0).count, 2500);
  EXPECT_EQ(with_amount(f, "count_alpha1 = 1000", 2.5).insertions.at(0).count, 64);
  EXPECT_EQ(with_amount(f, "count = 1000", 2.5).insertions.at(0).count, 1000);  // a level's own count is kept
  const CaseSpec r = with_amount(f, "count_alpha1 = 1000", 2.0);
  const CaseSpec r1 = with_amount(f, "count_alpha1 = 1000", 1.0);
  EXPECT_NEAR(r.insertions.at(0).rate * 8.0, r1.insertions.at(0).rate, 1e-9 * r1.insertions.at(0).rate);
  try {
    with_amount(f, "count_alpha1 = 3", 2.0);
    FAIL() << "3 particles at alpha = 1 are 0.375 at alpha = 2";
  } catch (const CaseError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("scene.toml:"), std::string::npos) << msg;
    EXPECT_NE(msg.find("count_alpha1: 3 particles at alpha = 1 are 0.375 at alpha = 2"), std::string::npos) << msg;
    EXPECT_NE(msg.find("count_alpha1 >= 4"), std::string::npos) << msg;
  }
  try {
    with_amount(f, "count_alpha1 = 100\ncount = 3", 1.0);
    FAIL() << "two amounts accepted";
  } catch (const CaseError& e) {
    EXPECT_NE(std::string(e.what()).find("count_alpha1"), std::string::npos) << e.what();
  }
}

}  // namespace
