#include "run/status.hpp"

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <fstream>
#include <unistd.h>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "run/checkpoints.hpp"
#include "io/atomic_file.hpp"

namespace fs = std::filesystem;

namespace mlcg::launcher {
namespace {

double unix_now() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

std::string host_name() {
  char h[256] = {0};
  if (gethostname(h, sizeof h - 1) != 0) return "localhost";
  return h;
}

std::string duration(double s) {
  if (s < 0) return "?";
  if (s < 60) return fmt::format("{:.0f} s", s);
  if (s < 3600) return fmt::format("{:.0f} min {:02.0f} s", std::floor(s / 60), std::fmod(s, 60));
  return fmt::format("{:.0f} h {:02.0f} min", std::floor(s / 3600), std::fmod(s, 3600) / 60);
}

bool alive(pid_t pid) { return pid > 0 && (kill(pid, 0) == 0 || errno == EPERM); }

// "fine 0.1234 s 1520 p 2.1e+06 p-steps/s | coarse ..."
std::string level_progress(const nlohmann::json& progress) {
  std::string s;
  if (!progress.is_object()) return s;
  for (const auto& l : progress.value("levels", nlohmann::json::array()))
    s += fmt::format("{}{} t={:.4f} s {} p {:.3g} p-steps/s", s.empty() ? "" : " | ", l.value("name", "?"),
                     l.value("sim_time", 0.0), l.value("particles", 0), l.value("particle_steps_per_second", 0.0));
  return s;
}

}  // namespace

StatusBoard::StatusBoard(fs::path run_dir, std::string case_file, bool show_progress)
    : run_dir_(std::move(run_dir)), case_file_(std::move(case_file)), show_(show_progress) {}

void StatusBoard::update(const std::vector<Member>& members, const std::string& state, int attempt, bool force,
                         const std::string& reason) {
  const double now = unix_now();
  if (!force && now - last_ < 1.0) return;
  last_ = now;
  nlohmann::json j;
  j["state"] = state;
  if (!reason.empty()) j["reason"] = reason;
  j["case"] = case_file_;
  j["run_dir"] = fs::absolute(run_dir_).string();
  j["launcher_pid"] = getpid();
  j["host"] = host_name();
  j["attempt"] = attempt;
  j["updated"] = now;
  j["processes"] = nlohmann::json::array();
  for (const auto& m : members)
    j["processes"].push_back({{"name", m.name}, {"pid", m.pid}, {"host", host_name()}, {"state", m.state}});
  const auto progress = read_json_or_null(run_dir_ / "coupling" / "progress.json");
  j["progress"] = progress;
  if (progress.is_object()) sim_time_ = progress.value("sim_time", sim_time_);
  const auto manifest = read_json_or_null(run_dir_ / "checkpoints" / "manifest.json");
  if (manifest.is_object())
    j["checkpoint"] = {{"interval", manifest.value("interval", 0)}, {"sim_time", manifest.value("sim_time", 0.0)}};
  try {
    io::write_file_atomic(run_dir_ / "status.json", j.dump(2) + "\n");
    write_error_.clear();
  } catch (const std::exception& e) {
    if (write_error_ != e.what()) std::fprintf(stderr, "mlcg: cannot write status.json: %s\n", e.what());
    write_error_ = e.what();
  }
  if (!show_ || !progress.is_object() || force) return;  // forced: the final state, after the line ended
  std::printf("\r\033[K%s | ETA %s", level_progress(progress).c_str(), duration(progress.value("eta_seconds", -1.0)).c_str());
  std::fflush(stdout);
  line_open_ = true;
}

void StatusBoard::end_line() {
  if (!line_open_) return;
  std::printf("\n");
  line_open_ = false;
}

int print_ps(const fs::path& run_dir) {
  const auto j = read_json_or_null(run_dir / "status.json");
  if (!j.is_object()) {
    std::fprintf(stderr, "error: %s has no status.json: not the run folder of a multi-level run\n", run_dir.c_str());
    return 1;
  }
  std::string state = j.value("state", "?");
  const bool running = alive(j.value("launcher_pid", -1));
  if (!running && (state == "running" || state == "stopping" || state == "restarting"))
    state += " (launcher gone)";
  std::printf("%s: %s (case %s, launcher pid %d on %s, attempt %d)\n", run_dir.c_str(), state.c_str(),
              j.value("case", "?").c_str(), j.value("launcher_pid", -1), j.value("host", "?").c_str(),
              j.value("attempt", 0) + 1);
  if (j.contains("reason")) std::printf("reason: %s\n", j.value("reason", "").c_str());
  std::printf("%-16s %8s %-12s %s\n", "process", "pid", "host", "state");
  for (const auto& p : j.value("processes", nlohmann::json::array())) {
    std::string st = p.value("state", "?");
    if (st == "running" && !alive(p.value("pid", -1))) st = "gone";
    std::printf("%-16s %8d %-12s %s\n", p.value("name", "?").c_str(), p.value("pid", -1),
                p.value("host", "?").c_str(), st.c_str());
  }
  const auto& pr = j["progress"];
  if (pr.is_object()) {
    std::printf("%-16s %12s %10s %14s\n", "level", "sim time [s]", "particles", "p-steps/s");
    for (const auto& l : pr.value("levels", nlohmann::json::array()))
      std::printf("%-16s %12.4f %10d %14.3g\n", l.value("name", "?").c_str(), l.value("sim_time", 0.0),
                  l.value("particles", 0), l.value("particle_steps_per_second", 0.0));
    std::printf("interval %llu, t = %.4f of %.4g s", pr.value("interval", 0ULL), pr.value("sim_time", 0.0),
                pr.value("end_time", -1.0));
    // An ETA only while the run goes on: a finished or failed run's last progress is where it ended.
    if (running) std::printf(", ETA %s", duration(pr.value("eta_seconds", -1.0)).c_str());
    std::printf("\n");
  }
  if (j.contains("checkpoint"))
    std::printf("last consistent checkpoint: interval %d, t = %.4f s\n", j["checkpoint"].value("interval", 0),
                j["checkpoint"].value("sim_time", 0.0));
  return 0;
}

int print_status_all(const fs::path& runs_dir) {
  std::vector<fs::path> dirs;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(runs_dir, ec))
    if (fs::exists(e.path() / "status.json")) dirs.push_back(e.path());
  std::sort(dirs.begin(), dirs.end());
  if (dirs.empty()) {
    std::printf("no multi-level runs under %s\n", runs_dir.c_str());
    return 0;
  }
  for (const auto& d : dirs) {
    const auto j = read_json_or_null(d / "status.json");
    if (!j.is_object()) continue;
    std::string state = j.value("state", "?");
    if (!alive(j.value("launcher_pid", -1)) && (state == "running" || state == "stopping" || state == "restarting"))
      state += " (launcher gone)";
    const auto& pr = j["progress"];
    std::printf("%-40s %-24s", d.filename().c_str(), state.c_str());
    if (pr.is_object())
      std::printf(" t = %.4f / %.4g s, ETA %s", pr.value("sim_time", 0.0), pr.value("end_time", -1.0),
                  duration(pr.value("eta_seconds", -1.0)).c_str());
    std::printf("\n");
  }
  return 0;
}

}  // namespace mlcg::launcher
