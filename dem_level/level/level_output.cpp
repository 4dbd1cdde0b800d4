// What a level reports: the run loop with progress lines, time series,
// probe files, snapshots, grid series and summary.json. Every file is written
// under a temporary name and renamed.
#include <chrono>
#include <cmath>
#include <cstdio>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "core/huge_pages.hpp"
#include "io/atomic_file.hpp"
#include "io/grid_series.hpp"
#include "io/snapshot_series.hpp"
#include "level/level.hpp"
#include "level/phase_timer.hpp"

namespace mlcg {

namespace {
std::string human_duration(double s) {
  if (!std::isfinite(s) || s < 0) return "?";
  if (s < 60) return fmt::format("{:.0f} s", s);
  if (s < 3600) return fmt::format("{:.0f} min {:02.0f} s", std::floor(s / 60), std::fmod(s, 60));
  return fmt::format("{:.0f} h {:02.0f} min", std::floor(s / 3600), std::fmod(s, 3600) / 60);
}
// summary.json's entry of each probe: its window, mean, spread and the mean's interval.
nlohmann::json probe_entries(const std::vector<MassFlowProbe>& all) {
  using nlohmann::json;
  json probes = json::array();
  for (const auto& pr : all) {
    const auto w = pr.window_stats();
    json q;
    q["name"] = pr.params().name;
    q["file"] = "probes/" + pr.params().name + ".csv";
    q["window"] = pr.params().window_known ? json::array({pr.params().window_start, pr.params().window_end}) : json();
    q["samples_in_window"] = w.samples;
    q["mean_kg_per_s"] = w.mean;
    q["std_kg_per_s"] = w.stddev;
    // The samples are autocorrelated: the half-width comes from batch means, not std / sqrt(n).
    const bool has_ci = std::isfinite(w.ci.ci95);
    q["ci95_kg_per_s"] = has_ci ? json(w.ci.ci95) : json();
    q["ci_method"] = has_ci ? w.ci.method() : "fewer than 2 samples in the window";
    q["effective_samples"] = has_ci ? json(w.ci.effective_samples) : json();
    q["ci_batch_lag1"] = has_ci ? json(w.ci.lag1) : json();  // above 0.1: batches too short, interval too narrow
    q["total_mass_kg"] = pr.state().total_mass;
    probes.push_back(q);
  }
  return probes;
}

constexpr const char* kSeriesHeader =
    "t,particles,kinetic_energy_J,pair_contacts,wall_contacts,requested,inserted,removed,failed,pending,rebuilds\n";
}  // namespace

RunStatus Level::run() {
  out_.wall_start = wall_seconds();
  const double half = 0.5 * physics_.dt;
  if (opt_.restart.empty()) {
    const auto& o = cs_.output;
    run_.next_stats = o.stats_interval;
    run_.next_snapshot = o.snapshot_interval;
    run_.next_checkpoint = o.checkpoint_interval;
    out_.series_rows.push_back(series_row());
  }
  if (run_.end_time >= 0.0)
    log_->info("running to t = {:.4g} s ({} steps)", run_.end_time, std::llround(run_.end_time / physics_.dt));
  else log_->info("running until event '{}' + {} s", cs_.time.end_event, cs_.time.end_plus);

  RunStatus status = RunStatus::Completed;
  std::string reason;
  bool output_failed = false;
  try {
    while (true) {
      // A coupled level ends with an interval, the same one on every level (whatever its dt): one cut short has
      // received and inserted the coupler's particles but never reports them, and the coupler would take them back.
      if (run_.end_time >= 0.0 && (coupled_ ? coupling_reached(run_.end_time) : time() >= run_.end_time - half)) break;
      if (comm_.any(stopping())) {
        status = RunStatus::Interrupted;
        reason = "interrupted by a signal";
        break;
      }
      if (opt_.max_steps >= 0 && steps_this_process_ >= opt_.max_steps) {
        status = RunStatus::StepLimit;
        break;
      }
      if (coupled_ && coupling_finished()) {
        if (!coupling_stop_reason().empty()) {
          status = RunStatus::Interrupted;
          reason = coupling_stop_reason();
        }
        break;
      }
      step(true);
      progress(false);
    }
    settle_kick();
  } catch (const GuardStop& e) {
    pay_owed_kick();  // the state at the stop is the whole step's
    status = RunStatus::Failed;
    reason = e.what();
    log_->error("STOPPED: {}", reason);
    if (!opt_.out_dir.empty()) try {
      write_checkpoint(opt_.out_dir / "checkpoint_failed.h5");
      log_->error("state at the stop written to {}", (opt_.out_dir / "checkpoint_failed.h5").string());
    } catch (const OutputStop& w) {
      log_->error("the state at the stop could not be written: {}", w.what());
    }
  } catch (const StopRequested& e) {
    pay_owed_kick();
    status = RunStatus::Interrupted;
    reason = e.what();
    log_->warn("{}", reason);
    if (opt_.quiet && comm_.rank() == 0) std::fprintf(stderr, "dem_level: %s\n", reason.c_str());  // not in the log alone
  } catch (const CouplingStop& e) {  // the last checkpoint stays
    pay_owed_kick();
    status = RunStatus::Failed;
    reason = e.what();
    log_->error("STOPPED: {}", reason);
  } catch (const OutputStop& e) {  // the last checkpoint stays
    pay_owed_kick();
    status = RunStatus::Failed;
    reason = std::string("cannot write the run's output: ") + e.what();
    output_failed = true;
  }
  finish_run(status, reason, output_failed);
  return status;
}

void Level::finish_run(RunStatus status, const std::string& reason, bool output_failed) {
  if (coupled_) coupling_bye(status, reason);
  if (status == RunStatus::Completed)
    for (auto& in : scene_.ins) in.abandon_pending();
  progress(true);
  try {
    if (output_failed) {  // nothing more but the summary: every further file would fail the same way
      log_->error("STOPPED: {}; earlier files and checkpoints are intact", reason);
      log_->flush();
    } else {
      // Timed as output, so that the summary's time stepping excludes the final files (a million
      // particles' checkpoint takes seconds).
      PhaseTimer t(out_.times.output);
      write_outputs(true);
      if (!opt_.out_dir.empty() && status != RunStatus::Failed) write_checkpoint(opt_.out_dir / "checkpoint.h5");
    }
    write_summary(to_string(status), reason);
  } catch (const OutputStop& e) {
    log_->error("cannot write the run's output: {}", e.what());
    status = RunStatus::Failed;
  }
  // The log file may be on the full disk too, and a quiet level has no console: stderr always tells.
  if (status == RunStatus::Failed && comm_.rank() == 0 && (output_failed || !out_.output_error.empty()))
    std::fprintf(stderr, "dem_level: level '%s' failed: %s%s\n", lvl_.name.c_str(), reason.c_str(),
                 out_.output_error.empty() || reason.find(out_.output_error) != std::string::npos
                     ? ""
                     : ("; and " + out_.output_error).c_str());
  const auto b = mass_balance();
  log_->info("{}: t = {:.4f} s, {} steps, {} particles present, {} removed, {} failed to place", to_string(status),
             time(), run_.step, b.present, b.removed, b.failed);
  for (const auto& pr : scene_.probes) {
    const auto w = pr.window_stats();
    if (w.samples > 0)
      log_->info("probe '{}': mass flow {:.4g} +- {:.2g} kg/s over {} samples; mean's 95 % CI +- {:.2g} kg/s ({})",
                 pr.params().name, w.mean, w.stddev, w.samples, w.ci.ci95, w.ci.method());
    if (w.samples > 1 && w.ci.lag1 > stats::kLag1Limit)
      log_->warn("probe '{}': the batch means are still correlated (lag 1: {:.2f}), so the interval is likely too "
                 "narrow; a longer window gives room for longer batches", pr.params().name, w.ci.lag1);
  }
}

void Level::rank0_output(const std::function<void()>& write) const {
  try {
    write();
  } catch (const std::exception& e) {
    if (out_.output_error.empty()) out_.output_error = e.what();
  }
}

void Level::sync_output() const {
  if (!comm_.any(!out_.output_error.empty())) return;
  throw OutputStop(comm_.serial() ? out_.output_error : comm_.bcast(out_.output_error, 0));
}

void Level::sample_energy() {
  // The account measures between steps with current lists; a pending rebuild (a test moved
  // particles) would change the run, so the sample waits a step.
  if (!account_ || !account_->due(run_.step) || comm_.any(stepper_.rebuild_pending)) return;
  account_->sample(run_.step, time(), energy(), comm_);
}

void Level::after_step() {
  const double t = time();
  const double half = 0.5 * physics_.dt;
  const auto& o = cs_.output;
  const bool stats_due = o.stats_interval > 0.0 && t >= run_.next_stats - half;
  const bool snapshot_due = o.snapshot_interval > 0.0 && t >= run_.next_snapshot - half;
  const bool checkpoint_due = o.checkpoint_interval > 0.0 && t >= run_.next_checkpoint - half;
  // Every reader of the velocities below settles an owed kick first (grid samples read them too).
  bool reads = stats_due || snapshot_due || checkpoint_due;
  for (const auto& g : scene_.grids) reads = reads || run_.step % g.sample_every == 0;
  if (reads) settle_kick();
  bool grid_output = false;
  if (account_) {
    PhaseTimer measure(out_.times.measure);
    sample_energy();
  }
  {
    PhaseTimer measure(out_.times.measure);
    for (auto& pr : scene_.probes)
      if (pr.sample_due(t)) pr.close_sample(t, comm_.sum(pr.open_mass()));
    for (auto& g : scene_.grids) {
      if (run_.step % g.sample_every == 0) {
        g.grid.local_sample(state_.p, state_.stress6, g.sums, g.maxs);
        comm_.sum_in_place(g.sums.data(), g.sums.size());
        comm_.max_in_place(g.maxs.data(), g.maxs.size());
        g.grid.add_sample(g.sums, g.maxs);
      }
      if (t >= g.next_output - half) {
        const GridAverages a = g.grid.take_averages();
        if (g.series)
          rank0_output([&] { g.series->write(t, a.volume_fraction, a.mean_velocity, a.max_speed, a.stress6, a.count); });
        grid_output = true;
        g.next_output += g.output_interval;
        ++g.outputs;
      }
    }
  }
  PhaseTimer output(out_.times.output);
  if (grid_output) sync_output();
  if (stats_due) {
    out_.series_rows.push_back(series_row());
    run_.next_stats += o.stats_interval;
  }
  if (snapshot_due) {
    write_snapshot();
    ++run_.snapshots;
    run_.next_snapshot += o.snapshot_interval;
  }
  if (checkpoint_due) {
    run_.next_checkpoint += o.checkpoint_interval;
    if (!opt_.out_dir.empty()) {
      write_checkpoint(opt_.out_dir / "checkpoint.h5");
      write_outputs(false);
      write_summary("running", "");
    }
    // The restarted run rebuilds its lists at the next step; so does this one,
    // which keeps both bit-identical.
    stepper_.rebuild_pending = true;
  }
}

std::string Level::series_row() const {
  const auto b = mass_balance();
  int64_t contacts[2] = {stepper_.fctx.stats.pair_contacts, stepper_.fctx.stats.wall_contacts};
  comm_.sum_in_place(contacts, 2);
  return fmt::format("{:.6f},{},{:.9g},{},{},{},{},{},{},{},{}", time(), b.present, kinetic_energy(), contacts[0],
                     contacts[1], b.requested, b.inserted, b.removed, b.failed, b.pending, run_.rebuilds);
}

void Level::write_snapshot() {
  // Gathered on rank 0 in rank order.
  std::vector<char> buf;
  ByteWriter w(buf);
  const Particles& p = state_.p;
  for (size_t i = 0; i < p.n_local(); ++i) {
    w.put(p.x[i]); w.put(p.v[i]); w.put(p.omega[i]); w.put(p.radius[i]); w.put(p.id[i]);
  }
  const auto all = comm_.gather0(buf);
  if (out_.snaps) rank0_output([&] { write_snapshot_file(all); });
  sync_output();
}

void Level::write_snapshot_file(const std::vector<char>& all) {
  std::vector<Vec3> x, v, om;
  std::vector<double> r;
  std::vector<int64_t> id;
  ByteReader rd(all);
  while (!rd.done()) {
    x.push_back(rd.get<Vec3>()); v.push_back(rd.get<Vec3>()); om.push_back(rd.get<Vec3>());
    r.push_back(rd.get<double>()); id.push_back(rd.get<int64_t>());
  }
  out_.snaps->write(time(), run_.step, x.size(), x.data(), v.data(), om.data(), r.data(), id.data());
}

void Level::write_outputs(bool final) {
  if (opt_.out_dir.empty()) return;
  const bool need_final_snapshot = comm_.rank() != 0 || !out_.snaps || out_.snaps->entries().empty() ||
                                   out_.snaps->entries().back().time < time();
  if (final && comm_.any(comm_.rank() == 0 && need_final_snapshot)) write_snapshot();
  // The file ends with the state at the end of this process (replacing a row of
  // the same time); that row is not part of the checkpointed series.
  std::vector<std::string> rows = out_.series_rows;
  const std::string last = final ? series_row() : std::string();
  if (comm_.rank() == 0) rank0_output([&] { write_series_files(rows, last, final); });
  sync_output();
}

void Level::write_series_files(std::vector<std::string> rows, const std::string& last, bool final) const {
  if (final) {
    const auto stamp = [](const std::string& r) { return r.substr(0, r.find(',')); };
    if (!rows.empty() && stamp(rows.back()) == stamp(last)) rows.back() = last;
    else rows.push_back(last);
  }
  std::string csv = kSeriesHeader;
  for (const auto& r : rows) csv += r + "\n";
  io::write_file_atomic(opt_.out_dir / "series.csv", csv);
  if (account_) io::write_file_atomic(opt_.out_dir / "energy.csv", account_->csv());
  for (const auto& pr : scene_.probes)
    io::write_file_atomic(opt_.out_dir / "probes" / (pr.params().name + ".csv"), pr.csv());
}

namespace {
// The pair kernel's variants as shares of the (rank-)steps that listed pairs: a level of one size runs
// the kernel that holds radius and mass as loop invariants; a mixed one shows why it runs slower.
nlohmann::json pair_kernel_json(const double* sums) {
  const double total = sums[23] + sums[24] + sums[25];
  const auto share = [&](double s) { return total > 0.0 ? s / total : 0.0; };
  return {{"one_size", share(sums[25])}, {"one_material", share(sums[24])}, {"mixed", share(sums[23])}};
}
}  // namespace

void Level::write_summary(const std::string& status, const std::string& reason) const {
  if (opt_.out_dir.empty()) return;
  // Collective part first: every rank contributes, rank 0 writes.
  const auto b = mass_balance();
  const PhaseTimes& pt = out_.times;
  const CouplingTimes& ct = pt.coupling;
  double sums[26] = {pt.integrate, pt.neighbor, pt.force, pt.comm, pt.measure, pt.insert, pt.output,
                     static_cast<double>(state_.nl.pairs()), static_cast<double>(memory_bytes()),
                     static_cast<double>(state_.p.n_local()), ct.total(), pt.coupling_wait, ct.insert,
                     ct.crossings, ct.controller, ct.samples, ct.statistics, ct.send, pt.force_sample_steps,
                     pt.sample_steps, static_cast<double>(steps_this_process_), pt.insert_rebuilds, pt.insert_rebuild_seconds,
                     pt.pair_kernel_steps[0], pt.pair_kernel_steps[1], pt.pair_kernel_steps[2]};
  comm_.sum_in_place(sums, 26);
  const CouplingReport cr = coupling_report();
  if (comm_.rank() == 0) rank0_output([&] { write_summary_file(status, reason, b, sums, cr); });
  sync_output();
}

namespace {

// energy.csv in short for summary.json: the largest unexplained gain, and the scale it is judged against.
nlohmann::json energy_summary(const EnergyTotals& e) {
  return {{"samples", e.samples},
          {"start_J", e.start},
          {"controller_work_J", e.controller_work},
          {"inserted_J", e.inserted},
          {"removed_J", e.removed},
          {"wall_work_J", e.wall_work},
          {"max_gain_J", e.max_gain},
          {"max_gain_time", e.max_gain_time},
          {"max_rise_J", e.max_rise},
          {"max_rise_time", e.max_rise_time},
          {"end_gain_J", e.end_gain},
          {"in_motion_J", e.in_motion},
          {"max_gain_of_in_motion", e.in_motion > 0.0 ? e.max_gain / e.in_motion : 0.0},
          {"max_rise_of_in_motion", e.in_motion > 0.0 ? e.max_rise / e.in_motion : 0.0}};
}

// performance.coupling_parts: the coupling seconds in parts (summing to performance.seconds.coupling), and
// what the stress-accumulating kernel costs on the steps that sample cells, over the other steps' force time.
nlohmann::json coupling_parts_json(const double* sums, double nr) {
  const double n_sample = sums[19] / nr, n_other = sums[20] / nr - n_sample;
  const double f_sample = sums[18] / nr, f_other = sums[2] / nr - f_sample;
  const double extra = n_sample > 0.0 && n_other > 0.0 ? f_sample - n_sample * (f_other / n_other) : 0.0;
  return {{"insert", sums[12] / nr},           {"crossings", sums[13] / nr},
          {"controller", sums[14] / nr},       {"samples", sums[15] / nr},
          {"statistics", sums[16] / nr},       {"send", sums[17] / nr},
          {"sample_steps", n_sample},          {"force_on_sample_steps", f_sample},
          {"stress_kernel_extra", extra},      {"insertion_rebuilds", sums[21] / nr},
          {"insertion_rebuild_seconds", sums[22] / nr}};
}

}  // namespace

void Level::write_summary_file(const std::string& status, const std::string& reason, const MassBalance& b,
                               const double* sums, const CouplingReport& cr) const {
  using nlohmann::json;
  const double nr = static_cast<double>(comm_.size());
  const double wall = run_.wall_seconds_before + (wall_seconds() - out_.wall_start);
  json j;
  j["status"] = status;
  j["reason"] = reason;
  j["case"] = cs_.path;
  j["title"] = cs_.title;
  j["wall_seconds"] = wall;
  j["simulated_time"] = time();
  j["steps"] = run_.step;
  j["end_time"] = run_.end_time;
  json lv;
  lv["name"] = lvl_.name;
  lv["alpha"] = physics_.alpha;
  lv["dt"] = physics_.dt;
  lv["ranks"] = lvl_.ranks;
  lv["particles_max"] = run_.max_particles;
  lv["particles_final"] = b.present;
  lv["particle_steps"] = run_.particle_steps;
  lv["particle_steps_per_second"] = wall > 0.0 ? static_cast<double>(run_.particle_steps) / wall : 0.0;
  lv["neighbour_rebuilds"] = run_.rebuilds;
  lv["skin"] = stepper_.skin;
  lv["rayleigh_time"] = physics_.stab.rayleigh_time;
  lv["hertz_contact_time"] = physics_.stab.contact_time;
  lv["impact_speed"] = physics_.stab.impact_speed;
  lv["steps_per_contact"] = physics_.stab.steps_per_contact;
  lv["dt_guard_overridden"] = physics_.stab.overridden;
  // Where the time went (mean over ranks), and what the neighbour search and memory look like now.
  const double n_now = std::max(1.0, sums[9]);
  lv["performance"] = {
      {"seconds", {{"integrate", sums[0] / nr}, {"neighbor", sums[1] / nr}, {"force", sums[2] / nr},
                   {"comm", sums[3] / nr}, {"measure", sums[4] / nr}, {"insert", sums[5] / nr},
                   {"output", sums[6] / nr}, {"coupling", sums[10] / nr}, {"coupling_wait", sums[11] / nr}}},
      {"coupling_parts", coupling_parts_json(sums, nr)},
      {"rebuilds_per_1000_steps",
       run_.step > 0 ? 1000.0 * static_cast<double>(run_.rebuilds) / static_cast<double>(run_.step) : 0.0},
      {"neighbour_pairs_per_particle", sums[7] / n_now},
      {"bytes_per_particle", sums[8] / n_now},
      {"ranks", comm_.size()},
      {"integration",
       {{"kick", kick_.started() ? kick_.name() : "split"},
        {"chosen_by", kick_.started() ? kick_.chosen_by() : "the scene (velocities read between steps)"},
        {"split_seconds", kick_.split_seconds()},
        {"fused_seconds", kick_.fused_seconds()}}},
      {"pair_kernel", pair_kernel_json(sums)},
      {"memory_pages", huge_pages_state().empty() ? "the system allocator's" : huge_pages_state()}};
  if (coupled_)
    lv["coupling"] = {{"intervals", cr.intervals}, {"inserted_from_coupler", cr.inserted},
                      {"largest_insert_overlap_of_diameter", cr.worst_insert_overlap},
                      {"largest_insert_wall_overlap_of_diameter", cr.worst_insert_wall_overlap},
                      {"inserted_outside_walls", cr.inserted_outside_walls}};
  if (account_) lv["energy"] = energy_summary(account_->totals());
  j["levels"] = json::array({lv});
  j["probes"] = probe_entries(scene_.probes);
  j["mass_balance"] = {{"requested", b.requested},       {"inserted", b.inserted},
                       {"present", b.present},           {"removed", b.removed},
                       {"failed_to_place", b.failed},    {"pending", b.pending},
                       {"inserted_mass_kg", b.inserted_mass}, {"present_mass_kg", b.present_mass},
                       {"removed_mass_kg", b.removed_mass},   {"failed_mass_kg", b.failed_mass}};
  for (int e = 0; e < kExits; ++e)
    j["mass_balance"]["removed_by"][to_string(static_cast<Exit>(e))] = {{"count", b.removed_by[e]},
                                                                         {"mass_kg", b.removed_mass_by[e]}};
  json ev = json::array();
  for (size_t e = 0; e < scene_.events.size(); ++e)
    ev.push_back({{"name", cs_.events[e].name},
                  {"fired", scene_.events[e].fired},
                  {"time", scene_.events[e].fired ? json(scene_.events[e].fired_at) : json()}});
  j["events"] = ev;
  io::write_file_atomic(opt_.out_dir / "summary.json", j.dump(2) + "\n");
}

void Level::progress(bool force) {
  if (opt_.quiet || comm_.rank() != 0) return;
  const double now = wall_seconds();
  if (!force && now - out_.last_progress < cs_.time.progress_interval) return;
  const double wall = now - out_.wall_start;
  const double t = time(), end = run_.end_time;
  const double rate = wall > 0.0 ? static_cast<double>(run_.particle_steps) / (wall + run_.wall_seconds_before) : 0.0;
  // ETA from the simulated-time speed of the last interval.
  std::string eta = "ETA ?";
  if (end >= 0.0 && t >= end - 0.5 * physics_.dt) {
    eta = "done";
  } else if (end >= 0.0 && out_.last_progress > -1e299 && now > out_.last_progress && t > out_.last_progress_t) {
    const double speed = (t - out_.last_progress_t) / (now - out_.last_progress);
    eta = "ETA " + human_duration((end - t) / speed);
  } else if (end < 0.0) {
    eta = fmt::format("end: event '{}' + {} s", cs_.time.end_event, cs_.time.end_plus);
  }
  log_->info("t = {:.4f} s{} | {} particles | {:.3g} particle-steps/s | {}", t,
             end >= 0.0 ? fmt::format(" / {:.4f} s ({:.0f} %)", end, 100.0 * t / end) : "",
             stepper_.global_particles, rate, eta);
  out_.last_progress_t = t;
  out_.last_progress = now;
}

}  // namespace mlcg
