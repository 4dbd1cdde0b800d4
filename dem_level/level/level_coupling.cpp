// A level inside a multi-level run (paper section 2.3; DESIGN.md sections 3-4):
// the hooks the time loop calls when LevelOptions::coupler is set. The bus and
// the per-grid work live in coupling/; this file connects them to the level's
// particles, insertion, removal and time loop.
//
// Interval k covers steps [k n, (k + 1) n), n = coupling interval / dt. At its
// first step the level waits for the coupler's commands of k (insertion list,
// traction, accelerations); after its last step it sends the statistics of k.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "bus/case_hash.hpp"
#include "config/case_parser.hpp"
#include "core/spheres.hpp"
#include "core/time_steps.hpp"
#include "coupling/client.hpp"
#include "coupling/grid_link.hpp"
#include "coupling/insert_log.hpp"
#include "level/level.hpp"
#include "level/phase_timer.hpp"

namespace mlcg {

struct Level::Coupled {
  std::unique_ptr<coupling::Client> client;
  std::vector<coupling::GridLink> grids;
  uint64_t steps = 1;         // steps per interval
  double interval = 0.0;      // the coupler's, the same double on every level
  uint64_t send_at = 1;       // the step of the interval after which the statistics are built ([coupling] lead)
  // The run's last interval (by the end time, the same whether or not the run is interrupted on the way) sends at
  // its end: nothing may be counted after the last statistics (its last steps' removals and crossings would
  // reach no interval's).
  bool last = false;
  bool insert_rebuild = false;  // this interval's insertion asked for a neighbour rebuild
  uint64_t send_step() const { return last ? steps : send_at; }
  uint64_t sample_every = 1;  // steps between cell samples (up to send_at)
  bus::IntervalStats held;    // built, not yet sent (a checkpoint at the interval's end comes first)
  bool built = false, sent = false;
  uint64_t k = 0;             // the interval being run
  uint64_t done = 0;          // its steps done
  bool stop = false, checkpoint = false, finished = false;
  std::string checkpoint_path;  // the coupler's (a consistent set of the hierarchy); empty = our own
  std::string stop_reason;      // the coupler cut the run short (interrupted, swapped)
  double wall0 = 0.0;
  int material = 0;           // of inserted particles
  double density = 0.0;
  uint64_t inserted = 0;      // particles received from the coupler (all ranks)
  double worst_overlap = 0.0; // largest overlap of an inserted particle / its diameter, on the inserting rank
  double worst_wall_overlap = 0.0;  // the same with the walls
  uint64_t outside_walls = 0;       // inserted particles whose centre lies outside the walls (this rank)
  coupling::InsertLog inserts;      // inserted.csv (rank 0, a fine level with an output folder)
};

namespace {

// The intervals a run to `end` takes: counted in intervals, not in a level's steps, so that levels of different dt
// stop after the same interval even when `end` is no whole number of intervals (the first boundary at or after it).
double intervals_to(double end, double interval) { return std::ceil(end / interval - 1e-6); }

// Largest overlap / diameter of particles [first, n) with each other and with every other local particle
// (a pair of two new ones over the smaller's diameter).
double insert_overlap(const Particles& p, size_t first) {
  double worst = 0.0;
  for_new_pairs(p, first, 0.0, [&](size_t k, size_t j, double d2) {
    const double rk = p.radius[k], rj = p.radius[j], gap = rk + rj - std::sqrt(d2);
    worst = std::max(worst, gap / (2.0 * rk));
    if (j >= first) worst = std::max(worst, gap / (2.0 * rj));
  });
  return worst;
}

}  // namespace

void Level::CoupledDeleter::operator()(Coupled* c) const { delete c; }

void Level::connect_coupler() {
  const double interval_case = cs_.coupling ? cs_.coupling->interval : 0.0;
  uint64_t start = 0;
  if (run_.step > 0) {  // continuing from a checkpoint: it must sit on an interval boundary
    const uint64_t n = interval_case > 0.0 ? whole_steps(interval_case, physics_.dt) : 0;
    if (n == 0 || run_.step % n != 0)
      throw std::runtime_error(fmt::format("level '{}': the checkpoint at step {} is not at the end of a coupling "
                                           "interval of the case's [coupling] ({} s = {} steps)",
                                           lvl_.name, run_.step, interval_case, n));
    start = run_.step / n;
  }
  coupling::ClientOptions o;
  o.endpoint = opt_.coupler;
  o.level_name = lvl_.name;
  if (cs_.coupling) {
    o.timeout = cs_.coupling->timeout;
    o.heartbeat = cs_.coupling->heartbeat;
  }
  auto log = log_;
  o.warn = [log](const std::string& m) { log->warn("{}", m); };
  o.stop = [this] { return stopping(); };
  auto c = std::make_unique<Coupled>();
  c->client = std::make_unique<coupling::Client>(comm_, o);

  bus::Register reg;
  reg.set_level_name(lvl_.name);
  reg.set_alpha(physics_.alpha);
  reg.set_dt(physics_.dt);
  reg.set_ranks(static_cast<uint32_t>(comm_.size()));
  reg.set_case_hash(bus::case_hash_of_bytes(config::resolved_case_text(cs_.path)));
  std::error_code ec;
  const auto exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  reg.set_binary(ec ? std::string("dem_level") : exe.string());
  reg.set_start_interval(start);
  log_->info("level '{}': registering with the coupler at {} (interval {})", lvl_.name, o.endpoint, start);
  const bus::Welcome w = c->client->handshake(reg);

  c->steps = whole_steps(w.coupling_interval(), physics_.dt);
  if (c->steps == 0)
    throw std::runtime_error(fmt::format("level '{}': the coupler's interval {} s is not a whole number of steps of "
                                         "dt = {} s (1 to 2^63)",
                                         lvl_.name, w.coupling_interval(), physics_.dt));
  if (w.start_interval() != start)
    throw std::runtime_error(fmt::format("level '{}': the coupler starts at interval {}, this level at {}", lvl_.name,
                                         w.start_interval(), start));
  c->interval = w.coupling_interval();
  const double lead = cs_.coupling ? cs_.coupling->lead : 0.0;
  c->send_at = c->steps - std::min<uint64_t>(c->steps - 1, static_cast<uint64_t>(std::floor(lead * static_cast<double>(c->steps))));
  // [coupling] samples: evenly over the steps up to the statistics, the last of them always sampling.
  const uint64_t samples = static_cast<uint64_t>(cs_.coupling ? cs_.coupling->samples : config::CouplingSpec{}.samples);
  c->sample_every = std::max<uint64_t>(1, c->send_at / samples);
  c->k = start;
  c->inserted = coupling_restored_.inserted;  // the run before the checkpoint's, so the report covers the whole run
  c->worst_overlap = coupling_restored_.worst_insert_overlap;
  c->worst_wall_overlap = coupling_restored_.worst_insert_wall_overlap;
  c->outside_walls = comm_.rank() == 0 ? coupling_restored_.inserted_outside_walls : 0;
  try {
    c->grids = coupling::links_of(w);
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error(fmt::format("level '{}': the coupler's {}", lvl_.name, e.what()));
  }
  if (!coupling_pending_restored_.empty()) {  // the sums the checkpoint's interval counted after its statistics
    size_t at = 0;
    for (auto& link : c->grids) {
      const size_t n = link.pending_size();
      if (at + n > coupling_pending_restored_.size()) break;
      link.set_pending({coupling_pending_restored_.begin() + static_cast<std::ptrdiff_t>(at),
                        coupling_pending_restored_.begin() + static_cast<std::ptrdiff_t>(at + n)});
      at += n;
    }
    if (at != coupling_pending_restored_.size())
      throw std::runtime_error(fmt::format("level '{}': the checkpoint holds {} pending coupling sums, the coupler's "
                                           "grids {}", lvl_.name, coupling_pending_restored_.size(), at));
    double m = 0.0;
    for (const auto& link : c->grids) m += link.pending_mass();
    log_->info("coupling: carried over from the checkpoint what the interval's last steps counted after its "
               "statistics: {:.6g} kg crossed or removed", comm_.sum(m));
  }
  for (const auto& link : c->grids) {
    const auto& geo = link.geometry();
    log_->info("coupling grid {}: {} level, {} cells, {} boundary faces at z = {} m", link.index(),
               coupling::to_string(link.role()), geo.cells(), geo.faces(), geo.top());
  }
  const bool fine = std::any_of(c->grids.begin(), c->grids.end(),
                                 [](const auto& g) { return g.role() == coupling::Role::Fine; });
  if (fine && comm_.rank() == 0 && !opt_.out_dir.empty()) c->inserts.open(opt_.out_dir / "inserted.csv", start);
  if (c->grids.empty()) log_->warn("level '{}' takes part in none of the coupler's {} grids", lvl_.name, w.grids_size());
  c->material = cs_.insertions.empty() ? 0 : physics_.mt.index_of(cs_.insertions.front().material);
  c->density = physics_.mt.material(c->material).density;
  log_->info("coupled as level {} of {}: interval {} s = {} steps, {} cell samples per interval, statistics after "
             "step {}", w.level_index(), w.level_count(), w.coupling_interval(), c->steps,
             (c->send_at + c->sample_every - 1) / c->sample_every, c->send_at);
  coupled_.reset(c.release());
  stepper_.rebuild_pending = true;  // the crossing candidates start at a rebuild
}

void Level::coupling_begin_step() {
  Coupled& c = *coupled_;
  if (c.done != 0 || c.finished) return;
  c.wall0 = wall_seconds();
  bus::IntervalCommands cmd;
  {
    PhaseTimer t(out_.times.coupling_wait);
    try {
      cmd = c.client->commands(c.k, time(), run_.step);
    } catch (const coupling::CouplingError& e) {
      throw CouplingStop(e.what());
    }
  }
  c.stop = cmd.stop();
  c.last = run_.end_time >= 0.0 && static_cast<double>(c.k + 1) >= intervals_to(run_.end_time, c.interval);
  c.checkpoint = cmd.checkpoint();
  c.checkpoint_path = cmd.checkpoint_path();
  c.stop_reason = cmd.stop_reason();
  std::vector<const bus::GridCommands*> of;
  try {
    of = coupling::commands_of(cmd, c.grids, lvl_.name);
  } catch (const std::invalid_argument& e) {
    throw CouplingStop(e.what());
  }
  const size_t born_from = state_.p.n_local();  // ghosts are detached before any insertion: local = all
  for (size_t l = 0; l < c.grids.size(); ++l) {
    uint64_t count = 0;
    double mass = 0.0;
    if (c.grids[l].role() == coupling::Role::Fine && of[l] && of[l]->insert_size() > 0) {
      PhaseTimer t(out_.times.coupling.insert);
      // Every rank reads the same list: the ids agree, each rank keeps what it owns.
      std::vector<ParticleInit> list;
      const int64_t first_id = run_.next_id;
      try {
        list = coupling::GridLink::parse_inserts(*of[l], c.material, c.density, first_id);
      } catch (const std::invalid_argument& e) {
        throw CouplingStop(e.what());
      }
      if (comm_.rank() == 0) c.inserts.record(c.k, *of[l], list);
      const bool pending = stepper_.rebuild_pending;  // a rebuild due anyway (after a checkpoint) is not the insertion's
      bool append = can_append();
      if (!append) state_.detach_ghosts(stepper_.keep_history);
      const size_t first_new = state_.p.n_local();
      double r_big = 0.0;
      for (const auto& pi : list) {
        mass += sphere_mass(pi.density, pi.radius);
        r_big = std::max(r_big, pi.radius);
        if (stepper_.dec.owner(pi.x) == comm_.rank()) add_particle(pi);
      }
      count = list.size();
      c.inserted += count;
      c.worst_overlap = std::max(c.worst_overlap, insert_overlap(state_.p, first_new));
      check_inserted_walls(c, c.grids[l].geometry(), first_new);
      // Not `+= count`: add_particle already raised run_.next_id, on the owning rank only. The ranks must agree on
      // ids (contact histories are keyed by them).
      run_.next_id = first_id + static_cast<int64_t>(count);
      run_.explicit_count += static_cast<int64_t>(count);  // requested and inserted, like the case's own particles
      run_.explicit_mass += mass;
      if (r_big > stepper_.r_max) {  // the same on every rank
        append = false;
        log_->warn("coupling: inserted radius {:.4g} m exceeds the largest radius {:.4g} m the level was set up for",
                   r_big, stepper_.r_max);
        stepper_.r_max = r_big;
        if (stepper_.skin <= 0.0) {
          stepper_.skin = 0.5 * stepper_.r_max;
          state_.nl.set_skin(stepper_.skin);
        }
        stepper_.ghost_cutoff = 2.0 * stepper_.r_max + stepper_.skin;
      }
      if (append) {
        append_inserted(first_new);
      } else {
        refresh_candidates(first_new);  // they may cross a face (of a region this level feeds) before the rebuild
        stepper_.rebuild_pending = true;
        c.insert_rebuild = !pending;
      }
    }
    PhaseTimer t(out_.times.coupling.controller);  // the traction's weights
    try {
      c.grids[l].begin_interval(of[l], state_.p, comm_, count, mass);
    } catch (const std::invalid_argument& e) {
      throw CouplingStop(e.what());
    }
  }
  // A middle level of a hierarchy: what the coupler inserted may lie inside the region this level
  // feeds as the coarse level. It enters that region by birth, counted after the intervals' resets.
  PhaseTimer t(out_.times.coupling.crossings);
  for (size_t i = born_from; i < state_.p.n_local(); ++i) coupling_born(i);
}

void Level::check_inserted_walls(Coupled& c, const bus::CouplingGeometry& geo, size_t first) {
  // Independent of the coupler's own placement test: the level's walls, the grid's inside point.
  const auto& ip = geo.grid().inside_point();
  const bool can_reach = ip.size() == 3;
  const Vec3 inside = can_reach ? Vec3{ip[0], ip[1], ip[2]} : Vec3{};
  const Particles& p = state_.p;
  for (size_t i = first; i < p.n_local(); ++i) {
    const double overlap = state_.walls.overlap(p.x[i], p.radius[i]) / (2.0 * p.radius[i]);
    c.worst_wall_overlap = std::max(c.worst_wall_overlap, overlap);
    if (can_reach && state_.walls.crosses(inside, p.x[i])) {
      if (c.outside_walls == 0)
        log_->warn("coupling: inserted particle {} at ({:.5g}, {:.5g}, {:.5g}) m lies outside the walls", p.id[i],
                   p.x[i].x, p.x[i].y, p.x[i].z);
      ++c.outside_walls;
    }
  }
}

bool Level::can_append() const {
  // Ghosts would need the new particles on the other ranks; a list waiting for its rebuild, or history
  // held per particle (after a checkpoint), is rebuilt anyway.
  return comm_.serial() && !stepper_.rebuild_pending && !state_.history_loaded &&
         state_.nl.matches(state_.p);
}

void Level::append_inserted(size_t first) {
  // A rebuild at every insertion was half a small hopper's fine-level rebuilds (wall -2.7 % without them):
  // the new particles join the lists, everything else stays as it is until the next rebuild.
  state_.nl.append(state_.p, first, stepper_.keep_history);
  state_.walls.append_candidates(state_.p, first, stepper_.skin, stepper_.keep_history);
  refresh_candidates(first);
  stepper_.global_particles = static_cast<int64_t>(state_.p.n_local());
  stepper_.rebuild_pending = false;  // add_particle asked for one; the lists hold the new particles now
}

void Level::coupling_refresh(size_t from) {
  for (auto& g : coupled_->grids) g.refresh(state_.p, stepper_.skin, from);
}

void Level::coupling_after_drift() {
  PhaseTimer t(out_.times.coupling.crossings);
  for (auto& g : coupled_->grids) g.after_drift(state_.p);
}

void Level::coupling_born(size_t i) {
  for (auto& g : coupled_->grids) g.born(state_.p, i);
}

bool Level::coupling_take_insert_rebuild() {
  const bool r = coupled_->insert_rebuild;
  coupled_->insert_rebuild = false;
  return r;
}

bool Level::coupling_wants_stress() const {
  const Coupled& c = *coupled_;
  const uint64_t j = c.done + 1;  // this step's number within the interval
  const uint64_t send = c.send_step();
  return !c.grids.empty() && j <= send && (j % c.sample_every == 0 || j == send);
}

void Level::coupling_forces() {
  PhaseTimer t(out_.times.coupling.controller);
  for (const auto& g : coupled_->grids) g.add_forces(state_.p);
}

bool Level::coupling_removes(size_t i) {
  for (auto& g : coupled_->grids)
    if (g.leaves(state_.p.x[i])) {
      g.count_removed(state_.p.x[i], state_.p.mass[i]);
      return true;
    }
  return false;
}

bool Level::coupling_finished() const { return coupled_->finished; }

bool Level::coupling_mid_interval() const { return coupled_ && coupled_->done != 0; }

bool Level::coupling_reached(double end) const {
  const Coupled& c = *coupled_;
  return c.done == 0 && static_cast<double>(c.k) >= intervals_to(end, c.interval);
}

const std::string& Level::coupling_stop_reason() const { return coupled_->stop_reason; }

Level::CouplingReport Level::coupling_report() const {
  CouplingReport r;
  if (!coupled_) return r;
  r.intervals = coupled_->k;
  r.inserted = coupled_->inserted;
  r.worst_insert_overlap = comm_.max(coupled_->worst_overlap);
  r.worst_insert_wall_overlap = comm_.max(coupled_->worst_wall_overlap);
  r.inserted_outside_walls = static_cast<uint64_t>(comm_.sum(static_cast<int64_t>(coupled_->outside_walls)));
  return r;
}

void Level::coupling_end_step() {
  Coupled& c = *coupled_;
  const bool sample = coupling_wants_stress();
  ++c.done;
  if (sample) {
    PhaseTimer t(out_.times.coupling.samples);
    for (auto& g : c.grids) g.sample(state_.p, state_.stress6, comm_);
  }
  // The checkpoint at an interval's end before the statistics go: they tell the coupler it is on disk (its
  // consistent set). Statistics built early ([coupling] lead) wait for it; otherwise they go once built.
  const bool checkpoint = c.checkpoint && !opt_.out_dir.empty();
  if (c.done == c.send_step() && c.done < c.steps) {
    c.held = coupling_stats();
    c.built = true;
    if (!checkpoint) {
      PhaseTimer t(out_.times.coupling.send);
      c.client->send_stats(std::move(c.held));
      c.sent = true;
    }
  }
  if (c.done < c.steps) {
    c.client->keepalive(time(), run_.step);
    return;
  }
  // Built before the checkpoint, which then holds only what the statistics do not (coupling_pending).
  if (!c.built) c.held = coupling_stats();
  std::string path;
  if (checkpoint) {
    PhaseTimer t(out_.times.output);
    path = c.checkpoint_path.empty() ? (opt_.out_dir / "checkpoint.h5").string() : c.checkpoint_path;
    c.inserts.flush();  // the rows the checkpoint covers are on disk before it is
    write_checkpoint(path);
    stepper_.rebuild_pending = true;  // as a restarted run will
  }
  if (!c.sent) {
    PhaseTimer t(out_.times.coupling.send);
    if (checkpoint) c.held.set_checkpoint(path);
    c.client->send_stats(std::move(c.held));
  }
  c.built = c.sent = false;
  ++c.k;
  c.done = 0;
  c.finished = c.stop;
}

bus::IntervalStats Level::coupling_stats() {
  Coupled& c = *coupled_;
  PhaseTimer t(out_.times.coupling.statistics);
  bus::IntervalStats s;
  s.set_interval(c.k);
  s.set_sim_time(time());
  const double ahead = static_cast<double>(c.steps - c.done) * physics_.dt;  // to the interval's end
  for (auto& g : c.grids) *s.add_grids() = g.finish(state_.p, comm_, stepper_.r_max, ahead);
  s.set_particles(static_cast<uint64_t>(comm_.sum(static_cast<int64_t>(state_.p.n_local()))));
  s.set_wall_seconds(wall_seconds() - c.wall0);
  return s;
}

std::vector<double> Level::coupling_pending() const {
  std::vector<double> v;
  if (!coupled_) return v;
  for (const auto& g : coupled_->grids) {
    const auto p = g.pending();
    v.insert(v.end(), p.begin(), p.end());
  }
  return v;
}

void Level::coupling_bye(RunStatus status, const std::string& reason) {
  Coupled& c = *coupled_;
  std::string why = reason;
  if (why.empty())
    why = c.finished ? fmt::format("finished after interval {}", c.k - 1)
                     : fmt::format("{} at t = {:.6g} s (interval {}, step {} of {})", to_string(status), time(), c.k,
                                   c.done, c.steps);
  // Stopping where the coupler said (c.finished) is no failure, even when the run was cut short.
  const bool failed = status == RunStatus::Failed || (status == RunStatus::Interrupted && !c.finished);
  c.client->bye(why, failed);
  log_->info("coupling: said bye to the coupler ({})", why);
}

}  // namespace mlcg
