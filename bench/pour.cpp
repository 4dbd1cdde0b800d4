#include "pour.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <fmt/format.h>

#include "bed.hpp"

namespace mlcg::bench {

namespace fs = std::filesystem;

namespace {

// One run on `ranks` ranks (repeat `rep`); its metrics, or an error in m.error.
RunMetrics measure_once(const BenchParams& p, const PourOptions& o, int ranks, int rep, long steps) {
  const fs::path dir = o.work / "runs" / "pour";
  const fs::path case_file = dir / fmt::format("mlcg_r{}.toml", ranks);
  if (rep == 1) write_text(case_file, pour_case(p, o.files, ranks));
  std::fputs(fmt::format("pour: {} rank{}, repeat {}/{} ... ", ranks, ranks > 1 ? "s" : "", rep, o.repeat).c_str(),
             stdout);
  std::fflush(stdout);
  RunMetrics m = run_mlcg(o.dem_level, o.mpirun, ranks, case_file, dir / fmt::format("mlcg_r{}_{}", ranks, rep),
                          Count::Grows);
  if (!m.ok) {
    say("unavailable: " + m.error);
    return m;
  }
  m.warnings = pour_problems(m, steps);
  say(fmt::format("{:.1f} s, {:.3g} particle-steps/s per core, {} particles, rebuilds {} of the time; other processes "
                  "kept {} core(s) busy",
                  m.loop_seconds, m.rate / ranks, m.particles_end, fmt_pct(m.share[1]),
                  fmt_num(m.background_cores, "{:.2f}")));
  return m;
}

void print_table(const BenchParams& p, const PourOptions& o, const PourRows& rows, long steps) {
  say("");
  say(fmt::format("== pour: the empty silo (lid closed) filled close above the heap at {:g} particles/s for {:g} s "
                  "({} steps of {:g} s, skin {} mm), MLCG only | median of {} ==",
                  p.pour_rate, p.pour_time, steps, p.dt, p.skin * 1e3, o.repeat));
  const std::string head = fmt::format("{:>6}{:>14}{:>8}{:>8}{:>10}{:>8}{:>11}{:>11}", "ranks", "per core", "spread",
                                       "busy", "neighbor", "insert", "particles", "rebuild/k");
  say(head);
  say(std::string(head.size(), '-'));
  for (const auto& [r, row] : rows)
    say(row.error.empty()
            ? fmt::format("{:>6}{:>14}{:>8}{:>8}{:>10}{:>8}{:>11}{:>11}", r, fmt_num(row.per_core, "{:.3g}"),
                          fmt_pct(row.spread), fmt_num(row.busy, "{:.2f}"), fmt_pct(row.rebuild_share),
                          fmt_pct(row.insert_share), row.particles_end,
                          fmt_num(row.rebuilds_per_1000, "{:.2f}"))
            : fmt::format("{:>6}  unavailable: {}", r, row.error));
  say("time breakdown of the median run:");
  for (const auto& [r, row] : rows)
    if (row.error.empty()) say(fmt::format("  {} rank{}: {}", r, r > 1 ? "s" : "", row.breakdown));
  say("Columns: per core = particle-steps/s per core (summary.json particle_steps, the sum of the particles present "
      "at each step, / the time-stepping wall time / ranks); spread and busy as in the silo tables; neighbor and "
      "insert = summary.json's \"neighbor\" (binning + list builds) and \"insert\" seconds / the time-stepping time; "
      "particles = present at the end; rebuild/k = neighbour-list builds per 1000 steps.");
}

}  // namespace

std::vector<std::string> pour_problems(const RunMetrics& m, long steps) {
  std::vector<std::string> out = m.warnings;
  // The silo is closed: every particle inserted must still be there.
  if (m.particles_end != m.inserted)
    out.push_back(fmt::format("{} particles at the end, but {} inserted: some left the closed silo", m.particles_end,
                              m.inserted));
  if (m.failed_to_place > 0)
    out.push_back(fmt::format("{} particles found no place (the insertion could not keep the rate)",
                              m.failed_to_place));
  if (m.steps != steps) out.push_back(fmt::format("ran {} steps, not {}", m.steps, steps));
  return out;
}

PourRow summarise_pour(const std::vector<RunMetrics>& runs) {
  PourRow row;
  if (runs.empty()) {
    row.error = "not run";
    return row;
  }
  auto med = [&](auto f) { return median_of(runs, f); };
  const double rate = med([](const RunMetrics& m) { return m.rate / m.ranks; });
  const RunMetrics* mid = &median_run(runs);
  row.per_core = rate;
  row.spread = rate_spread(runs);
  row.busy = med([](const RunMetrics& m) { return m.background_cores; });
  row.rebuild_share = med([](const RunMetrics& m) { return m.share[1]; });
  row.insert_share = med([](const RunMetrics& m) { return m.insert_share; });
  row.rebuilds_per_1000 = med([](const RunMetrics& m) { return m.rebuilds_per_1000; });
  row.particles_end = mid->particles_end;
  row.breakdown = fmt::format("{}; inserted {}, failed to place {}", mid->breakdown, mid->inserted,
                              mid->failed_to_place);
  return row;
}

PourRows run_pour(const BenchParams& p, const PourOptions& o) {
  fs::create_directories(o.work / "runs" / "pour");
  const long steps = std::lround(p.pour_time / p.dt);
  std::map<int, std::vector<RunMetrics>> runs;
  std::map<int, std::string> errors;
  // Repeats in rounds over the rank counts, as the sweep: a drift of the machine's speed then slows
  // every rank count alike.
  for (int rep = 1; rep <= o.repeat; ++rep)
    for (int r : o.ranks) {
      if (r > 1 && o.mpirun.empty()) errors[r] = "mpirun not found";
      if (errors.count(r)) continue;
      RunMetrics m = measure_once(p, o, r, rep, steps);
      if (m.ok) runs[r].push_back(std::move(m));
      else errors[r] = m.error;
    }
  PourRows rows;
  std::vector<std::string> problems;
  for (int r : o.ranks) {
    if (errors.count(r)) {
      rows[r].error = errors[r];
      continue;
    }
    rows[r] = summarise_pour(runs[r]);
    for (const auto& m : runs[r])
      for (const auto& w : m.warnings) {
        const std::string s = fmt::format("pour {} rank(s): {}", r, w);
        if (std::find(problems.begin(), problems.end(), s) == problems.end()) problems.push_back(s);
      }
  }
  print_table(p, o, rows, steps);
  if (!problems.empty()) {
    say("Warnings:");
    for (const auto& s : problems) say("  " + s);
  }
  return rows;
}

std::string pour_line(const PourRows& rows, const std::vector<int>& ranks) {
  std::string rates, shares;
  for (int r : ranks) {
    const auto it = rows.find(r);
    const bool ok = it != rows.end() && it->second.error.empty();
    const double rate = ok ? it->second.per_core : kNaN, share = ok ? it->second.rebuild_share : kNaN;
    rates += fmt::format(" rank{}={}", r, std::isnan(rate) ? "na" : fmt::format("{:.4g}", rate));
    shares += fmt::format(" rebuild_share{}={}", r, std::isnan(share) ? "na" : fmt::format("{:.3f}", share));
  }
  return "pour" + rates + shares;
}

}  // namespace mlcg::bench
