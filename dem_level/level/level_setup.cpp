// Building a level from a parsed case: materials, contact model, walls,
// insertion, explicit particles, measurements and the stability guard.
#include <algorithm>
#include <cmath>
#include <numbers>

#include <fmt/format.h>
#include <spdlog/sinks/basic_file_sink.h>
#include <spdlog/sinks/stdout_sinks.h>
#include <spdlog/spdlog.h>

#include "core/huge_pages.hpp"
#include "core/spheres.hpp"
#include "forces/integrator.hpp"
#include "config/case_parser.hpp"
#include "io/atomic_file.hpp"
#include "io/grid_series.hpp"
#include "io/h5.hpp"
#include "io/snapshot_series.hpp"
#include "level/level.hpp"
#include "scene/walls_from_case.hpp"
#include "stability/initial_state.hpp"
#include "stability/stability_preview.hpp"

namespace mlcg {

namespace {

Vec3 unit(const Vec3& a) { return a / norm(a); }

}  // namespace

const char* to_string(Exit e) {
  switch (e) {
    case Exit::Outlet: return "outlet";
    case Exit::Boundary: return "boundary_surface";
    case Exit::Wall: return "wall";
  }
  return "unknown";
}

const char* to_string(RunStatus s) {
  switch (s) {
    case RunStatus::Completed: return "completed";
    case RunStatus::StepLimit: return "stopped_at_step_limit";
    case RunStatus::Interrupted: return "interrupted";
    case RunStatus::Failed: return "failed";
  }
  return "unknown";
}

Level::Level(const config::CaseSpec& cs, LevelOptions opt)
    : cs_(cs), opt_(std::move(opt)), comm_(opt_.single_rank), stepper_(state_, physics_.mt) {
  setup();
}

Level::~Level() = default;

void Level::setup() {
  setup_logging();
  select_level();
  setup_contact();
  setup_decomposition();
  setup_walls();
  setup_insertions();
  // In a hierarchy the case's particles fill the coarsest level only; finer
  // levels get theirs from the coupler (their kinds still set the guards).
  bool fills_scene = true;
  for (const auto& l : cs_.levels) fills_scene = fills_scene && (!cs_.coupling || l.alpha <= physics_.alpha);
  std::vector<ParticleKind> explicit_kinds;
  std::vector<PlacedParticle> placed;  // for the initial-overlap check
  place_case_particles(fills_scene, explicit_kinds, placed);
  const double r_max = setup_stability(explicit_kinds, placed);
  if (!fills_scene) scene_.ins.clear();
  setup_skin(r_max);
  setup_measurements();
  scene_.events.assign(cs_.events.size(), Scene::Event{});
  resolve_end_time();
  start_state();
}

void Level::setup_logging() {
  // Console (unless quiet) and, with a run folder, its log file.
  // Rank 0 speaks for the level; other ranks report only their errors.
  std::vector<spdlog::sink_ptr> sinks;
  if (comm_.rank() == 0) {
    if (!opt_.quiet) sinks.push_back(std::make_shared<spdlog::sinks::stdout_sink_mt>());
    if (!opt_.out_dir.empty()) {
      std::filesystem::create_directories(opt_.out_dir);
      sinks.push_back(std::make_shared<spdlog::sinks::basic_file_sink_mt>((opt_.out_dir / "log.txt").string()));
    }
  } else {
    sinks.push_back(std::make_shared<spdlog::sinks::stderr_sink_mt>());
  }
  log_ = std::make_shared<spdlog::logger>("dem_level", sinks.begin(), sinks.end());
  log_->set_pattern("[%H:%M:%S] %v");
  log_->flush_on(spdlog::level::info);  // `tail -f log.txt` shows each line as it happens (they are seconds apart)
  if (comm_.rank() != 0) log_->set_level(spdlog::level::err);
}

void Level::select_level() {
  // The [[levels]] entry this process runs, and what the time loop takes from the case as plain numbers.
  lvl_ = cs_.levels.front();
  if (!opt_.level.empty()) {
    const auto it = std::find_if(cs_.levels.begin(), cs_.levels.end(),
                                 [&](const config::LevelSpec& l) { return l.name == opt_.level; });
    if (it == cs_.levels.end()) {
      std::vector<std::string> names;
      for (const auto& l : cs_.levels) names.push_back("'" + l.name + "'");
      throw std::runtime_error(fmt::format("{}: no [[levels]] entry is named '{}'; the case has {}", cs_.path,
                                           opt_.level, fmt::join(names, ", ")));
    }
    lvl_ = *it;
  }
  physics_.dt = lvl_.dt;
  physics_.alpha = lvl_.alpha;
  stepper_.fctx.dt = physics_.dt;
  physics_.gravity = cs_.gravity;
  physics_.dom_lo = cs_.domain.min;
  physics_.dom_hi = cs_.domain.max;
  run_.rng.seed(cs_.seed);
}

void Level::setup_contact() {
  // The materials, and the force routine compiled for the case's contact model.
  physics_.mt = materials_of_case(cs_);
  stepper_.choice.tangential_history = cs_.contact.tangential == "history";
  stepper_.choice.rolling_cdt = cs_.contact.rolling == "cdt";
  stepper_.choice.clamp_normal = cs_.contact.clamp_normal;
  stepper_.forces = select_force_routine(stepper_.choice);
  stepper_.keep_history = model_keeps_history(stepper_.choice);
  log_->info("level '{}': alpha = {}, dt = {:.4g} s, contact model hertz + tangential {} + rolling {}{}", lvl_.name,
             physics_.alpha, physics_.dt, cs_.contact.tangential, cs_.contact.rolling,
             stepper_.choice.clamp_normal ? " (normal force clamped)" : "");
  if (!huge_pages_state().empty()) log_->info("memory: {}", huge_pages_state());
}

void Level::setup_decomposition() {
  // The process grid; the boundaries start uniform and are balanced at the first rebuild.
  std::array<int, 3> grid =
      Decomposition::default_grid(comm_.size(), physics_.dom_lo, physics_.dom_hi, physics_.gravity);
  if (!lvl_.processors.empty()) grid = {lvl_.processors[0], lvl_.processors[1], lvl_.processors[2]};
  if (grid[0] * grid[1] * grid[2] != comm_.size())
    throw std::runtime_error(fmt::format("{}: levels[{}].processors = [{}, {}, {}] needs {} MPI ranks, but the level "
                                         "runs on {}",
                                         lvl_.loc.str(), lvl_.name, grid[0], grid[1], grid[2],
                                         grid[0] * grid[1] * grid[2], comm_.size()));
  stepper_.dec = Decomposition(grid, physics_.dom_lo, physics_.dom_hi);
  stepper_.balance = lvl_.balance;
  if (!comm_.serial())
    log_->info("MPI: {} ranks as a {} x {} x {} grid{}", comm_.size(), grid[0], grid[1], grid[2],
               stepper_.balance ? ", boundaries balanced by particle count" : "");
}

void Level::place_case_particles(bool fills_scene, std::vector<ParticleKind>& kinds,
                                 std::vector<PlacedParticle>& placed) {
  // The case's [[particles]] and [initial] state: added only when this level fills the scene, but
  // always listed (kinds for the guard, positions for the initial-overlap check).
  for (const auto& ps : cs_.particles) {
    ParticleInit pi;
    pi.id = run_.next_id++;
    pi.material = physics_.mt.index_of(ps.material);
    pi.radius = ps.radius * physics_.alpha;
    pi.density = physics_.mt.material(pi.material).density;
    pi.x = ps.position;
    pi.v = ps.velocity;
    pi.omega = ps.omega;
    kinds.push_back({pi.material, pi.radius, pi.radius, norm(pi.v)});
    placed.push_back({{pi.x, pi.radius}, pi.material, pi.id});
    if (!fills_scene) continue;
    ++run_.explicit_count;
    run_.explicit_mass += sphere_mass(pi.density, pi.radius);
    if (stepper_.dec.owner(pi.x) == comm_.rank()) add_particle(pi);
  }
  if (cs_.initial) load_initial_state(kinds, placed, fills_scene && opt_.restart.empty());
  case_placed_ = run_.explicit_count;  // before a checkpoint or the coupler adds to the count
}

double Level::setup_stability(const std::vector<ParticleKind>& explicit_kinds,
                              const std::vector<PlacedParticle>& placed) {
  // The guard, over every kind of particle this level will hold; returns the largest radius.
  std::vector<ParticleKind> kinds;
  double r_max = 0.0;
  for (const auto& in : cs_.insertions) {  // the kinds `mlcg check` previews too (stability_preview.hpp)
    kinds.push_back(insertion_kind(in, physics_.alpha, physics_.mt));
    r_max = std::max(r_max, kinds.back().r_max);
  }
  for (const auto& k : merge_kinds(explicit_kinds)) {  // one kind per particle would make the guard O(N^2)
    kinds.push_back(k);
    r_max = std::max(r_max, k.r_max);
  }
  std::vector<int> wall_mats;
  for (size_t w = 0; w < state_.walls.walls(); ++w) wall_mats.push_back(state_.walls.info(w).material);
  const double height = guard_height(cs_);
  // A restart continues from a state the guard already let start.
  const InitialOverlap overlaps = opt_.restart.empty() ? initial_overlaps(placed, physics_.mt) : InitialOverlap{};
  physics_.stab = check_stability(cs_, lvl_, physics_.mt, kinds, wall_mats, height, overlaps);
  for (const auto& l : physics_.stab.lines) log_->info("{}", l);
  return r_max;
}

void Level::setup_skin(double r_max) {
  stepper_.skin = lvl_.skin > 0.0 ? lvl_.skin : 0.5 * r_max;
  state_.nl.set_skin(stepper_.skin);
  stepper_.r_max = r_max;
  stepper_.ghost_cutoff = 2.0 * stepper_.r_max + stepper_.skin;
  log_->info("neighbour search: skin {:.4g} m, rebuild when a particle moved {:.4g} m", stepper_.skin,
             0.5 * stepper_.skin);
}

void Level::start_state() {
  // The run folder, then the state at t0: a checkpoint's, the coupler's, or the case's with its forces.
  if (!opt_.out_dir.empty() && comm_.rank() == 0) {
    io::write_file_atomic(opt_.out_dir / "case.toml", config::resolved_case_text(cs_.path));  // a variant resolved
    std::filesystem::create_directories(opt_.out_dir / "probes");
  }
  if (!opt_.restart.empty()) load_checkpoint(opt_.restart);
  if (!opt_.out_dir.empty() && comm_.rank() == 0)
    out_.snaps = std::make_unique<io::SnapshotSeries>(opt_.out_dir, "particles", !opt_.restart.empty());
  if (!opt_.coupler.empty()) connect_coupler();
  else if (opt_.restart.empty()) initial_forces();
  // A step checks the crossings before its rebuild. The probes' and the coupling's candidates start from the loaded
  // positions, the sides the uninterrupted run knows (a coupling face lost a crossing in a restart's first step).
  if (stepper_.rebuild_pending) refresh_candidates();
}

void Level::initial_forces() {
  // Velocity Verlet's first half kick needs the forces at t = 0 (a checkpoint stores them). Without
  // them particles placed touching start half a kick short: a pack placed with overlaps gained
  // (omega dt / 2)^2 of its stored energy, 2 % at 10 steps per contact (cases/stability/overlap_pack.toml).
  // The evaluation leaves the tangential history as it was: step 1 integrates it.
  rebuild();
  const std::vector<Vec3f> pair_hist = state_.nl.hist;
  const std::vector<Vec3> wall_hist = state_.walls.hist;
  clear_ghost_forces(state_.p);
  stepper_.forces(stepper_.fctx, false);
  state_.nl.hist = pair_hist;
  state_.walls.hist = wall_hist;
  refuse_placed_overlap();
}

void Level::refuse_placed_overlap() {
  // A particle placed deeper in a neighbour or a wall than the run guard allows would stop the run
  // in step 1 (or, centred on a wall, have no direction to be pushed along): refuse it now, by name.
  const auto& st = stepper_.fctx.stats;
  std::string problem;
  if (st.max_overlap_ratio > cs_.stability.max_overlap_fraction) {
    const auto i = static_cast<size_t>(st.worst_particle);
    const int64_t id = state_.p.id[i];
    const bool listed = id < static_cast<int64_t>(cs_.particles.size()) && !cs_.initial;
    problem = fmt::format(
        "{}: particle id {} is placed overlapping a neighbour or a wall by {:.1f} % of its radius, above [stability] "
        "max_overlap_fraction = {:.0f} %; the run would stop in step 1. Move it ({}) or raise max_overlap_fraction",
        listed ? cs_.particles[static_cast<size_t>(id)].loc.str() + ": particles[" + std::to_string(id) + "]"
               : (cs_.initial ? cs_.initial->loc.str() + ": initial" : cs_.path),
        id, 100.0 * st.max_overlap_ratio, 100.0 * cs_.stability.max_overlap_fraction,
        listed ? "its position" : "the snapshot's positions");
  }
  try {
    guard(problem, st.max_overlap_ratio);
  } catch (const GuardStop& e) {
    throw StabilityError(e.what());
  }
}

void Level::setup_walls() {
  state_.walls = walls_from_case(cs_, physics_.mt);
  for (size_t w = 0; w < state_.walls.walls(); ++w) {
    const auto& in = state_.walls.info(w);
    if (in.is_mesh)
      log_->info("wall '{}': {} triangles from {}", in.name, state_.walls.mesh(in.mesh).triangles(),
                 state_.walls.mesh(in.mesh).name());
  }
}

void Level::setup_insertions() {
  const double g = norm(physics_.gravity), alpha = physics_.alpha;
  for (const auto& s : cs_.insertions) {
    InsertionParams q;
    q.name = s.name;
    q.material = physics_.mt.index_of(s.material);
    q.density = physics_.mt.material(q.material).density;
    q.cylinder = s.region.type == config::RegionType::Cylinder;
    q.lo = s.region.min;
    q.hi = s.region.max;
    q.cx = s.region.cx;
    q.cy = s.region.cy;
    q.cyl_radius = s.region.radius;
    switch (s.radius.kind) {
      case config::RadiusKind::Constant:
        q.dist = InsertionParams::Dist::Constant;
        q.r_const = s.radius.value * alpha;
        q.r_min = q.r_max = q.r_const;
        break;
      case config::RadiusKind::Uniform:
        q.dist = InsertionParams::Dist::Uniform;
        q.r_min = s.radius.min * alpha;
        q.r_max = s.radius.max * alpha;
        break;
      case config::RadiusKind::Discrete: {
        q.dist = InsertionParams::Dist::Discrete;
        double c = 0.0;
        for (size_t k = 0; k < s.radius.values.size(); ++k) {
          q.values.push_back(s.radius.values[k] * alpha);
          c += s.radius.fractions[k];
          q.cumulative.push_back(c);
        }
        q.r_min = *std::min_element(q.values.begin(), q.values.end());
        q.r_max = *std::max_element(q.values.begin(), q.values.end());
        break;
      }
    }
    const double mean_mass =
        q.density * 4.0 / 3.0 * std::numbers::pi * s.radius.mean_volume_factor() * alpha * alpha * alpha;
    q.target = s.count >= 0 ? s.count : static_cast<int64_t>(std::llround(s.mass / mean_mass));
    if (s.rate > 0.0) q.rate = s.rate;
    else if (s.mass_rate > 0.0) q.rate = s.mass_rate / mean_mass;
    q.start = s.start;
    q.velocity = s.velocity;
    q.follow_gap = s.follow_gap;
    q.follow_height = s.follow_height > 0.0 ? s.follow_height : 10.0 * q.r_max;
    q.max_attempts = s.max_attempts;
    // Automatic batch period: the time a batch needs to clear its slab, at least one step.
    const double slab = s.follow_gap >= 0.0 ? q.follow_height : q.hi.z - q.lo.z;
    double period = s.interval;
    if (period <= 0.0) {
      const double vz = std::fabs(q.velocity.z);
      period = vz > 0.0 ? slab / vz : std::sqrt(2.0 * slab / std::max(g, 1e-12));
    }
    q.interval = std::max(period, physics_.dt);
    log_->info("insertion '{}': {} particles, {}, batch every {:.4g} s", q.name, q.target,
               q.rate > 0.0 ? fmt::format("{:.4g} particles/s", q.rate) : std::string("all at once"), q.interval);
    scene_.ins.emplace_back(q);
  }
}

void Level::setup_measurements() {
  for (const auto& s : cs_.probes) {
    ProbeParams q;
    q.name = s.name;
    q.point = s.point;
    q.normal = unit(s.normal);
    q.radius = s.radius;
    q.sample_interval = 1.0 / s.sample_rate;
    q.window_start = s.window_start;
    q.window_end = s.window_end;
    q.window_known = s.window_event.empty();
    scene_.probes.emplace_back(q);
    scene_.probe_events.push_back(s.window_event);
  }
  for (const auto& s : cs_.grids) {
    GridParams q;
    q.name = s.name;
    q.origin = s.min;
    q.h = s.cell_size;
    q.nx = std::max(1, static_cast<int>(std::ceil((s.max.x - s.min.x) / s.cell_size - 1e-9)));
    q.ny = std::max(1, static_cast<int>(std::ceil((s.max.y - s.min.y) / s.cell_size - 1e-9)));
    q.nz = std::max(1, static_cast<int>(std::ceil((s.max.z - s.min.z) / s.cell_size - 1e-9)));
    Scene::Grid g{CellGrid(q), 1, s.output_interval, s.output_interval, 0, nullptr, {}, {}};
    const double si = s.sample_interval > 0.0 ? s.sample_interval : s.output_interval;
    g.sample_every = std::max<uint64_t>(1, static_cast<uint64_t>(std::llround(si / physics_.dt)));
    if (!opt_.out_dir.empty() && comm_.rank() == 0)
      g.series = std::make_unique<io::GridSeries>(opt_.out_dir, q.name, q.origin, q.h, q.nx, q.ny, q.nz,
                                                  !opt_.restart.empty());
    scene_.grids.push_back(std::move(g));
  }
  if (cs_.output.energy_interval > 0.0)
    account_ = std::make_unique<EnergyAccount>(
        std::max<uint64_t>(1, static_cast<uint64_t>(std::llround(cs_.output.energy_interval / physics_.dt))),
        physics_.gravity, physics_.dt);
}

void Level::load_initial_state(std::vector<ParticleKind>& kinds, std::vector<PlacedParticle>& placed, bool add) {
  const auto& in = *cs_.initial;
  const int mat = physics_.mt.index_of(in.material);
  const auto list = read_initial_particles(in, cs_.domain, mat, physics_.mt.material(mat).density);
  for (const ParticleInit& pi : list) {
    placed.push_back({{pi.x, pi.radius}, mat, pi.id});
    ++run_.explicit_count;
    run_.explicit_mass += sphere_mass(pi.density, pi.radius);
    run_.next_id = std::max(run_.next_id, pi.id + 1);
    if (add && stepper_.dec.owner(pi.x) == comm_.rank()) add_particle(pi);
  }
  if (!list.empty()) kinds.push_back(initial_kind(list, mat));  // as mlcg check previews it
  log_->info("initial state: {} particles from {}", list.size(), in.file);
}

void Level::add_particle(const ParticleInit& pi) {
  state_.p.add(pi);
  if (state_.history_loaded) {  // keep the per-particle history aligned with the particles
    state_.pair_hist.append(nullptr, nullptr, 0);
    state_.wall_hist.append(nullptr, nullptr, 0);
  }
  state_.p.f.back() = state_.p.mass.back() * physics_.gravity;
  run_.next_id = std::max(run_.next_id, pi.id + 1);
  stepper_.rebuild_pending = true;
  if (account_) account_->carried_in(state_.p, state_.p.n_local() - 1);
}

void Level::resolve_end_time() {
  if (cs_.time.end >= 0.0) {
    run_.end_time = cs_.time.end;
    return;
  }
  for (size_t e = 0; e < cs_.events.size(); ++e)
    if (cs_.events[e].name == cs_.time.end_event && scene_.events[e].fired)
      run_.end_time = scene_.events[e].fired_at + cs_.time.end_plus;
}

}  // namespace mlcg
