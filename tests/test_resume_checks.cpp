// `mlcg resume` and the coupler check what a run folder's records say before
// anything starts (issue 13 A): a manifest or launcher.json field of the wrong
// type is named with its file; a manifest may not name files outside its run's
// checkpoints folder; a damaged consistent set is refused with the previous set
// to continue from (or that none exists); an empty, cut or another case's coupler.pb is called so; a cut,
// foreign or other-case manifest is named.
// The run folders here are made by hand: nothing is simulated.
#include <gtest/gtest.h>


#include <filesystem>
#include <fstream>
#include <string>

#include <nlohmann/json.hpp>

#include "bus/case_hash.hpp"
#include "files.hpp"
#include "launch_support.hpp"
#include "shell.hpp"
#include "level/level.hpp"
#include "mlcg/bus.pb.h"
#include "scene_support.hpp"

namespace fs = std::filesystem;
using mlcg::test::slurp;
using mlcg::test::run;
using nlohmann::json;

namespace {

const std::string kBin = MLCG_BIN_DIR;
const std::string kSrc = MLCG_SOURCE_DIR;
const std::string kCase = kSrc + "/cases/quickstart/mlcg.toml";

void write(const fs::path& p, const std::string& text) {
  fs::create_directories(p.parent_path());
  std::ofstream(p, std::ios::binary) << text;
}

// A real level checkpoint (what the launcher checks is its format) and a coupler state of interval k.
void level_file(const fs::path& p) {
  mlcg::Level level(mlcg::test::load("quickstart/case.toml"), mlcg::test::quiet());
  level.write_checkpoint(p);
}

void coupler_file(const fs::path& p, uint64_t k) {
  mlcg::bus::CouplerCheckpoint c;
  c.set_interval(k);
  c.set_case_hash(mlcg::bus::case_hash(kCase));
  write(p, c.SerializeAsString());
}

json set_entry(uint64_t k) {
  std::string set = "i";  // appended: "i" + std::string&& trips a GCC 12 -Wrestrict false positive
  set += std::to_string(k);
  return {{"interval", k}, {"sim_time", 1e-4 * static_cast<double>(k)}, {"case_hash", "0000000000000000"},
          {"coupler", set + "/coupler.pb"}, {"levels", {{"coarse", set + "/coarse.h5"}, {"fine", set + "/fine.h5"}}}};
}

// A run folder with launcher.json and a manifest `m` (the files it names are made by the test). The
// manifest's case hash is not the case's: were the checks missing, resume would stop at the hash and
// start nothing.
struct RunFolder {
  explicit RunFolder(const std::string& tag) : tmp("resume_" + tag), dir(tmp.path()) {
    write(dir / "launcher.json", json{{"case", kCase}}.dump());
  }
  void manifest(json m) {
    m["format"] = "mlcg-hierarchy-checkpoint";
    write(dir / "checkpoints" / "manifest.json", m.dump(2));
  }
  void full_set(uint64_t k) {
    const fs::path set = dir / "checkpoints" / fs::path("i").concat(std::to_string(k));
    level_file(set / "coarse.h5");
    level_file(set / "fine.h5");
    coupler_file(set / "coupler.pb", k);
  }
  std::string resume(int expect_rc, const std::string& extra = "") {
    std::string out;
    EXPECT_EQ(run(kBin + "/mlcg resume " + dir.string() + " --quiet" + extra, out), expect_rc) << out;
    return out;
  }
  const mlcg::test::TempDir tmp;
  const fs::path dir;
};

}  // namespace

TEST(ResumeChecks, ManifestFieldOfTheWrongTypeIsNamedWithItsFile) {
  RunFolder run("type");
  run.full_set(7);
  json m = set_entry(7);
  m["interval"] = "seven";
  run.manifest(m);
  const std::string out = run.resume(2);
  EXPECT_NE(out.find(run.dir.string() + "/checkpoints/manifest.json: field 'interval' is string \"seven\"; expected "
                     "a whole number >= 0"),
            std::string::npos)
      << out;
  EXPECT_EQ(out.find("type_error"), std::string::npos) << out;
  m = set_entry(7);
  m["levels"]["fine"] = 12;
  run.manifest(m);
  EXPECT_NE(run.resume(2).find("field 'levels.fine' is number 12"), std::string::npos);
}

TEST(ResumeChecks, LauncherRecordOfTheWrongTypeIsNamedWithItsFile) {
  RunFolder run("record");
  write(run.dir / "launcher.json", R"({"case": 5})");
  const std::string out = run.resume(2);
  EXPECT_NE(out.find("launcher.json: field 'case' is number 5; expected the case file's path"), std::string::npos)
      << out;
}

TEST(ResumeChecks, ManifestNamingAnotherRunsFilesIsRefused) {
  RunFolder run("outside"), other("other");
  other.full_set(5);
  run.full_set(5);
  json m = set_entry(5);
  m["coupler"] = "../../" + other.dir.filename().string() + "/checkpoints/i5/coupler.pb";
  run.manifest(m);
  std::string out = run.resume(2);
  EXPECT_NE(out.find("field 'coupler' names '../../" + other.dir.filename().string() +
                     "/checkpoints/i5/coupler.pb', outside the run's checkpoints folder"),
            std::string::npos)
      << out;
  m = set_entry(5);
  m["levels"]["coarse"] = (other.dir / "checkpoints" / "i5" / "coarse.h5").string();  // absolute
  run.manifest(m);
  out = run.resume(2);
  EXPECT_NE(out.find("field 'levels.coarse' names '" + other.dir.string()), std::string::npos) << out;
  // A symbolic link inside the folder that leads out of it counts as outside.
  fs::create_directory_symlink(other.dir / "checkpoints" / "i5", run.dir / "checkpoints" / "i6");
  m = set_entry(6);
  run.manifest(m);
  out = run.resume(2);
  EXPECT_NE(out.find("outside the run's checkpoints folder"), std::string::npos) << out;
}

