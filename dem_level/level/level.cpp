// The time loop of a level: events, insertion, velocity Verlet, neighbour
// rebuilds (with removal and spatial sorting), guards and measurements.
#include "level/level.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <csignal>
#include <cstring>
#include <limits>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "forces/integrator.hpp"
#include "parallel/exchange.hpp"
#include "level/phase_timer.hpp"

namespace mlcg {

namespace {
std::atomic<bool> g_stop{false};
extern "C" void on_signal(int) { g_stop.store(true); }
constexpr uint64_t kSortEvery = 20;  // spatial sort every this many rebuilds
}  // namespace

void install_signal_handlers() {
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
}
bool stop_requested() { return g_stop.load(); }
bool Level::stopping() const { return interrupted_ || stop_requested(); }

void Level::pre_step() {
  const double t = time();
  if (!events_.empty()) {
    PhaseTimer timer(times_.measure);
    check_events(t);
  }
  insert_due(t);
}

void Level::check_events(double t) {
  const double half = 0.5 * dt_;
  for (size_t e = 0; e < events_.size(); ++e) {
    auto& es = events_[e];
    if (es.fired) continue;
    const auto& spec = cs_.events[e];
    if (spec.at >= 0.0) {
      if (t + half >= spec.at) fire_event(e);
      continue;
    }
    if (t + half < es.next_check) continue;
    es.next_check = t + spec.check_interval;
    bool ready = true;
    if (spec.after_insertion)
      for (const auto& in : ins_) ready = ready && in.state().done;
    if (ready && spec.mean_speed_below >= 0.0) {
      double s[2] = {0.0, 0.0};  // mass, sum m v^2 over all ranks
      for (size_t i = 0; i < p_.n_local(); ++i) {
        s[0] += p_.mass[i];
        s[1] += p_.mass[i] * norm2(p_.v[i]);
      }
      comm_.sum_in_place(s, 2);
      const double rms = s[0] > 0.0 ? std::sqrt(s[1] / s[0]) : 0.0;
      ready = rms < spec.mean_speed_below;
    }
    if (ready) {
      fire_event(e);
    } else if (t + half >= spec.latest) {
      log_->warn("event '{}': its condition was not met by latest = {} s; firing anyway", spec.name, spec.latest);
      fire_event(e);
    }
  }
}

void Level::insert_due(double t) {
  PhaseTimer timer(times_.insert);
  for (auto& in : ins_) {
    if (!in.due(t, dt_)) continue;
    // Every rank computes the same batch from the same data and keeps its own particles.
    const double heap = in.follows_heap() ? comm_.max(in.heap_top(p_, norm(gravity_)))
                                          : -std::numeric_limits<double>::infinity();
    Vec3 lo, hi;
    in.batch_region(heap, lo, hi);
    std::vector<Sphere> mine;
    in.nearby(p_, lo, hi, 2.0 * r_max_, mine);
    std::vector<char> buf(reinterpret_cast<const char*>(mine.data()),
                          reinterpret_cast<const char*>(mine.data() + mine.size()));
    const std::vector<char> all = comm_.allgather(buf);
    std::vector<Sphere> obstacles(all.size() / sizeof(Sphere));
    if (!obstacles.empty()) std::memcpy(obstacles.data(), all.data(), obstacles.size() * sizeof(Sphere));
    const auto before = in.state();
    const auto rng_before = run_.rng;
    const int64_t id_before = run_.next_id;
    // One batch of a large count without a rate can take minutes: say that it moves.
    double last_line = wall_seconds();
    const auto progress = [&](int64_t tried, int64_t wanted) {
      const double now = wall_seconds();
      if (now - last_line < cs_.time.progress_interval) return;
      last_line = now;
      log_->info("insertion '{}': batch {} has tried {} of {} particles", in.params().name, before.batch + 1, tried,
                 wanted);
    };
    const auto batch = in.place_batch(obstacles, 2.0 * r_max_, lo, hi, walls_, run_.rng, run_.next_id,
                                      [this] { return stopping(); }, progress);
    // A signal reaches the ranks at different moments: all drop the batch together, and the state
    // (a checkpoint written on the way out) stays that before it.
    if (comm_.any(!batch)) {
      in.state() = before;
      run_.rng = rng_before;
      run_.next_id = id_before;
      throw StopRequested(fmt::format("interrupted by a signal during batch {} of insertion '{}' at t = {:.6g} s; "
                                      "the unfinished batch was dropped", before.batch + 1, in.params().name, t));
    }
    const auto& placed = *batch;
    if (!placed.empty()) {
      detach_ghosts();  // new local particles go before the ghosts; the rebuild restores them
      for (const auto& pi : placed)
        if (dec_.owner(pi.x) == comm_.rank()) {
          add_particle(pi);
          if (coupled_) coupling_born(p_.n_local() - 1);
        }
      rebuild_pending_ = true;
    }
    if (in.state().done && in.state().failed > 0)
      log_->warn("insertion '{}': {} particles could not be placed (region full or blocked)", in.params().name,
                 in.state().failed);
  }
}

void Level::fire_event(size_t e) {
  auto& es = events_[e];
  const auto& spec = cs_.events[e];
  es.fired = true;
  es.fired_at = time();
  for (const auto& w : spec.remove_walls) {
    walls_.set_active(static_cast<size_t>(walls_.find(w)), false);
    rebuild_pending_ = true;
  }
  log_->info("t = {:.4f} s: event '{}'{}", es.fired_at, spec.name,
             spec.remove_walls.empty() ? "" : fmt::format(" removes {}", fmt::join(spec.remove_walls, ", ")));
  for (size_t k = 0; k < probes_.size(); ++k)
    if (probe_events_[k] == spec.name) {
      auto& q = probes_[k].params();
      q.window_start = es.fired_at + cs_.probes[k].window_start;
      q.window_end = es.fired_at + cs_.probes[k].window_end;
      q.window_known = true;
    }
  resolve_end_time();
}

void Level::detach_ghosts() {
  // The lists index ghosts; before the ghosts go, the contact history moves to
  // per-particle form (the ghosts' own entries go with them).
  if (!history_loaded_) {
    if (keep_history_) {
      nl_.save_history(p_, pair_hist_);
      walls_.save_history(p_, wall_hist_);
    } else {
      pair_hist_.clear(p_.size());
      wall_hist_.clear(p_.size());
    }
    history_loaded_ = true;
  }
  p_.drop_ghosts();
  pair_hist_.truncate(p_.n_local());
  wall_hist_.truncate(p_.n_local());
}

void Level::rebuild() {
  detach_ghosts();

  if (!comm_.serial()) {
    PhaseTimer t(times_.comm);
    if (balance_ && run_.rebuilds % kSortEvery == 0 && dec_.imbalance(comm_, p_.n_local()) > 1.05)
      dec_.balance(comm_, p_.x, p_.n_local());
    migrate(comm_, dec_, p_, pair_hist_, wall_hist_);
  }

  // Removal of particles that left the domain, and a periodic spatial sort.
  const size_t n = p_.n_local();
  std::vector<int32_t> order;
  const bool sort_now = run_.rebuilds % kSortEvery == 0;
  if (sort_now) {
    CellBins bins;
    bins.build(p_.x, n, 2.0 * r_max_ + skin_);
    order = bins.sorted();
  } else {
    order.resize(n);
    for (size_t i = 0; i < n; ++i) order[i] = static_cast<int32_t>(i);
  }
  std::vector<int32_t> keep;
  keep.reserve(n);
  double gone[2 * kExits] = {};  // count, mass per exit
  for (int32_t i : order) {
    const Vec3& x = p_.x[static_cast<size_t>(i)];
    int exit = -1;
    if (x.z < dom_lo_.z) exit = static_cast<int>(Exit::Outlet);
    else if (x.x < dom_lo_.x || x.y < dom_lo_.y || x.x > dom_hi_.x || x.y > dom_hi_.y || x.z > dom_hi_.z)
      exit = static_cast<int>(Exit::Wall);
    else if (coupled_ && coupling_removes(static_cast<size_t>(i))) exit = static_cast<int>(Exit::Boundary);
    if (exit >= 0) {
      if (account_) account_->carried_out(p_, static_cast<size_t>(i));
      gone[2 * exit] += 1.0;
      gone[2 * exit + 1] += p_.mass[static_cast<size_t>(i)];
      continue;
    }
    keep.push_back(i);
  }
  if (sort_now || keep.size() != n) {
    p_.permute(keep);
    pair_hist_.permute(keep, p_.size());
    wall_hist_.permute(keep, p_.size());
  }
  {
    PhaseTimer t(times_.comm);
    double counts[2 * kExits + 1];
    std::copy(gone, gone + 2 * kExits, counts);
    counts[2 * kExits] = static_cast<double>(p_.n_local());
    comm_.sum_in_place(counts, 2 * kExits + 1);
    for (int e = 0; e < kExits; ++e) {
      const auto k = static_cast<int64_t>(std::llround(counts[2 * e]));
      run_.removed_by[e] += k;
      run_.removed_mass_by[e] += counts[2 * e + 1];
      run_.removed += k;
      run_.removed_mass += counts[2 * e + 1];
    }
    global_particles_ = static_cast<int64_t>(std::llround(counts[2 * kExits]));
    ghosts_.build(comm_, dec_, p_, ghost_cutoff_);
  }

  nl_.build(p_, keep_history_);
  walls_.build_candidates(p_, skin_, keep_history_);
  if (keep_history_) {
    nl_.load_history(p_, pair_hist_);
    walls_.load_history(wall_hist_);
  }
  // The lists hold the history now; the per-particle copies are only needed at
  // the next rebuild, so give their memory back (about 190 bytes per particle).
  pair_hist_ = ContactHistory{};
  wall_hist_ = ContactHistory{};
  history_loaded_ = false;
  for (auto& pr : probes_) pr.refresh(p_, skin_);
  if (coupled_) coupling_refresh();
  ++run_.rebuilds;
  rebuild_pending_ = false;
}

std::string Level::describe_particle(size_t i) const {
  const Vec3& x = p_.x[i];
  const Vec3& v = p_.v[i];
  return fmt::format("particle id {} (radius {:.4g} m) at ({:.6g}, {:.6g}, {:.6g}) m with velocity ({:.4g}, {:.4g}, "
                     "{:.4g}) m/s, step {}, t = {:.6g} s",
                     p_.id[i], p_.radius[i], x.x, x.y, x.z, v.x, v.y, v.z, run_.step, time());
}

std::string Level::non_finite(const char* what) const {
  for (size_t i = 0; i < p_.n_local(); ++i)
    if (!finite(p_.x[i]) || !finite(p_.v[i]) || !finite(p_.omega[i]))
      return fmt::format("non-finite {} of {}", what, describe_particle(i));
  return fmt::format("non-finite {} at step {} (sum overflow)", what, run_.step);
}

void Level::guard(const std::string& local_problem, double badness) {
  // Collective: every rank stops together, with the message of the worst rank.
  if (comm_.serial()) {
    if (!local_problem.empty()) throw GuardStop(local_problem);
    return;
  }
  PhaseTimer t(times_.comm);
  const auto [worst, at] = comm_.max_loc(local_problem.empty() ? -1.0 : badness);
  if (worst < 0.0) return;
  throw GuardStop(comm_.bcast(local_problem, at));
}

void Level::step_once() {
  if (coupled_) coupling_begin_step();
  pre_step();
  double sum = 0.0;
  bool rebuild_now = rebuild_pending_;
  {
    PhaseTimer t(times_.integrate);
    const Vec3* ref = nl_.reference(p_);
    const FirstHalf fh = integrate_first_half(p_, dt_, gravity_, ref);
    sum = fh.checksum;
    rebuild_now = rebuild_now || !ref || fh.max_disp2 > 0.25 * skin_ * skin_;
  }
  {
    // One reduction decides both: does any rank need a rebuild, has any a NaN.
    PhaseTimer t(times_.comm);
    double flags[2] = {rebuild_now ? 1.0 : 0.0, std::isfinite(sum) ? 0.0 : 1.0};
    comm_.max_in_place(flags, 2);
    rebuild_now = flags[0] > 0.0;
    if (flags[1] > 0.0) guard(std::isfinite(sum) ? std::string() : non_finite("position"), 2.0);
    if (!rebuild_now) ghosts_.forward(comm_, p_);
  }
  if (!probes_.empty()) {
    PhaseTimer t(times_.measure);
    for (auto& pr : probes_) pr.check(p_);
  }
  if (coupled_) coupling_after_drift();
  if (rebuild_now) {
    PhaseTimer t(times_.neighbor);
    rebuild();
  }
  bool stress = false;
  for (const auto& g : grids_) stress = stress || (run_.step + 1) % g.sample_every == 0;
  if (coupled_) stress = stress || coupling_wants_stress();
  {
    PhaseTimer t(times_.force);
    clear_ghost_forces(p_);
    forces_(fctx_, stress);
    if (coupled_) {
      if (account_) account_->before_controller(p_);
      coupling_forces();
      if (account_) account_->after_controller(p_);
    }
  }
  const auto& st = fctx_.stats;
  std::string problem;
  if (st.max_overlap_ratio > cs_.stability.max_overlap_fraction)
    problem = fmt::format("overlap of {:.1f} % of the radius (limit [stability] max_overlap_fraction = {:.0f} %) at "
                          "{}: the time step is too large for this impact or the material too soft",
                          100.0 * st.max_overlap_ratio, 100.0 * cs_.stability.max_overlap_fraction,
                          describe_particle(static_cast<size_t>(st.worst_particle)));
  {
    PhaseTimer t(times_.integrate);
    sum = integrate_second_half(p_, dt_);
    if (account_) account_->controller_work(p_, dt_);
  }
  if (problem.empty() && !std::isfinite(sum)) problem = non_finite("velocity");
  guard(problem, std::isfinite(sum) ? st.max_overlap_ratio : 2.0);
  ++run_.step;
  ++steps_this_process_;
  run_.particle_steps += static_cast<uint64_t>(global_particles_);
  run_.max_particles = std::max<size_t>(run_.max_particles, static_cast<size_t>(global_particles_));
  after_step();
  if (coupled_) coupling_end_step();
}

MassBalance Level::mass_balance() const {
  MassBalance b;
  for (const auto& in : ins_) {
    const auto& s = in.state();
    b.requested += s.requested;
    b.inserted += s.placed;
    b.failed += s.failed;
    b.pending += s.pending;
    b.inserted_mass += s.placed_mass;
    b.failed_mass += s.failed_mass_estimate;
  }
  // Particles placed explicitly by the case count as requested and inserted.
  b.requested += run_.explicit_count;
  b.inserted += run_.explicit_count;
  b.inserted_mass += run_.explicit_mass;
  double present[2] = {static_cast<double>(p_.n_local()), 0.0};
  for (size_t i = 0; i < p_.n_local(); ++i) present[1] += p_.mass[i];
  comm_.sum_in_place(present, 2);
  b.present = static_cast<int64_t>(std::llround(present[0]));
  b.present_mass = present[1];
  b.removed = run_.removed;
  b.removed_mass = run_.removed_mass;
  std::copy(run_.removed_by, run_.removed_by + kExits, b.removed_by);
  std::copy(run_.removed_mass_by, run_.removed_mass_by + kExits, b.removed_mass_by);
  return b;
}

double Level::kinetic_energy() const {
  double e = 0.0;
  for (size_t i = 0; i < p_.n_local(); ++i)
    e += 0.5 * p_.mass[i] * norm2(p_.v[i]) + 0.5 / p_.inv_inertia[i] * norm2(p_.omega[i]);
  return comm_.sum(e);
}

}  // namespace mlcg

namespace mlcg {

size_t Level::memory_bytes() const {
  auto bytes = [](const auto& v) { return v.capacity() * sizeof(typename std::decay_t<decltype(v)>::value_type); };
  size_t b = bytes(p_.x) + bytes(p_.v) + bytes(p_.f) + bytes(p_.omega) + bytes(p_.torque) + bytes(p_.radius) +
             bytes(p_.mass) + bytes(p_.inv_mass) + bytes(p_.inv_inertia) + bytes(p_.id) + bytes(p_.material);
  b += bytes(nl_.first) + bytes(nl_.neigh) + bytes(nl_.hist) + nl_.extra_bytes();
  b += bytes(walls_.first) + bytes(walls_.prim) + bytes(walls_.hist);
  b += bytes(pair_hist_.first) + bytes(pair_hist_.key) + bytes(pair_hist_.value);
  b += bytes(wall_hist_.first) + bytes(wall_hist_.key) + bytes(wall_hist_.value);
  b += bytes(stress6_);
  return b;
}

}  // namespace mlcg
