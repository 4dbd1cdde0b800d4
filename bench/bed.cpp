#include "bed.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include <fmt/format.h>

#include "parse.hpp"
#include "process.hpp"

namespace mlcg::bench {

namespace fs = std::filesystem;

void say(const std::string& s) {
  std::fputs(s.c_str(), stdout);
  std::fputc('\n', stdout);
  std::fflush(stdout);
}

void write_text(const fs::path& f, const std::string& text) {
  const auto tmp = fs::path(f.string() + ".tmp");
  {
    std::ofstream o(tmp);
    o << text;
    if (!o) throw std::runtime_error("cannot write " + tmp.string());
  }
  fs::rename(tmp, f);
}

std::string read_text(const fs::path& f) {
  std::ifstream in(f);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}


Bed prepare_bed(const BedRecipe& recipe, const fs::path& dir, const fs::path& dem_level, bool rebuild) {
  const fs::path bed_h5 = dir / "bed.h5", bed_json = dir / "bed.json";
  const nlohmann::json& fp = recipe.fingerprint;
  if (!rebuild && fs::exists(bed_h5) && fs::exists(bed_json)) {
    try {
      const auto j = nlohmann::json::parse(read_text(bed_json));
      if (j.at("fingerprint") == fp) {
        Bed b{read_snapshot(bed_h5), j.at("info")};
        if (b.snap.size() == static_cast<size_t>(recipe.particles)) {
          say(fmt::format("bed: cached {} ({} particles, settled at t = {:.3f} s, kept to t = {:.3f} s, top of bed "
                          "z = {:.4f} m)",
                          bed_h5.string(), b.snap.size(), b.info.value("settled_event_time", kNaN),
                          b.info.value("end_time", kNaN), b.info.value("top_z", kNaN)));
          return b;
        }
      }
      say("bed: the cached bed was made with other parameters; preparing a new one");
    } catch (const std::exception& e) {
      say(fmt::format("bed: cannot use the cached bed ({}); preparing a new one", e.what()));
    }
  }
  const fs::path run = dir / "prepare";
  fs::remove_all(run);
  const fs::path case_file = dir / "prepare.toml";
  write_text(case_file, recipe.case_text);
  say(fmt::format("bed: preparing {}; a few minutes. Log: {}", recipe.what, (dir / "prepare.log").string()));
  fs::remove(dir / "prepare.log");
  const auto r = run_process({dem_level.string(), case_file.string(), "--out", run.string()}, dir,
                             dir / "prepare.log", "  prepare | ", {""});
  if (r.exit_code != 0)
    throw std::runtime_error(fmt::format("bed preparation failed (exit code {}); see {}", r.exit_code,
                                         (dir / "prepare.log").string()));
  const auto summary = nlohmann::json::parse(read_text(run / "summary.json"));
  const auto& mb = summary.at("mass_balance");
  if (mb.at("present").get<long>() != recipe.particles || mb.at("failed_to_place").get<long>() != 0)
    throw std::runtime_error(fmt::format("bed preparation: {} particles present, {} failed to place (wanted {}); see {}",
                                         mb.at("present").get<long>(), mb.at("failed_to_place").get<long>(),
                                         recipe.particles, (run / "summary.json").string()));
  double settled_at = kNaN;
  for (const auto& e : summary.at("events"))
    if (e.at("name") == "settled" && e.at("fired").get<bool>()) settled_at = e.at("time").get<double>();
  std::vector<fs::path> snaps;
  for (const auto& e : fs::directory_iterator(run / "particles"))
    if (e.path().extension() == ".h5") snaps.push_back(e.path());
  if (snaps.empty()) throw std::runtime_error("bed preparation wrote no snapshot in " + (run / "particles").string());
  std::sort(snaps.begin(), snaps.end());
  Bed b{read_snapshot(snaps.back()), {}};
  // The bed both codes start from: the settled positions, at rest (velocities and spins set to zero).
  double v2 = 0.0, top = -1e300;
  for (size_t i = 0; i < b.snap.size(); ++i) {
    for (int k = 0; k < 3; ++k) v2 += b.snap.v[3 * i + k] * b.snap.v[3 * i + k];
    top = std::max(top, b.snap.x[3 * i + 2] + b.snap.radius[i]);
  }
  std::fill(b.snap.v.begin(), b.snap.v.end(), 0.0);
  std::fill(b.snap.w.begin(), b.snap.w.end(), 0.0);
  write_snapshot(bed_h5, b.snap);
  b.info = {{"source", snaps.back().string()},
            {"settled_event_time", settled_at},
            {"end_time", summary.value("simulated_time", kNaN)},
            {"rms_speed_before_zeroing", std::sqrt(v2 / std::max<size_t>(1, b.snap.size()))},
            {"top_z", top},
            {"prepare_wall_seconds", summary.value("wall_seconds", kNaN)}};
  write_text(bed_json, nlohmann::json{{"fingerprint", fp}, {"info", b.info}}.dump(2) + "\n");
  if (recipe.settle_speed > 0 && !(settled_at < recipe.settle_latest - 1e-9))
    say(fmt::format("bed: WARNING: the mean speed did not drop below {} m/s before t = {} s", recipe.settle_speed,
                    recipe.settle_latest));
  say(fmt::format("bed: prepared in {:.0f} s: {} particles, settled at t = {:.3f} s (RMS speed {:.2g} m/s, set to 0), "
                  "top of bed z = {:.4f} m -> {}",
                  r.wall_seconds, b.snap.size(), settled_at, b.info["rms_speed_before_zeroing"].get<double>(), top,
                  bed_h5.string()));
  return b;
}


}  // namespace mlcg::bench