// A level checkpoint overwritten with garbage, or cut to half its length (a copy that stopped short).
TEST(ResumeChecks, DamagedLevelCheckpointPointsToThePreviousIntactSet) {
  RunFolder run("damaged");
  run.full_set(8);
  run.full_set(4);
  const fs::path fine = run.dir / "checkpoints" / "i8" / "fine.h5";
  const std::string whole = slurp(fine);
  json m = set_entry(8);
  m["previous"] = set_entry(4);
  run.manifest(m);
  for (const std::string& damaged : {std::string("not an HDF5 file"), whole.substr(0, whole.size() / 2)}) {
    write(fine, damaged);
    const std::string out = run.resume(2);
    EXPECT_NE(out.find("the consistent checkpoint at interval 8 (t = 0.0008 s) is damaged: " + fine.string() +
                       " (level 'fine') cannot be read"),
              std::string::npos)
        << out;
    EXPECT_NE(out.find("the previous consistent set, interval 4 (t = 0.0004 s), is intact: continue from it with "
                       "`mlcg resume " + run.dir.string() + " --previous`"),
              std::string::npos)
        << out;
  }
  // --previous takes that set (and then meets the case hash the test left wrong, before starting anything).
  EXPECT_NE(run.resume(2, " --previous").find("changed since the checkpoint"), std::string::npos);
}

// The manifest itself cut short, replaced by a JSON file that is not a manifest, or written for another case:
// refused naming it, before anything starts, and the run folder is left as it was.
TEST(ResumeChecks, CutForeignOrOtherCaseManifestIsRefusedNamingIt) {
  RunFolder run("manifest");
  run.full_set(6);
  run.manifest(set_entry(6));
  const fs::path path = run.dir / "checkpoints" / "manifest.json";
  const std::string whole = slurp(path);
  const std::pair<std::string, std::string> cases[] = {
      {whole.substr(0, whole.size() / 2), path.string() + " is not valid JSON (the hierarchy's consistent checkpoint)"},
      {R"({"format": "another-program", "interval": 6})", path.string() + " is not an MLCG hierarchy checkpoint manifest"},
      {whole, "changed since the checkpoint (hash "}};  // the fixture's manifest names another case's hash
  // What may change: launcher.lock, which names the last launcher that held the folder.
  const auto files = [&] {
    auto f = launch_support::fingerprint(run.dir);
    f.erase("launcher.lock");
    return f;
  };
  for (const auto& [text, refusal] : cases) {
    write(path, text);
    const auto before = files();
    const std::string out = run.resume(2);
    EXPECT_NE(out.find(refusal), std::string::npos) << out;
    EXPECT_EQ(files(), before) << "a refused resume changed the run folder";
  }
}

TEST(ResumeChecks, DamagedSetWithoutAnEarlierOneSaysNoneExists) {
  RunFolder run("none");
  run.full_set(3);
  write(run.dir / "checkpoints" / "i3" / "coupler.pb", "");
  run.manifest(set_entry(3));
  const std::string out = run.resume(2);
  EXPECT_NE(out.find("i3/coupler.pb is empty (0 bytes)"), std::string::npos) << out;
  EXPECT_NE(out.find("no earlier consistent set exists: start the run again with `mlcg run`"), std::string::npos)
      << out;
  EXPECT_EQ(out.find("--previous"), std::string::npos) << out;
}

TEST(ResumeChecks, CouplerCallsAnEmptyTruncatedOrOtherCaseStateSo) {
  const fs::path dir = mlcg::test::fresh_temp_path("resume_pb");
  write(dir / "empty.pb", "");
  coupler_file(dir / "whole.pb", 3);
  const std::string whole = slurp(dir / "whole.pb");
  write(dir / "cut.pb", whole.substr(0, whole.size() / 2));
  mlcg::bus::CouplerCheckpoint other;
  other.set_interval(3);
  other.set_case_hash("0123456789abcdef");
  write(dir / "other.pb", other.SerializeAsString());
  std::string out;
  EXPECT_EQ(run(kBin + "/coupler_service " + kCase + " --out " + (dir / "run").string() + " --quiet --resume " +
                    (dir / "empty.pb").string(), out),
            1);
  EXPECT_NE(out.find((dir / "empty.pb").string() + " is empty (0 bytes)"), std::string::npos) << out;
  EXPECT_EQ(out.find("another case"), std::string::npos) << out;
  EXPECT_EQ(run(kBin + "/coupler_service " + kCase + " --out " + (dir / "run").string() + " --quiet --resume " +
                    (dir / "cut.pb").string(), out),
            1);
  EXPECT_NE(out.find((dir / "cut.pb").string() + " is truncated or not a coupler checkpoint"), std::string::npos)
      << out;
  EXPECT_EQ(run(kBin + "/coupler_service " + kCase + " --out " + (dir / "run").string() + " --quiet --resume " +
                    (dir / "other.pb").string(), out),
            1);
  EXPECT_NE(out.find((dir / "other.pb").string() + ": written for another case (hash 0123456789abcdef"),
            std::string::npos) << out;
  fs::remove_all(dir);
}
