#include "run/hierarchy.hpp"

#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "io/atomic_file.hpp"
#include "bus/case_hash.hpp"
#include "config/case_parser.hpp"
#include "config/regions.hpp"
#include "run/checkpoints.hpp"
#include "process/process.hpp"
#include "run/run_folder.hpp"
#include "run/status.hpp"
#include "run/supervise.hpp"
#include "run/swap.hpp"

namespace fs = std::filesystem;

namespace mlcg::launcher {
namespace {

// ipc:// paths must stay under ~107 characters; fall back to /tmp.
std::string bus_endpoint(const fs::path& run_dir) {
  const std::string p = (fs::absolute(run_dir) / "bus.ipc").string();
  if (p.size() < 100) return "ipc://" + p;
  return fmt::format("ipc:///tmp/mlcg-bus-{}.ipc", getpid());
}

// The level with the smallest alpha: its data are the best resolved.
size_t finest_level(const config::CaseSpec& cs) {
  size_t finest = 0;
  for (size_t l = 0; l < cs.levels.size(); ++l)
    if (cs.levels[l].alpha < cs.levels[finest].alpha) finest = l;
  return finest;
}

// A summary the process may not have written (it failed): an empty object reads as "missing".
nlohmann::json read_json(const fs::path& p) {
  auto j = read_json_or_null(p);
  return j.is_object() ? j : nlohmann::json::object();
}

// Each probe's entry from the finest level whose region holds it (config/regions.hpp): a fine level removes
// its particles where they leave its region, so it cannot see a probe outside; `level` says which, and
// `resolved` whether that is a finest level.
nlohmann::json resolved_probes(const config::CaseSpec& cs, const fs::path& run_dir) {
  double finest = cs.levels.front().alpha;
  for (const auto& l : cs.levels) finest = std::min(finest, l.alpha);
  std::map<size_t, nlohmann::json> summaries;
  auto out = nlohmann::json::array();
  for (const auto& p : cs.probes) {
    const size_t l = config::resolving_level(cs, p.point);
    if (!summaries.count(l)) summaries[l] = read_json(run_dir / "levels" / cs.levels[l].name / "summary.json");
    nlohmann::json e = {{"name", p.name}};
    for (const auto& q : summaries[l].value("probes", nlohmann::json::array()))
      if (q.value("name", "") == p.name) e = q;
    e["level"] = cs.levels[l].name;
    e["resolved"] = cs.levels[l].alpha <= finest;
    out.push_back(e);
  }
  return out;
}

// One summary over the hierarchy: every level's entry, each probe from the level that resolves it
// (data at the highest resolution available), overall status.
void write_summary(const config::CaseSpec& cs, const fs::path& run_dir, const Outcome& r, int attempts) {
  nlohmann::json s;
  s["case"] = cs.path;
  s["title"] = cs.title;
  s["status"] = r.exit_code == 0 ? "completed" : (r.interrupted ? "interrupted" : "failed");
  s["reason"] = r.failed;
  s["attempts"] = attempts;
  try {
    if (const auto m = read_manifest(run_dir)) {
      s["checkpoint"] = {{"interval", m->interval}, {"sim_time", m->sim_time},
                         {"manifest", (run_dir / "checkpoints" / "manifest.json").string()}};
      if (const std::string damage = damage_of(*m); !damage.empty())
        s["checkpoint"]["damaged"] = damaged_set_advice(*m, damage, run_dir);
    }
  } catch (const std::exception& e) {
    s["checkpoint_error"] = e.what();
  }
  s["levels"] = nlohmann::json::array();
  double wall = 0.0;
  const size_t finest = finest_level(cs);
  for (size_t l = 0; l < cs.levels.size(); ++l) {
    const auto j = read_json(run_dir / "levels" / cs.levels[l].name / "summary.json");
    nlohmann::json e = j.contains("levels") && !j["levels"].empty() ? j["levels"][0] : nlohmann::json::object();
    e["name"] = cs.levels[l].name;
    e["wall_seconds"] = j.value("wall_seconds", 0.0);
    e["status"] = j.value("status", "missing");
    e["mass_balance"] = j.value("mass_balance", nlohmann::json::object());
    wall = std::max(wall, j.value("wall_seconds", 0.0));
    s["simulated_time"] = j.value("simulated_time", 0.0);
    s["levels"].push_back(e);
  }
  s["probes"] = resolved_probes(cs, run_dir);
  s["probes_from_level"] = s["probes"].empty() ? cs.levels[finest].name : s["probes"][0].value("level", "");
  s["wall_seconds"] = wall;
  // Coupling overhead: the largest level share of coupling work plus the coupler's busy time,
  // over the run's wall time; waiting on the coupler reported apart. The level that waited least sets the
  // pace (the others wait for it): its wait is the exchange's latency, wall time the coupling costs too.
  const auto cpl = read_json(run_dir / "coupling" / "summary.json");
  double work = 0.0, wait = 0.0, pace_wait = INFINITY;
  std::string pace;
  nlohmann::json work_parts;  // the parts of the largest level's coupling work
  for (const auto& e : s["levels"]) {
    if (!e.contains("performance")) continue;
    const auto& sec = e["performance"]["seconds"];
    if (sec.value("coupling", 0.0) >= work) {
      work = sec.value("coupling", 0.0);
      work_parts = e["performance"].value("coupling_parts", nlohmann::json::object());
      work_parts["level"] = e.value("name", "");
    }
    wait = std::max(wait, sec.value("coupling_wait", 0.0));
    if (sec.value("coupling_wait", 0.0) < pace_wait) {
      pace_wait = sec.value("coupling_wait", 0.0);
      pace = e.value("name", "");
    }
  }
  const double busy = cpl.value("coupler_busy_seconds", 0.0);
  s["coupling"] = cpl;
  s["coupling"]["overhead_share"] = wall > 0.0 ? (work + busy) / wall : 0.0;
  s["coupling"]["level_coupling_seconds_max"] = work;
  s["coupling"]["level_wait_seconds_max"] = wait;
  if (!pace.empty() && wall > 0.0) {
    auto& parts = s["coupling"]["overhead_parts"];
    parts = {{"level_coupling_share", work / wall},
             {"coupler_busy_share", busy / wall},
             {"pacing_level", pace},
             {"pacing_level_wait_share", pace_wait / wall}};
    // The largest level's work in parts, each a share of wall time: where an overhead above the goal goes.
    auto& lp = parts["level_coupling_parts"];
    lp = {{"level", work_parts.value("level", "")}};
    for (const char* k : {"insert", "crossings", "controller", "samples", "statistics", "send", "stress_kernel_extra",
                          "insertion_rebuild_seconds"})
      lp[k] = work_parts.value(k, 0.0) / wall;
    // The pacing level's wait in parts: the other levels, the coupler's response, and the rest (the bus). With
    // statistics sent early ([coupling] lead) the coupler answers while the level still steps: no such parts.
    if (cs.coupling && cs.coupling->lead == 0.0) {
      double others = 0.0;
      for (const auto& l : cpl.value("levels", nlohmann::json::array()))
        if (l.value("name", "") == pace) others = l.value("waited_for_other_levels_seconds", 0.0);
      const double response = cpl.value("coupler_response_seconds", 0.0);
      parts["pacing_level_waited_for_levels_share"] = others / wall;
      parts["coupler_response_share"] = response / wall;
      parts["bus_share"] = std::max(0.0, pace_wait - others - response) / wall;
    }
  }
  io::write_file_atomic(run_dir / "summary.json", s.dump(2) + "\n");
}

// A process's summary written by this attempt (since `start`): one of an earlier attempt that this one could not
// replace (a full disk) would name an old failure.
nlohmann::json summary_since(const fs::path& p, fs::file_time_type start) {
  std::error_code ec;
  const auto t = fs::last_write_time(p, ec);
  return !ec && t >= start ? read_json(p) : nlohmann::json::object();
}

// A level that went silent (hung, SIGSTOP) or told the coupler it failed (a signal, a full disk) is the run's
// failure, whichever process ended first: the coupler that stopped the run on its account, or a level it told
// to stop. Its pid goes into the coupler's message.
void name_failed_level(const fs::path& run_dir, fs::file_time_type start, const nlohmann::json& cpl,
                       const std::vector<Member>& members, Outcome& r) {
  std::string level = cpl.value("silent_level", "");
  if (level.empty()) level = cpl.value("failed_level", "");
  const std::string why = cpl.value("error", ""), name = "level '" + level + "'";
  if (level.empty() || why.rfind(name, 0) != 0) return;
  // Not a level the launcher itself stopped: when another level ended first on its own (killed, or refused by
  // the coupler before it wrote anything) the launcher's SIGTERM reaches the others, and one of them may tell
  // the coupler "interrupted by a signal" before the first one's end is heard there. A first level that the
  // coupler stopped ("the coupler at ... ended the run") is no such case: the coupler's level is the failure.
  const std::string prefix = "level '";
  if (r.failed_name != name && r.failed_name.rfind(prefix, 0) == 0 &&
      why.rfind(name + " failed: interrupted by a signal", 0) == 0) {
    const std::string first = r.failed_name.substr(prefix.size(), r.failed_name.size() - prefix.size() - 1);
    const auto own = summary_since(run_dir / "levels" / first / "summary.json", start);
    if (own.value("reason", "").rfind("the coupler at", 0) != 0) return;
  }
  for (const auto& m : members)
    if (m.name == name) {
      r.failed = name + " (pid " + std::to_string(m.pid) + ")" + why.substr(name.size());
      r.failed_name = name;
    }
}

// A coupler that went silent (hung, SIGSTOP) is noticed by the levels waiting on it: the first to time out
// ends first, but the coupler is the run's failure. Its pid goes into the level's message. Not when the coupler
// itself heard nothing from a level: then both were cut off from each other (a network partition), and the
// coupler, which hears every level, knows which one.
void name_silent_coupler(const fs::path& run_dir, fs::file_time_type start, const nlohmann::json& cpl,
                         const std::vector<Member>& members, Outcome& r) {
  const std::string prefix = "level '";
  if (r.failed_name.rfind(prefix, 0) != 0 || !cpl.value("silent_level", "").empty()) return;
  const std::string level = r.failed_name.substr(prefix.size(), r.failed_name.size() - prefix.size() - 1);
  const std::string why = summary_since(run_dir / "levels" / level / "summary.json", start).value("reason", "");
  if (why.rfind("no message from the coupler", 0) != 0) return;
  r.failed = "coupler (pid " + std::to_string(members.front().pid) + ") went silent: " + r.failed_name + ": " + why;
  r.failed_name = "coupler";
}

// Names the process that failed the attempt begun at `start` by what the processes recorded.
void name_failure(const fs::path& run_dir, fs::file_time_type start, const std::vector<Member>& members,
                  Outcome& r) {
  if (r.exit_code == 0 || r.interrupted) return;
  const auto cpl = summary_since(run_dir / "coupling" / "summary.json", start);
  name_failed_level(run_dir, start, cpl, members, r);
  if (r.failed_name == "coupler" && !cpl.value("error", "").empty())  // its reason (it runs --quiet)
    r.failed += ": " + cpl.value("error", "");
  name_silent_coupler(run_dir, start, cpl, members, r);
}

// The coupler's and every level's command line; from a consistent checkpoint when `from` is set.
// Where each runs and its key files come from `pl` (hosts/hosts.hpp).
std::vector<Member> members_of(const config::CaseSpec& cs, const std::string& case_file, const fs::path& run_dir,
                               const std::string& ep, const std::optional<ResumePoint>& from, const Swapper& swaps,
                               const Placement& pl) {
  const fs::path bin(own_directory());
  std::vector<Member> m;
  std::vector<std::string> coupler = pl.launch_prefix("coupler", 1);
  coupler.insert(coupler.end(), {(bin / "coupler_service").string(), case_file, "--out", run_dir.string(),
                                 "--endpoint", ep, "--quiet"});
  for (auto& a : pl.extra_args("coupler")) coupler.push_back(a);
  if (from) coupler.insert(coupler.end(), {"--resume", from->coupler.string()});
  m.push_back({"coupler", coupler});
  for (const auto& lvl : cs.levels) {
    std::vector<std::string> argv = pl.launch_prefix(lvl.name, lvl.ranks);
    argv.push_back(swaps.binary(lvl.name));
    argv.insert(argv.end(), {case_file, "--out", (run_dir / "levels" / lvl.name).string(), "--level", lvl.name,
                             "--coupler", ep, "--quiet"});
    for (auto& a : pl.extra_args(lvl.name)) argv.push_back(a);
    if (from) {
      const auto it = from->levels.find(lvl.name);
      if (it == from->levels.end())
        throw std::runtime_error("the consistent checkpoint has no file for level '" + lvl.name + "'");
      argv.insert(argv.end(), {"--restart", it->second.string()});
    }
    m.push_back({"level '" + lvl.name + "'", argv});
  }
  return m;
}

void print_end(const fs::path& run_dir, const Outcome& r) {
  const auto s = read_json(run_dir / "summary.json");
  std::printf("\n== %s: %s ==\n", run_dir.c_str(), s.value("status", "?").c_str());
  for (const auto& l : s["levels"]) {
    std::string bus;
    if (s.contains("coupling") && s["coupling"].contains("levels"))
      for (const auto& b : s["coupling"]["levels"])
        if (b.value("name", "") == l.value("name", "?"))
          bus = fmt::format("; bus {:.0f} B out, {:.0f} B in per coupling interval",
                            b.value("bytes_per_interval_from_level", 0.0), b.value("bytes_per_interval_to_level", 0.0));
    std::printf("level %s: alpha %g, up to %d particles, %.1f s wall, %.3g particle-steps/s%s\n",
                l.value("name", "?").c_str(), l.value("alpha", 0.0), l.value("particles_max", 0),
                l.value("wall_seconds", 0.0), l.value("particle_steps_per_second", 0.0), bus.c_str());
  }
  if (s.contains("coupling") && s["coupling"].contains("regions"))
    for (const auto& g : s["coupling"]["regions"])
      std::printf("coupling: %llu fine particles inserted (%.6g kg of %.6g kg crossed, %.3g kg carried); overhead "
                  "%.1f %% of wall time\n",
                  g.value("inserted_particles", 0ULL), g.value("inserted_kg", 0.0), g.value("crossed_kg", 0.0),
                  g.value("remainder_kg", 0.0), 100.0 * s["coupling"].value("overhead_share", 0.0));
  if (s.contains("coupling") && s["coupling"].contains("regions"))
    for (const auto& g : s["coupling"]["regions"])
      if (g.contains("unplaced_warning")) std::printf("warning: %s\n", g["unplaced_warning"].get<std::string>().c_str());
  if (s.contains("coupling") && s["coupling"].contains("overhead_parts")) {
    const auto& o = s["coupling"]["overhead_parts"];
    std::printf("coupling cost: levels' coupling work %.1f %% and coupler %.1f %% of wall time; level %s, which sets "
                "the pace, waited %.1f %% of it for the coupler's commands",
                100.0 * o.value("level_coupling_share", 0.0), 100.0 * o.value("coupler_busy_share", 0.0),
                o.value("pacing_level", "?").c_str(), 100.0 * o.value("pacing_level_wait_share", 0.0));
    if (o.contains("bus_share"))
      std::printf(" (other levels %.1f %%, the coupler's response %.1f %%, the bus %.1f %%)",
                  100.0 * o.value("pacing_level_waited_for_levels_share", 0.0),
                  100.0 * o.value("coupler_response_share", 0.0), 100.0 * o.value("bus_share", 0.0));
    if (o.contains("level_coupling_parts")) {
      const auto& lp = o["level_coupling_parts"];
      std::printf("; level %s's work: samples %.1f %%, controller %.1f %%, statistics %.1f %%, send %.1f %%, "
                  "insertion %.1f %%, crossings %.1f %% (the stress kernel on sample steps %.1f %% more, in force; "
                  "rebuilds at the insertions %.1f %%, in neighbor)",
                  lp.value("level", "?").c_str(), 100.0 * lp.value("samples", 0.0),
                  100.0 * lp.value("controller", 0.0), 100.0 * lp.value("statistics", 0.0),
                  100.0 * lp.value("send", 0.0), 100.0 * lp.value("insert", 0.0), 100.0 * lp.value("crossings", 0.0),
                  100.0 * lp.value("stress_kernel_extra", 0.0), 100.0 * lp.value("insertion_rebuild_seconds", 0.0));
    }
    std::printf("\n");
  }
  for (const auto& p : s["probes"])
    std::printf("probe %s (level %s%s): %s\n", p.value("name", "?").c_str(), p.value("level", "?").c_str(),
                p.value("resolved", true) ? "" : ", coarse: no fine region holds it", probe_flow_text(p).c_str());
  if (r.exit_code == 0) return;
  if (!r.failed.empty()) std::fprintf(stderr, "mlcg: %s; every other process was stopped\n", r.failed.c_str());
  if (s.contains("checkpoint") && s["checkpoint"].contains("damaged"))
    std::fprintf(stderr, "mlcg: %s\n", s["checkpoint"]["damaged"].get<std::string>().c_str());
  else if (s.contains("checkpoint"))
    std::fprintf(stderr, "mlcg: last consistent checkpoint: interval %llu (t = %.6g s), %s; continue with `mlcg "
                         "resume %s`\n", s["checkpoint"].value("interval", 0ULL), s["checkpoint"].value("sim_time", 0.0),
                 s["checkpoint"].value("manifest", "").c_str(), run_dir.c_str());
  else
    std::fprintf(stderr, "mlcg: no consistent checkpoint was written yet\n");
}

// Runs the hierarchy (restarting it per [launcher] restart_on_failure) until it completes, is
// interrupted or fails for good.
int supervise_hierarchy(const config::CaseSpec& cs, const std::string& case_file, const fs::path& run_dir, bool quiet,
                        std::optional<ResumePoint> from, Placement placement) {
  std::string ep = !cs.coupling->endpoint.empty() ? cs.coupling->endpoint : bus_endpoint(run_dir);
  ep = placement.prepare(cs, run_dir, ep);  // hosts / CURVE (hosts/hosts.hpp)
  std::printf("mlcg: case %s, %zu levels coupled over %s; run folder %s\n%s", case_file.c_str(), cs.levels.size(),
              ep.c_str(), run_dir.c_str(), placement.describe().c_str());
  for (const auto& lvl : cs.levels)
    std::printf("mlcg: level '%s' (alpha %g, dt %g s, %d rank(s))\n", lvl.name.c_str(), lvl.alpha, lvl.dt, lvl.ranks);
  StatusBoard board(run_dir, case_file, !quiet && isatty(STDOUT_FILENO));
  Swapper swaps(cs, run_dir, (fs::path(own_directory()) / "dem_level").string());
  Outcome r;
  int attempt = 0, restarts = 0;
  for (;; ++attempt) {
    if (from)
      std::printf("mlcg: continuing from the consistent checkpoint at interval %llu (t = %.6g s)\n",
                  static_cast<unsigned long long>(from->interval), from->sim_time);
    std::fflush(stdout);
    auto members = members_of(cs, case_file, run_dir, ep, from, swaps, placement);
    placement.forget_bound_endpoint();  // a restarted coupler binds afresh
    std::error_code gone;
    fs::remove(run_dir / "coupling" / "progress.json", gone);  // the previous attempt's
    SuperviseOptions so;
    so.interrupt_grace = cs.coupling->timeout + 30.0;
    so.tick = [&](const std::vector<Member>& m, const char* phase) {
      board.update(m, phase, attempt);
      swaps.poll(board.sim_time());
    };
    so.want_stop = [&] { return swaps.want_stop(); };
    so.coupler_started = [&](std::vector<Member>& m) {  // tcp://HOST:* becomes the port the coupler bound
      const std::string bound = placement.bound_endpoint(m[0].pid);
      for (size_t i = 1; i < m.size(); ++i)
        for (size_t a = 0; a + 1 < m[i].argv.size(); ++a)
          if (m[i].argv[a] == "--coupler") m[i].argv[a + 1] = bound;
    };
    const auto start = fs::file_time_type::clock::now();
    r = supervise(members, so);
    board.end_line();
    name_failure(run_dir, start, members, r);
    // A swap continues from the checkpoint the stop wrote; a swapped-in binary that failed is replaced
    // by the previous one, from the same checkpoint. Neither counts as a restart.
    const bool swapping = r.stopped_for_swap && r.failed.empty();
    const bool reverted = !swapping && r.exit_code != 0 && !r.interrupted && swaps.revert(r);
    const bool retry = !swapping && !reverted && r.exit_code != 0 && !r.interrupted &&
                       restarts < cs.launcher.restart_on_failure;
    const bool again = swapping || reverted || retry;
    board.update(members, again ? "restarting" : r.exit_code == 0 ? "completed" : r.interrupted ? "interrupted" : "failed",
                 attempt, true, r.failed);
    if (!again) break;
    try {
      from = read_manifest(run_dir);
      if (const std::string damage = from ? damage_of(*from) : ""; !damage.empty())
        throw std::runtime_error(damaged_set_advice(*from, damage, run_dir));
    } catch (const std::exception& e) {
      std::fprintf(stderr, "mlcg: cannot restart: %s\n", e.what());
      break;
    }
    if (swapping) {
      if (!from) break;  // cannot happen: the stop wrote one
      swaps.begin(from->interval);
      continue;
    }
    if (reverted) continue;
    ++restarts;
    std::fprintf(stderr, "mlcg: restarting the hierarchy (%d of %d restarts) from %s\n", restarts,
                 cs.launcher.restart_on_failure,
                 from ? fmt::format("the consistent checkpoint at interval {}", from->interval).c_str()
                      : "the beginning (no consistent checkpoint yet)");
  }
  swaps.finish(r.exit_code == 0);
  try {
    write_summary(cs, run_dir, r, attempt + 1);
  } catch (const std::exception& e) {  // a full disk: what failed must still reach the user, by stderr
    std::fprintf(stderr, "mlcg: cannot write the run's summary: %s\n", e.what());
    if (!r.failed.empty()) std::fprintf(stderr, "mlcg: %s; every other process was stopped\n", r.failed.c_str());
    std::fprintf(stderr, "mlcg: once there is room, continue with `mlcg resume %s`\n", run_dir.c_str());
    return r.exit_code != 0 ? r.exit_code : 1;
  }
  print_end(run_dir, r);
  return r.exit_code;
}

}  // namespace

int run_hierarchy(const config::CaseSpec& cs, const std::string& case_file, const std::string& out_dir, bool quiet,
                  Placement placement) {
  const fs::path run_dir(out_dir);
  write_run_info(run_dir, {fs::absolute(case_file).string()});
  return supervise_hierarchy(cs, case_file, run_dir, quiet, std::nullopt, std::move(placement));
}

int resume_hierarchy(const std::string& run_folder, bool quiet, bool previous) {
  const fs::path run_dir(run_folder);
  try {
    const RunInfo info = read_run_info(run_dir);
    const RunLock lock(run_dir);  // refuses while another launcher runs a hierarchy here
    // A completed run's results are final: resuming it would rerun its last interval and report that tail's
    // rates (a 0.1 s tail over the whole run's work gave "overhead 252 %").
    if (read_json(run_dir / "summary.json").value("status", "") == "completed")
      throw std::runtime_error(run_dir.string() + " completed (its summary.json says so): there is nothing to resume, "
                               "and its results stay as they are; to run the case again: `mlcg run " +
                               info.case_file + " --out NEW_FOLDER`");
    auto from = read_manifest(run_dir);
    if (!from)
      throw std::runtime_error(run_dir.string() + " has no consistent checkpoint (checkpoints/manifest.json); start "
                               "it again with `mlcg run`");
    if (previous) {
      if (!from->previous)
        throw std::runtime_error(run_dir.string() + " keeps no consistent set before interval " +
                                 std::to_string(from->interval) + "; resume without --previous");
      from = *from->previous;
    }
    // A damaged set is refused before anything starts, with the set to use instead.
    if (const std::string damage = damage_of(*from); !damage.empty())
      throw std::runtime_error(previous ? "the previous consistent set is damaged too: " + damage +
                                              "; start the run again with `mlcg run`"
                                        : damaged_set_advice(*from, damage, run_dir));
    const config::CaseSpec cs = config::load_case(info.case_file);
    const std::string hash = bus::case_hash_of_bytes(config::resolved_case_text(info.case_file));
    if (hash != from->case_hash)
      throw std::runtime_error(info.case_file + " changed since the checkpoint (hash " + hash +
                               ", the checkpoint's " + from->case_hash + "); a run resumes with the case it started with");
    return supervise_hierarchy(cs, info.case_file, run_dir, quiet, from, Placement{});  // resumes on this machine
  } catch (const config::CaseError& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: mlcg resume %s: %s\n", run_folder.c_str(), e.what());
    return 2;
  }
}

}  // namespace mlcg::launcher
