#include "study/study.hpp"

#include <cstdio>
#include <cstdlib>
#include <filesystem>

#include <fmt/format.h>

#include "io/atomic_file.hpp"
#include "process/process.hpp"
#include "run/run_case.hpp"
#include "run/run_folder.hpp"
#include "study/study_file.hpp"
#include "study/study_report.hpp"

namespace fs = std::filesystem;

namespace mlcg::launcher {
namespace {

// The folders whose copied case.toml a run left: one per level of a hierarchy.
std::vector<fs::path> copied_cases(const fs::path& run, const nlohmann::json& summary) {
  const auto& levels = summary.value("levels", nlohmann::json::array());
  if (levels.size() <= 1) return {run / "case.toml"};
  std::vector<fs::path> out;
  for (const auto& l : levels) out.push_back(run / "levels" / l.value("name", "") / "case.toml");
  return out;
}

// "" when the variant's run can be reused: completed, and run on exactly the case it names now.
std::string why_not_reusable(const Variant& v) {
  if (!fs::exists(v.run / "summary.json")) return "not run yet";
  const auto s = read_json_file(v.run / "summary.json");
  const std::string status = s.value("status", "unreadable");
  if (status != "completed") return "its run is " + status;
  for (const auto& c : copied_cases(v.run, s))
    if (read_text(c) != v.case_text) return "the case changed since " + c.string() + " was copied";
  return "";
}

// Only a run folder is replaced: anything else in the way is the user's.
void clear_run_folder(const fs::path& run) {
  if (!fs::exists(run)) return;
  bool is_run = false;
  for (const char* f : {"summary.json", "case.toml", "levels", "log.txt", "coupler.log"}) is_run |= fs::exists(run / f);
  // a folder a launcher claimed and died in before it wrote anything holds only its lock (and batch files)
  bool claimed_only = true;
  for (const auto& e : fs::directory_iterator(run)) claimed_only &= submission_file(e.path().filename().string());
  is_run |= claimed_only;
  if (!is_run && !fs::is_empty(run))
    throw StudyError(run.string() + " exists and is not a run folder; not replacing it (move it, or give the study "
                                    "another folder)");
  try {
    const RunLock in_use(run);  // nor the folder of a run that is going on
  } catch (const RunFolderError& e) {
    throw StudyError(e.what());
  }
  fs::remove_all(run);
}

// Derived cases are rewritten only when they change, so their runs stay reusable.
void write_if_changed(const fs::path& p, const std::string& text) {
  if (read_text(p) != text) io::write_file_atomic(p, text);
}

void print_plan(const StudySpec& s, const std::vector<std::string>& why) {
  std::printf("mlcg study: %zu variant(s) from %s; study folder %s\n", s.variants.size(),
              s.file.empty() ? "the case folder's usual files (no study.toml)" : s.file.c_str(), s.folder.c_str());
  for (size_t i = 0; i < s.variants.size(); ++i) {
    const auto& v = s.variants[i];
    const std::string action = v.pointed ? "given run, used as it is" : why[i].empty() ? "reuse" : "run: " + why[i];
    const std::string name = v.replica ? fmt::format("{} r{}/{}", v.name, v.replica, v.replicas) : v.name;
    fmt::print("  {:<16} {:<28} {} -> {} [{}]\n", name, v.label, v.case_file.empty() ? "(no case)" : v.case_file,
               v.run.string(), action);
  }
  std::fflush(stdout);
}

// scripts/plot_study.py: a missing python3 or matplotlib costs the plots, not the study.
void make_plots(const fs::path& folder) {
  const fs::path script = fs::path(MLCG_SCRIPTS_DIR) / "plot_study.py";
  const char* env = std::getenv("MLCG_PYTHON");
  const std::string py = env && *env ? env : fs::exists("/usr/bin/python3") ? "/usr/bin/python3" : "python3";
  int code = -1;
  if (fs::exists(script)) {
    try {
      code = wait_group({{"plot_study.py", spawn({py, script.string(), folder.string()})}}).exit_code;
    } catch (const std::exception& e) {
      std::fprintf(stderr, "%s\n", e.what());
    }
  }
  if (code != 0)
    std::fprintf(stderr,
                 "mlcg study: warning: no plots (%s %s %s); they need python3 with matplotlib (Debian: "
                 "python3-matplotlib, and python3-h5py for pressure.png). study.csv and study.md are written.\n",
                 py.c_str(), script.c_str(), code < 0 ? "could not be started" : fmt::format("exited with {}", code).c_str());
}

// Every probe of the reference compared across the variants (the study's own probe included: the per-outlet
// table). A probe some variant's run lacks, or that the reference never saw flow through, is left out.
std::vector<std::vector<StudyRow>> every_probe(const StudySpec& s, const std::vector<std::string>& why,
                                               const std::vector<StudyRow>& rows) {
  std::vector<std::vector<StudyRow>> out;
  for (const auto& name : probe_names(rows.front())) {
    if (name == rows.front().probe) {
      out.push_back(rows);
      continue;
    }
    try {
      std::vector<StudyRow> per;
      for (size_t i = 0; i < s.variants.size(); ++i) {
        per.push_back(measure_run(s.variants[i], name));
        per.back().reused = why[i].empty();
      }
      per = combine_replicas(std::move(per));
      compare_with_reference(per);
      out.push_back(std::move(per));
    } catch (const StudyError& e) {
      std::fprintf(stderr, "mlcg study: probe '%s' left out of the per-probe table: %s\n", name.c_str(), e.what());
    }
  }
  return out;
}

}  // namespace

int run_study(const StudyOptions& o) {
  StudySpec s;
  std::vector<std::string> why;
  try {
    const std::string file = o.study_file.empty() ? (fs::path(o.case_dir) / "study.toml").string() : o.study_file;
    s = load_study(o.case_dir, file, !o.study_file.empty(), o.out);
    for (const auto& v : s.variants) why.push_back(v.pointed ? "" : o.rerun ? "--rerun" : why_not_reusable(v));
  } catch (const StudyError& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 2;
  }
  print_plan(s, why);
  if (o.dry_run) return 0;
  std::vector<StudyRow> rows;
  std::vector<std::vector<StudyRow>> every;
  try {
    fs::create_directories(s.folder);
    for (size_t i = 0; i < s.variants.size(); ++i) {
      const Variant& v = s.variants[i];
      if (v.derived) write_if_changed(v.case_file, v.case_text);
      if (v.pointed && !v.case_text.empty() && why_not_reusable(v) != "")
        std::fprintf(stderr, "mlcg study: warning: variant '%s': %s was not run on %s as it is now; used as given\n",
                     v.name.c_str(), v.run.c_str(), v.case_file.c_str());
      if (!why[i].empty()) {
        clear_run_folder(v.run);
        const std::string rep = v.replica ? fmt::format(" replica {}/{}, seed {}", v.replica, v.replicas, v.seed) : "";
        std::printf("\nmlcg study: running '%s'%s (%s)\n", v.name.c_str(), rep.c_str(), why[i].c_str());
        std::fflush(stdout);
        const int rc = run_case(v.case_file, v.run.string(), o.quiet);
        if (rc != 0) {
          std::fprintf(stderr, "mlcg study: variant '%s' failed (exit code %d); the study stops here. Runs "
                               "completed so far are reused next time.\n", v.name.c_str(), rc);
          return rc;
        }
      }
      rows.push_back(measure_run(v, s.probe));
      rows.back().reused = why[i].empty();
    }
    rows = combine_replicas(std::move(rows));
    compare_with_reference(rows);
    every = every_probe(s, why, rows);
    write_study_report(s, rows, every);
  } catch (const StudyError& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 2;
  }
  std::printf("\n== study %s ==\n", s.folder.c_str());
  for (const auto& r : rows) fmt::print("{}\n", console_line(r));
  for (const auto& probe : every)
    if (every.size() > 1 && probe.front().probe != rows.front().probe)
      for (const auto& r : probe) fmt::print("probe {}: {}\n", r.probe, console_line(r));
  std::printf("files: %s/{study.csv, study.md, study.json, *.png}\n", s.folder.c_str());
  std::fflush(stdout);
  if (o.plots) make_plots(s.folder);
  return 0;
}

}  // namespace mlcg::launcher
