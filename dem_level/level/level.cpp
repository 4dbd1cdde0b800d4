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
  if (state_.walls.has_rigid()) state_.walls.set_time(t);  // where this step's insertions meet the walls
  if (!scene_.events.empty()) {
    PhaseTimer timer(out_.times.measure);
    check_events(t);
  }
  insert_due(t);
}

void Level::check_events(double t) {
  const double half = 0.5 * physics_.dt;
  for (size_t e = 0; e < scene_.events.size(); ++e) {
    auto& es = scene_.events[e];
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
      for (const auto& in : scene_.ins) ready = ready && in.state().done;
    if (ready && spec.mean_speed_below >= 0.0) {
      double s[2] = {0.0, 0.0};  // mass, sum m v^2 over all ranks
      for (size_t i = 0; i < state_.p.n_local(); ++i) {
        s[0] += state_.p.mass[i];
        s[1] += state_.p.mass[i] * norm2(state_.p.v[i]);
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
  PhaseTimer timer(out_.times.insert);
  for (auto& in : scene_.ins) {
    if (!in.due(t, physics_.dt)) continue;
    // Every rank computes the same batch from the same data and keeps its own particles.
    const double heap = in.follows_heap() ? comm_.max(in.heap_top(state_.p, norm(physics_.gravity)))
                                          : -std::numeric_limits<double>::infinity();
    Vec3 lo, hi;
    in.batch_region(heap, lo, hi);
    std::vector<Sphere> mine;
    in.nearby(state_.p, lo, hi, 2.0 * stepper_.r_max, mine);
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
    const auto batch = in.place_batch(obstacles, 2.0 * stepper_.r_max, lo, hi, state_.walls, run_.rng, run_.next_id,
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
      // New local particles go before the ghosts; the rebuild restores them.
      state_.detach_ghosts(stepper_.keep_history);
      const size_t first = state_.p.n_local();
      for (const auto& pi : placed)
        if (stepper_.dec.owner(pi.x) == comm_.rank()) {
          add_particle(pi);
          if (coupled_) coupling_born(state_.p.n_local() - 1);
        }
      refresh_candidates(first);  // one placed just above a face or a probe may cross it in this very step
      stepper_.rebuild_pending = true;
    }
    if (in.state().done && in.state().failed > 0)
      log_->warn("insertion '{}': {} particles could not be placed (region full or blocked)", in.params().name,
                 in.state().failed);
  }
}

void Level::fire_event(size_t e) {
  auto& es = scene_.events[e];
  const auto& spec = cs_.events[e];
  es.fired = true;
  es.fired_at = time();
  for (const auto& w : spec.remove_walls) {
    state_.walls.set_active(static_cast<size_t>(state_.walls.find(w)), false);
    stepper_.rebuild_pending = true;
  }
  log_->info("t = {:.4f} s: event '{}'{}", es.fired_at, spec.name,
             spec.remove_walls.empty() ? "" : fmt::format(" removes {}", fmt::join(spec.remove_walls, ", ")));
  for (size_t k = 0; k < scene_.probes.size(); ++k)
    if (scene_.probe_events[k] == spec.name) {
      auto& q = scene_.probes[k].params();
      q.window_start = es.fired_at + cs_.probes[k].window_start;
      q.window_end = es.fired_at + cs_.probes[k].window_end;
      q.window_known = true;
    }
  resolve_end_time();
}

void ParticleState::detach_ghosts(bool keep_history) {
  // The lists index ghosts; before the ghosts go, the contact history moves to
  // per-particle form (the ghosts' own entries go with them).
  if (!history_loaded) {
    if (keep_history) {
      nl.save_history(p, pair_hist);
      walls.save_history(p, wall_hist);
    } else {
      pair_hist.clear(p.size());
      wall_hist.clear(p.size());
    }
    history_loaded = true;
  }
  p.drop_ghosts();
  pair_hist.truncate(p.n_local());
  wall_hist.truncate(p.n_local());
}

void Level::rebuild() {
  state_.detach_ghosts(stepper_.keep_history);

  if (!comm_.serial()) {
    PhaseTimer t(out_.times.comm);
    if (stepper_.balance && run_.rebuilds % kSortEvery == 0 && stepper_.dec.imbalance(comm_, state_.p.n_local()) > 1.05)
      stepper_.dec.balance(comm_, state_.p.x, state_.p.n_local());
    migrate(comm_, stepper_.dec, state_.p, state_.pair_hist, state_.wall_hist);
  }

  // Removal of particles that left the domain, and a periodic spatial sort.
  const size_t n = state_.p.n_local();
  std::vector<int32_t> order;
  const bool sort_now = run_.rebuilds % kSortEvery == 0;
  if (sort_now) {
    CellBins bins;
    bins.build(state_.p.x, n, 2.0 * stepper_.r_max + stepper_.skin);
    order = bins.sorted();
  } else {
    order.resize(n);
    for (size_t i = 0; i < n; ++i) order[i] = static_cast<int32_t>(i);
  }
  std::vector<int32_t> keep;
  keep.reserve(n);
  double gone[2 * kExits] = {};  // count, mass per exit
  const Vec3 &lo = physics_.dom_lo, &hi = physics_.dom_hi;
  for (int32_t i : order) {
    const Vec3& x = state_.p.x[static_cast<size_t>(i)];
    int exit = -1;
    if (x.z < lo.z) exit = static_cast<int>(Exit::Outlet);
    else if (x.x < lo.x || x.y < lo.y || x.x > hi.x || x.y > hi.y || x.z > hi.z)
      exit = static_cast<int>(Exit::Wall);
    else if (coupled_ && coupling_removes(static_cast<size_t>(i))) exit = static_cast<int>(Exit::Boundary);
    if (exit >= 0) {
      if (account_) account_->carried_out(state_.p, static_cast<size_t>(i));
      gone[2 * exit] += 1.0;
      gone[2 * exit + 1] += state_.p.mass[static_cast<size_t>(i)];
      continue;
    }
    keep.push_back(i);
  }
  if (sort_now || keep.size() != n) {
    state_.p.permute(keep);
    state_.pair_hist.permute(keep, state_.p.size());
    state_.wall_hist.permute(keep, state_.p.size());
  }
  {
    PhaseTimer t(out_.times.comm);
    double counts[2 * kExits + 1];
    std::copy(gone, gone + 2 * kExits, counts);
    counts[2 * kExits] = static_cast<double>(state_.p.n_local());
    comm_.sum_in_place(counts, 2 * kExits + 1);
    for (int e = 0; e < kExits; ++e) {
      const auto k = static_cast<int64_t>(std::llround(counts[2 * e]));
      run_.removed_by[e] += k;
      run_.removed_mass_by[e] += counts[2 * e + 1];
      run_.removed += k;
      run_.removed_mass += counts[2 * e + 1];
    }
    stepper_.global_particles = static_cast<int64_t>(std::llround(counts[2 * kExits]));
    stepper_.ghosts.build(comm_, stepper_.dec, state_.p, stepper_.ghost_cutoff);
  }

  state_.nl.build(state_.p, stepper_.keep_history);
  state_.walls.build_candidates(state_.p, stepper_.skin, stepper_.keep_history);
  if (stepper_.keep_history) {
    state_.nl.load_history(state_.p, state_.pair_hist);
    state_.walls.load_history(state_.wall_hist);
  }
  // The lists hold the history now; the per-particle copies are only needed at
  // the next rebuild, so give their memory back (about 190 bytes per particle).
  state_.pair_hist = ContactHistory{};
  state_.wall_hist = ContactHistory{};
  state_.history_loaded = false;
  refresh_candidates();
  ++run_.rebuilds;
  stepper_.rebuild_pending = false;
}

void Level::refresh_candidates(size_t from) {
  for (auto& pr : scene_.probes) pr.refresh(state_.p, stepper_.skin, from);
  if (coupled_) coupling_refresh(from);
}

std::string Level::describe_particle(size_t i) const {
  const Vec3& x = state_.p.x[i];
  const Vec3& v = state_.p.v[i];
  return fmt::format("particle id {} (radius {:.4g} m) at ({:.6g}, {:.6g}, {:.6g}) m with velocity ({:.4g}, {:.4g}, "
                     "{:.4g}) m/s, step {}, t = {:.6g} s",
                     state_.p.id[i], state_.p.radius[i], x.x, x.y, x.z, v.x, v.y, v.z, run_.step, time());
}

std::string Level::non_finite(const char* what, uint64_t step) const {
  for (size_t i = 0; i < state_.p.n_local(); ++i)
    if (!finite(state_.p.x[i]) || !finite(state_.p.v[i]) || !finite(state_.p.omega[i]))
      return fmt::format("non-finite {} of {}", what, describe_particle(i));
  return fmt::format("non-finite {} at step {} (sum overflow)", what, step);
}

void Level::guard(const std::string& local_problem, double badness) {
  // Collective: every rank stops together, with the message of the worst rank.
  if (comm_.serial()) {
    if (!local_problem.empty()) throw GuardStop(local_problem);
    return;
  }
  PhaseTimer t(out_.times.comm);
  const auto [worst, at] = comm_.max_loc(local_problem.empty() ? -1.0 : badness);
  if (worst < 0.0) return;
  throw GuardStop(comm_.bcast(local_problem, at));
}

bool Level::may_owe_kick() const {
  // Nothing but the next step's first half may come between: no coupler or energy account (they
  // read and add forces between the halves), no events or insertions (they read speeds, add particles).
  // The same answer on every rank (settle_kick is collective): the size is the global one.
  return owe_kick_allowed() && kick_.started() && kick_.mode() == KickChoice::Mode::Fused;
}

bool Level::owe_kick_allowed() const {
  return !coupled_ && !account_ && scene_.events.empty() && scene_.ins.empty();
}

void Level::book_kick_step() {
  if (!kick_.after_step(out_.times.integrate)) return;
  // One answer on every rank: rank 0's, from the times summed over the ranks.
  const double split = comm_.sum(kick_.split_seconds()), fused = comm_.sum(kick_.fused_seconds());
  kick_.decide(comm_.max(comm_.rank() == 0 && fused < split ? 1.0 : 0.0) > 0.0);
  log_->info("integration: {} per step, timed on this host over {} steps each way (two passes {:.4g} s, one fused "
             "pass {:.4g} s of integration, all ranks)",
             kick_.mode() == KickChoice::Mode::Fused ? "one fused pass" : "two passes",
             KickChoice::kBlock * KickChoice::kRounds, split, fused);
}

double Level::pay_owed_kick() {
  if (!kick_owed_) return 0.0;
  kick_owed_ = false;
  PhaseTimer t(out_.times.integrate);
  return integrate_second_half(state_.p, physics_.dt);
}

void Level::settle_kick() {
  if (!kick_owed_) return;
  const double sum = pay_owed_kick();
  guard(std::isfinite(sum) ? std::string() : non_finite("velocity", run_.step - 1), 2.0);
}

void Level::step_once() { step(false); }

void Level::timed_rebuild(bool for_insert) {
  const double t0 = out_.times.neighbor;
  {
    PhaseTimer t(out_.times.neighbor);
    rebuild();
  }
  if (for_insert) {
    out_.times.insert_rebuilds += 1.0;
    out_.times.insert_rebuild_seconds += out_.times.neighbor - t0;
  }
}

void Level::step_forces() {
  bool stress = false;
  for (const auto& g : scene_.grids) stress = stress || (run_.step + 1) % g.sample_every == 0;
  if (coupled_) stress = stress || coupling_wants_stress();
  const double f0 = out_.times.force;
  {
    PhaseTimer t(out_.times.force);
    clear_ghost_forces(state_.p);
    stepper_.forces(stepper_.fctx, stress);
  }
  if (state_.nl.pairs() > 0) out_.times.pair_kernel_steps[stepper_.fctx.stats.pair_kernel] += 1.0;
  if (stress) {  // what the stress costs the kernels shows beside the other steps' force time
    out_.times.force_sample_steps += out_.times.force - f0;
    out_.times.sample_steps += 1.0;
  }
  if (coupled_) {  // timed as coupling work, not as force
    if (account_) account_->before_controller(state_.p);
    coupling_forces();
    if (account_) account_->after_controller(state_.p);
  }
}

void Level::step(bool may_owe) {
  if (may_owe && !kick_.started() && owe_kick_allowed())
    kick_.start(static_cast<double>(stepper_.global_particles) / comm_.size(), opt_.calibrate_kick_above,
                opt_.owed_kick_above, out_.times.integrate);
  if (coupled_) coupling_begin_step();
  pre_step();
  double sum = 0.0, owed_sum = 0.0;
  bool rebuild_now = stepper_.rebuild_pending;
  // A rebuild the coupler's insertion asks for: coupling cost that the neighbour time carries, reported apart.
  bool for_insert = coupled_ && coupling_take_insert_rebuild();
  {
    PhaseTimer t(out_.times.integrate);
    const Vec3* ref = state_.nl.reference(state_.p);
    const FirstHalf fh = kick_owed_ ? integrate_owed_kick_first_half(state_.p, physics_.dt, physics_.gravity, ref)
                                    : integrate_first_half(state_.p, physics_.dt, physics_.gravity, ref);
    kick_owed_ = false;
    sum = fh.checksum;
    owed_sum = fh.owed_checksum;
    bool moved = fh.max_disp2 > 0.25 * stepper_.skin * stepper_.skin;
    if (state_.walls.has_rigid()) {
      // The forces act at the step's end: a moving mesh is there, and the candidates hold while the particles and
      // the mesh together have closed no more than half the skin.
      state_.walls.set_time(time() + physics_.dt);
      moved = std::sqrt(fh.max_disp2) + state_.walls.moved_since_build() > 0.5 * stepper_.skin;
    }
    rebuild_now = rebuild_now || !ref || moved;
    // The inserted particles have no reference position, so how far the others moved is unknown then: some of these
    // rebuilds the displacement would have asked for a few steps later.
    for_insert = for_insert && !(ref && moved);
  }
  {
    // One reduction decides all: does any rank need a rebuild, has any a NaN (the last step's
    // velocities when their kick was owed, the positions).
    PhaseTimer t(out_.times.comm);
    double flags[3] = {rebuild_now ? 1.0 : 0.0, std::isfinite(sum) ? 0.0 : 1.0, std::isfinite(owed_sum) ? 0.0 : 1.0};
    comm_.max_in_place(flags, 3);
    rebuild_now = flags[0] > 0.0;
    if (flags[2] > 0.0) guard(std::isfinite(owed_sum) ? std::string() : non_finite("velocity", run_.step - 1), 2.0);
    if (flags[1] > 0.0) guard(std::isfinite(sum) ? std::string() : non_finite("position", run_.step), 2.0);
    if (!rebuild_now) stepper_.ghosts.forward(comm_, state_.p);
  }
  if (!scene_.probes.empty()) {
    PhaseTimer t(out_.times.measure);
    for (auto& pr : scene_.probes) pr.check(state_.p);
  }
  if (coupled_) coupling_after_drift();
  if (rebuild_now) timed_rebuild(for_insert);
  step_forces();
  const auto& st = stepper_.fctx.stats;
  if (account_) account_->wall_work(st.wall_power, physics_.dt);
  std::string problem;
  if (st.max_overlap_ratio > cs_.stability.max_overlap_fraction)
    problem = fmt::format("overlap of {:.1f} % of the radius (limit [stability] max_overlap_fraction = {:.0f} %) at "
                          "{}: the time step is too large for this impact or the material too soft",
                          100.0 * st.max_overlap_ratio, 100.0 * cs_.stability.max_overlap_fraction,
                          describe_particle(static_cast<size_t>(st.worst_particle)));
  // Within run(), the second half waits for the next step's first half (one pass over the arrays
  // instead of two) unless something reads the velocities first: settle_kick() pays it then.
  if (may_owe && may_owe_kick()) {
    kick_owed_ = true;
    sum = 0.0;
  } else {
    PhaseTimer t(out_.times.integrate);
    sum = integrate_second_half(state_.p, physics_.dt);
    if (account_) account_->controller_work(state_.p, physics_.dt);
  }
  if (problem.empty() && !std::isfinite(sum)) problem = non_finite("velocity", run_.step);
  guard(problem, std::isfinite(sum) ? st.max_overlap_ratio : 2.0);
  if (may_owe && kick_.calibrating()) book_kick_step();
  ++run_.step;
  ++steps_this_process_;
  run_.particle_steps += static_cast<uint64_t>(stepper_.global_particles);
  run_.max_particles = std::max<size_t>(run_.max_particles, static_cast<size_t>(stepper_.global_particles));
  after_step();
  if (coupled_) coupling_end_step();
}

MassBalance Level::mass_balance() const {
  MassBalance b;
  for (const auto& in : scene_.ins) {
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
  double present[2] = {static_cast<double>(state_.p.n_local()), 0.0};
  for (size_t i = 0; i < state_.p.n_local(); ++i) present[1] += state_.p.mass[i];
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
  for (size_t i = 0; i < state_.p.n_local(); ++i)
    e += 0.5 * state_.p.mass[i] * norm2(state_.p.v[i]) + 0.5 / state_.p.inv_inertia[i] * norm2(state_.p.omega[i]);
  return comm_.sum(e);
}

}  // namespace mlcg

namespace mlcg {

size_t ParticleState::memory_bytes() const {
  auto bytes = [](const auto& v) { return v.capacity() * sizeof(typename std::decay_t<decltype(v)>::value_type); };
  size_t b = bytes(p.x) + bytes(p.v) + bytes(p.f) + bytes(p.omega) + bytes(p.torque) + bytes(p.radius) +
             bytes(p.mass) + bytes(p.inv_mass) + bytes(p.inv_inertia) + bytes(p.id) + bytes(p.material);
  b += bytes(nl.first) + bytes(nl.neigh) + bytes(nl.hist) + nl.extra_bytes();
  b += bytes(walls.first) + bytes(walls.prim) + bytes(walls.hist) + bytes(walls.near);
  b += bytes(pair_hist.first) + bytes(pair_hist.key) + bytes(pair_hist.value);
  b += bytes(wall_hist.first) + bytes(wall_hist.key) + bytes(wall_hist.value);
  b += bytes(stress6);
  return b;
}

}  // namespace mlcg
