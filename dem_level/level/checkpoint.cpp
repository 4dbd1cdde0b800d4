// Checkpoint and restart: the complete state of a level in one HDF5 file
// (written to a temporary name, then renamed). Restarting from it and running
// N steps gives bit for bit the state of an uninterrupted run, because both
// rebuild their neighbour lists at the step after the checkpoint.
#include <cmath>
#include <cstring>
#include <sstream>
#include <tuple>
#include <type_traits>
#include <variant>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "io/h5.hpp"
#include "level/checkpoint_scene.hpp"
#include "level/level.hpp"

namespace mlcg {

namespace {
constexpr int64_t kCheckpointVersion = 1;

void write_history(io::H5Writer& w, const std::string& g, const ContactHistory& h) {
  w.write(g + "/first", h.first);
  w.write(g + "/key", h.key);
  w.write_vec3(g + "/value", h.value);
}

ContactHistory read_history(const io::H5Reader& r, const std::string& g) {
  ContactHistory h;
  h.first = r.read<int32_t>(g + "/first");
  h.key = r.read<int64_t>(g + "/key");
  h.value = r.read_vec3(g + "/value");
  return h;
}

// A checkpoint cut short, edited or damaged on disk: refused before anything of it is used.
[[noreturn]] void damaged(const io::H5Reader& r, const std::string& what) {
  throw std::runtime_error(fmt::format("{}: {}; the checkpoint is damaged: continue from an intact one or start the "
                                       "run afresh",
                                       r.path().string(), what));
}

void check_length(const io::H5Reader& r, const std::string& dataset, size_t got, size_t want, const std::string& per) {
  if (got != want) damaged(r, fmt::format("{} has {} entries, expected {} ({})", dataset, got, want, per));
}

bool finite3(const Vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

// Every particle array as long as particles/x, every value finite, radii and masses > 0.
void check_particles(const io::H5Reader& r, const Particles& p) {
  const size_t n = p.x.size();
  const std::pair<const char*, size_t> lengths[] = {
      {"v", p.v.size()},         {"f", p.f.size()},           {"omega", p.omega.size()},
      {"torque", p.torque.size()}, {"radius", p.radius.size()}, {"mass", p.mass.size()},
      {"inv_mass", p.inv_mass.size()}, {"inv_inertia", p.inv_inertia.size()}, {"id", p.id.size()},
      {"material", p.material.size()}};
  for (const auto& [name, got] : lengths) check_length(r, std::string("particles/") + name, got, n, "one per particle");
  for (size_t i = 0; i < n; ++i) {
    const bool finite = finite3(p.x[i]) && finite3(p.v[i]) && finite3(p.f[i]) && finite3(p.omega[i]) &&
                        finite3(p.torque[i]) && std::isfinite(p.inv_mass[i]) && std::isfinite(p.inv_inertia[i]);
    if (!finite) damaged(r, fmt::format("particle {} (id {}) has a value that is not a finite number", i, p.id[i]));
    if (!(p.radius[i] > 0.0 && std::isfinite(p.radius[i]) && p.mass[i] > 0.0 && std::isfinite(p.mass[i])))
      damaged(r, fmt::format("particle {} (id {}) has radius {} m and mass {} kg; both are > 0", i, p.id[i],
                             p.radius[i], p.mass[i]));
  }
}

// Compressed rows: first[0] = 0, never decreasing, first[n] = the number of keys and values.
void check_history(const io::H5Reader& r, const std::string& g, const ContactHistory& h, size_t n) {
  check_length(r, g + "/first", h.first.size(), n + 1, "one per particle, plus one");
  bool rows = h.first.front() == 0;
  for (size_t i = 0; i < n && rows; ++i) rows = h.first[i + 1] >= h.first[i];
  if (!rows || static_cast<size_t>(h.first.back()) != h.key.size())
    damaged(r, g + "/first is not a list of row starts from 0 to the number of keys");
  check_length(r, g + "/value", h.value.size(), h.key.size(), "one per key");
  for (const Vec3& v : h.value)
    if (!finite3(v)) damaged(r, g + "/value has a value that is not a finite number");
}

// Per axis: the grid's count of boxes plus one cut, finite and ascending.
void check_cuts(const io::H5Reader& r, const std::array<std::vector<double>, 3>& cuts,
                const std::vector<int32_t>& grid) {
  for (size_t a = 0; a < 3; ++a) {
    const std::string name = std::string("decomposition/cuts_") + "xyz"[a];
    check_length(r, name, cuts[a].size(), static_cast<size_t>(grid[a]) + 1,
                 "one per box of the decomposition grid, plus one");
    for (size_t k = 0; k < cuts[a].size(); ++k)
      if (!std::isfinite(cuts[a][k]) || (k > 0 && !(cuts[a][k] > cuts[a][k - 1])))
        damaged(r, name + " is not an ascending list of finite numbers");
  }
}
// One number among a group's attributes in the checkpoint (or the insertion generator's state) and
// where it lives while the level runs. `optional`: older checkpoints lack it and it reads as zero.
struct Scalar {
  std::string name;
  std::variant<uint64_t*, int64_t*, int*, bool*, double*, std::mt19937_64*> value;
  bool optional = false;
};

// Every scalar of a checkpoint's root, in the order written: the writer and the reader both work from
// this list, so a new one is one line here (and a member of RunState). dt and alpha are read only to
// be compared with the case; the coupling counters are written from coupling_report().
std::vector<Scalar> root_scalars(RunState& s, double& dt, double& alpha, Level::CouplingReport& c) {
  std::vector<Scalar> f = {{"step", &s.step}, {"dt", &dt}, {"alpha", &alpha}, {"next_id", &s.next_id},
                           {"removed", &s.removed}, {"removed_mass", &s.removed_mass}};
  for (int e = 0; e < kExits; ++e) {  // older checkpoints do not split the removals by exit
    const std::string exit = to_string(static_cast<Exit>(e));
    f.push_back({"removed_" + exit, &s.removed_by[e], true});
    f.push_back({"removed_mass_" + exit, &s.removed_mass_by[e], true});
  }
  f.insert(f.end(), {{"explicit_count", &s.explicit_count},
                     {"explicit_mass", &s.explicit_mass},
                     {"particle_steps", &s.particle_steps},
                     {"max_particles", &s.max_particles},
                     {"rebuilds", &s.rebuilds},
                     {"end_time", &s.end_time},
                     {"next_stats", &s.next_stats},
                     {"next_snapshot", &s.next_snapshot},
                     {"next_checkpoint", &s.next_checkpoint},
                     {"snapshots", &s.snapshots},
                     {"wall_seconds", &s.wall_seconds_before},
                     // The coupling counters came with later builds.
                     {"coupling_inserted", &c.inserted, true},
                     {"coupling_worst_insert_overlap", &c.worst_insert_overlap, true},
                     {"coupling_worst_insert_wall_overlap", &c.worst_insert_wall_overlap, true},
                     {"coupling_inserted_outside_walls", &c.inserted_outside_walls, true},
                     {"rng", &s.rng}});
  return f;
}

// The attributes of group insertion/<k>: one insertion's progress.
std::vector<Scalar> insertion_scalars(Inserter::State& s) {
  return {{"requested", &s.requested}, {"placed", &s.placed},
          {"failed", &s.failed},       {"pending", &s.pending},
          {"placed_mass", &s.placed_mass}, {"failed_mass", &s.failed_mass_estimate},
          {"batch", &s.batch},         {"stalled", &s.stalled},
          {"done", &s.done}};
}

// Unsigned integers are stored as uint64, int and bool as int64, the generator as its text.
void write_scalar(io::H5Writer& w, const std::string& obj, const Scalar& f) {
  std::visit(
      [&](auto* v) {
        using T = std::remove_pointer_t<decltype(v)>;
        if constexpr (std::is_same_v<T, std::mt19937_64>) {
          std::ostringstream text;
          text << *v;
          w.set_attr(obj, f.name, text.str());
        } else if constexpr (std::is_same_v<T, bool> || std::is_same_v<T, int>) {
          w.set_attr(obj, f.name, static_cast<int64_t>(*v));
        } else {
          w.set_attr(obj, f.name, *v);
        }
      },
      f.value);
}

void read_scalar(const io::H5Reader& r, const std::string& obj, const Scalar& f) {
  if (f.optional && !r.has_attr(obj, f.name)) return;
  std::visit(
      [&](auto* v) {
        using T = std::remove_pointer_t<decltype(v)>;
        if constexpr (std::is_same_v<T, std::mt19937_64>) {
          std::istringstream text(r.attr_string(obj, f.name));
          text >> *v;
        } else if constexpr (std::is_same_v<T, double>) {
          *v = r.attr_double(obj, f.name);
        } else if constexpr (std::is_same_v<T, bool>) {
          *v = r.attr_int64(obj, f.name) != 0;
        } else if constexpr (std::is_signed_v<T>) {
          *v = static_cast<T>(r.attr_int64(obj, f.name));
        } else {
          *v = r.attr_uint64(obj, f.name);
        }
      },
      f.value);
}
// Per-rank values written by `writers` ranks in rank order (n each): this rank's own n if the rank count is the
// same, else all of them summed on rank 0 in rank order and zeros elsewhere (each such value is a sum over the
// ranks, e.g. a probe's open sample or a grid's pending crossings).
std::vector<double> rank_share(const std::vector<double>& all, size_t writers, const Comm& comm) {
  const size_t n = writers == 0 ? 0 : all.size() / writers;
  if (writers == static_cast<size_t>(comm.size())) {
    const auto from = all.begin() + static_cast<std::ptrdiff_t>(static_cast<size_t>(comm.rank()) * n);
    return {from, from + static_cast<std::ptrdiff_t>(n)};
  }
  std::vector<double> out(n, 0.0);
  if (comm.rank() == 0)
    for (size_t q = 0; q < writers; ++q)
      for (size_t j = 0; j < n; ++j) out[j] += all[q * n + j];
  return out;
}

}  // namespace

void Level::write_checkpoint(const std::filesystem::path& path) const {
  // Particles and their contact history, gathered from all ranks in rank order.
  ContactHistory ph, wh;
  // Restarted, no list built yet: the history is still per particle.
  if (stepper_.keep_history && state_.history_loaded) {
    ph = state_.pair_hist;
    wh = state_.wall_hist;
  } else if (stepper_.keep_history) {
    state_.nl.save_history(state_.p, ph);
    state_.walls.save_history(state_.p, wh);
  } else {
    ph.clear(state_.p.size());
    wh.clear(state_.p.size());
  }
  std::vector<char> buf;
  ByteWriter bw(buf);
  for (size_t i = 0; i < state_.p.n_local(); ++i) pack_particle(bw, state_.p, i, ph, wh);
  std::vector<double> open_mass;  // each rank's part of each probe's open sample
  for (const auto& pr : scene_.probes) open_mass.push_back(pr.open_mass());
  std::vector<char> om(reinterpret_cast<const char*>(open_mass.data()),
                       reinterpret_cast<const char*>(open_mass.data() + open_mass.size()));
  const std::vector<double> pending = coupling_pending();  // empty when uncoupled
  std::vector<char> pb(reinterpret_cast<const char*>(pending.data()),
                       reinterpret_cast<const char*>(pending.data() + pending.size()));
  const auto all = comm_.gather0(buf);
  const auto all_open = comm_.gather0(om);
  const auto all_pending = comm_.gather0(pb);
  const CouplingReport coupling = coupling_report();  // collective; zeros when uncoupled
  if (comm_.rank() == 0) rank0_output([&] { write_checkpoint_file(path, all, all_open, all_pending, coupling); });
  sync_output();
}

void Level::write_checkpoint_file(const std::filesystem::path& path, const std::vector<char>& all,
                                  const std::vector<char>& all_open, const std::vector<char>& all_pending,
                                  const CouplingReport& coupling) const {
  io::H5Writer w(path);
  w.set_attr("/", "format", "mlcg-level-checkpoint");
  w.set_attr("/", "version", kCheckpointVersion);
  w.set_attr("/", "case", cs_.path);
  w.set_attr("/", "level", lvl_.name);
  // root_scalars() points into what it is given, for the reader too: the writer gives it copies.
  RunState run = run_;
  double dt = physics_.dt, alpha = physics_.alpha;
  CouplingReport cr = coupling;
  for (const Scalar& f : root_scalars(run, dt, alpha, cr)) write_scalar(w, "/", f);

  Particles p;
  ContactHistory hp, hw;
  hp.clear(0);
  hw.clear(0);
  ByteReader rd(all);
  while (!rd.done()) unpack_particle(rd, p, hp, hw);
  w.write_vec3("particles/x", p.x);
  w.write_vec3("particles/v", p.v);
  w.write_vec3("particles/f", p.f);
  w.write_vec3("particles/omega", p.omega);
  w.write_vec3("particles/torque", p.torque);
  w.write("particles/radius", p.radius);
  w.write("particles/mass", p.mass);
  w.write("particles/inv_mass", p.inv_mass);
  w.write("particles/inv_inertia", p.inv_inertia);
  w.write("particles/id", p.id);
  w.write("particles/material", p.material);
  write_history(w, "history/pairs", hp);
  write_history(w, "history/walls", hw);

  // The decomposition, so that a restart on the same grid keeps every particle on its rank.
  const auto& grid = stepper_.dec.grid();
  w.write("decomposition/grid", std::vector<int32_t>{grid[0], grid[1], grid[2]});
  w.write("decomposition/cuts_x", stepper_.dec.cuts()[0]);
  w.write("decomposition/cuts_y", stepper_.dec.cuts()[1]);
  w.write("decomposition/cuts_z", stepper_.dec.cuts()[2]);
  std::vector<double> opens(all_open.size() / sizeof(double));
  if (!opens.empty()) std::memcpy(opens.data(), all_open.data(), all_open.size());
  w.write("probes/open_mass_per_rank", opens);
  // A level that sends its statistics early ([coupling] lead) has counted the interval's last steps into the
  // next statistics: each rank's sums, to be restored on the same rank.
  std::vector<double> pending(all_pending.size() / sizeof(double));
  if (!pending.empty()) std::memcpy(pending.data(), all_pending.data(), all_pending.size());
  w.write("coupling/pending_per_rank", pending);
  w.write("coupling/pending_ranks", std::vector<int32_t>{comm_.size()});

  write_scene_state(w);
  w.commit();
}

void Level::write_scene_state(io::H5Writer& w) const {
  std::vector<uint8_t> active;
  for (size_t k = 0; k < state_.walls.walls(); ++k) active.push_back(state_.walls.active(k) ? 1 : 0);
  w.write("walls/active", active);

  for (size_t k = 0; k < scene_.ins.size(); ++k) {
    Inserter::State s = scene_.ins[k].state();
    const std::string g = fmt::format("insertion/{}", k);
    w.create_group(g);
    for (const Scalar& f : insertion_scalars(s)) write_scalar(w, g, f);
  }
  for (size_t k = 0; k < scene_.probes.size(); ++k) {
    const auto& pr = scene_.probes[k];
    const auto& s = pr.state();
    const std::string g = fmt::format("probes/{}", k);
    w.create_group(g);
    w.set_attr(g, "sample_start", s.sample_start);
    w.set_attr(g, "total_mass", s.total_mass);
    w.set_attr(g, "window_start", pr.params().window_start);
    w.set_attr(g, "window_end", pr.params().window_end);
    w.set_attr(g, "window_known", static_cast<int64_t>(pr.params().window_known));
    std::vector<double> te, rate;
    for (const auto& smp : s.samples) {
      te.push_back(smp.t_end);
      rate.push_back(smp.rate);
    }
    w.write(g + "/t_end", te);
    w.write(g + "/rate", rate);
  }
  for (size_t k = 0; k < scene_.grids.size(); ++k) {
    const auto& gr = scene_.grids[k];
    const auto& s = gr.grid.state();
    const std::string g = fmt::format("grids/{}", k);
    w.create_group(g);
    w.set_attr(g, "samples", s.samples);
    w.set_attr(g, "next_output", gr.next_output);
    w.set_attr(g, "outputs", gr.outputs);
    w.write(g + "/phi", s.phi);
    w.write(g + "/mass", s.mass);
    w.write(g + "/max_speed", s.max_speed);
    w.write(g + "/stress6", s.stress6);
    w.write(g + "/count", s.count);
    w.write_vec3(g + "/momentum", s.momentum);
  }
  std::vector<uint8_t> fired;
  std::vector<double> fired_at, next_check;
  for (const auto& e : scene_.events) {
    fired.push_back(e.fired ? 1 : 0);
    fired_at.push_back(e.fired_at);
    next_check.push_back(e.next_check);
  }
  w.write("events/fired", fired);
  w.write("events/fired_at", fired_at);
  w.write("events/next_check", next_check);
  const std::string scene = scene_record(cs_, lvl_, case_placed_).dump();
  w.write("scene/record", reinterpret_cast<const uint8_t*>(scene.data()), scene.size());
  std::string rows;
  for (const auto& r : out_.series_rows) rows += r + "\n";
  w.write("series/rows", reinterpret_cast<const uint8_t*>(rows.data()), rows.size());
}

void Level::load_checkpoint(const std::filesystem::path& path) {
  io::H5Reader r(path);
  const auto where = path.string();
  if (!r.has_attr("/", "format") || r.attr_string("/", "format") != "mlcg-level-checkpoint")
    throw std::runtime_error(where + ": not an MLCG level checkpoint");
  if (r.attr_int64("/", "version") != kCheckpointVersion)
    throw std::runtime_error(fmt::format("{}: checkpoint format version {} is not supported (this build reads {})",
                                         where, r.attr_int64("/", "version"), kCheckpointVersion));
  RunState run;
  double dt = 0.0, alpha = 0.0;
  CouplingReport cr;
  for (const Scalar& f : root_scalars(run, dt, alpha, cr)) read_scalar(r, "/", f);
  if (dt != physics_.dt || alpha != physics_.alpha)
    throw std::runtime_error(fmt::format("{}: written with dt = {} s and alpha = {}, but the case now has dt = {} s "
                                         "and alpha = {}",
                                         where, dt, alpha, physics_.dt, physics_.alpha));
  const SceneMap map = check_scene(r);
  run_ = run;
  coupling_restored_ = cr;
  restore_coupling_pending(r);
  load_particles(r, map);
  restore_scene_state(r, map);
  stepper_.rebuild_pending = true;
  log_->info("restarted from {} at step {} (t = {:.6g} s) with {} particles", where, run_.step, time(),
             state_.p.n_local());
}

SceneMap Level::check_scene(const io::H5Reader& r) const {
  // Checkpoints written before the record existed continue unchecked, in the case's order.
  nlohmann::json saved;
  if (r.has("scene/record")) {
    const auto bytes = r.read<uint8_t>("scene/record");
    saved = nlohmann::json::parse(bytes.begin(), bytes.end(), nullptr, false);
    if (saved.is_discarded())
      throw std::runtime_error(r.path().string() + ": its scene record (scene/record) is not valid JSON");
  } else {
    log_->warn("{}: written before checkpoints recorded their scene; the case cannot be checked against it",
               r.path().string());
  }
  const nlohmann::json now = scene_record(cs_, lvl_, case_placed_);
  if (saved.is_object()) {
    const auto diffs = scene_differences(saved, now);
    if (!diffs.empty())
      throw std::runtime_error(fmt::format("{}: written for another scene than {}: {}; restart with the case the "
                                           "checkpoint was written with, or start the run afresh",
                                           r.path().string(), cs_.path, fmt::join(diffs, "; ")));
  }
  return scene_map(saved, now);
}

void Level::load_particles(const io::H5Reader& r, const SceneMap& map) {
  // Every rank reads all particles and keeps those in its box. On the grid the
  // checkpoint was written with, the boxes are restored exactly, so each rank
  // gets back its particles in their order (a bit-identical continuation).
  Particles p;
  p.x = r.read_vec3("particles/x");
  p.v = r.read_vec3("particles/v");
  p.f = r.read_vec3("particles/f");
  p.omega = r.read_vec3("particles/omega");
  p.torque = r.read_vec3("particles/torque");
  p.radius = r.read<double>("particles/radius");
  p.mass = r.read<double>("particles/mass");
  p.inv_mass = r.read<double>("particles/inv_mass");
  p.inv_inertia = r.read<double>("particles/inv_inertia");
  p.id = r.read<int64_t>("particles/id");
  p.material = r.read<int32_t>("particles/material");
  check_particles(r, p);
  for (auto& m : p.material) {  // the case may list the same materials in another order
    const int to = m >= 0 && static_cast<size_t>(m) < map.material_of_saved.size() ? map.material_of_saved[m] : -1;
    if (to < 0)
      throw std::runtime_error(fmt::format("{}: a particle has material {}, which the case does not define",
                                           r.path().string(), m));
    m = to;
  }
  ContactHistory pairs = read_history(r, "history/pairs"), walls = read_history(r, "history/walls");
  check_history(r, "history/pairs", pairs, p.x.size());
  check_history(r, "history/walls", walls, p.x.size());
  const auto grid = r.read<int32_t>("decomposition/grid");
  check_length(r, "decomposition/grid", grid.size(), 3, "one per axis");
  const bool same_grid = grid[0] == stepper_.dec.grid()[0] && grid[1] == stepper_.dec.grid()[1] &&
                         grid[2] == stepper_.dec.grid()[2];
  if (same_grid) {
    const std::array<std::vector<double>, 3> cuts{r.read<double>("decomposition/cuts_x"),
                                                  r.read<double>("decomposition/cuts_y"),
                                                  r.read<double>("decomposition/cuts_z")};
    check_cuts(r, cuts, grid);
    stepper_.dec.set_cuts(cuts);
  } else {
    log_->info("{}: written on a {} x {} x {} grid, continuing on {} x {} x {}", r.path().string(), grid[0], grid[1],
               grid[2], stepper_.dec.grid()[0], stepper_.dec.grid()[1], stepper_.dec.grid()[2]);
  }
  std::vector<int32_t> mine;
  for (size_t i = 0; i < p.x.size(); ++i)
    if (stepper_.dec.owner(p.x[i]) == comm_.rank()) mine.push_back(static_cast<int32_t>(i));
  stepper_.global_particles = static_cast<int64_t>(p.x.size());
  p.permute(mine);  // also sets the local count
  state_.p = std::move(p);

  state_.pair_hist = std::move(pairs);
  state_.wall_hist = std::move(walls);
  state_.pair_hist.permute(mine, mine.size());
  state_.wall_hist.permute(mine, mine.size());
  state_.history_loaded = true;
}

void Level::restore_scene_state(const io::H5Reader& r, const SceneMap& map) {
  const auto active = r.read<uint8_t>("walls/active");
  if (active.size() != state_.walls.walls())
    throw std::runtime_error(fmt::format("{}: has {} walls, the case has {}", r.path().string(), active.size(),
                                         state_.walls.walls()));
  for (size_t k = 0; k < active.size(); ++k) state_.walls.set_active(k, active[static_cast<size_t>(map.walls[k])] != 0);
  for (size_t k = 0; k < scene_.ins.size(); ++k) {
    const std::string g = fmt::format("insertion/{}", map.insertions[k]);
    for (const Scalar& f : insertion_scalars(scene_.ins[k].state())) read_scalar(r, g, f);
  }
  // Events first: a probe added since counts its window from an event that has already fired.
  const auto fired = r.read<uint8_t>("events/fired");
  const auto fired_at = r.read<double>("events/fired_at");
  const auto next_check = r.read<double>("events/next_check");
  check_length(r, "events/fired_at", fired_at.size(), fired.size(), "one per event");
  check_length(r, "events/next_check", next_check.size(), fired.size(), "one per event");
  for (size_t e = 0; e < scene_.events.size(); ++e) {
    const int from = map.events[e];
    if (from < 0 || static_cast<size_t>(from) >= fired.size()) continue;  // added since: not fired yet
    scene_.events[e].fired = fired[static_cast<size_t>(from)] != 0;
    scene_.events[e].fired_at = fired_at[static_cast<size_t>(from)];
    scene_.events[e].next_check = next_check[static_cast<size_t>(from)];
  }
  restore_probes(r, map);
  restore_grids(r, map);
  const auto rows = r.read<uint8_t>("series/rows");
  out_.series_rows.clear();
  std::string line;
  for (uint8_t c : rows) {
    if (c == '\n') {
      out_.series_rows.push_back(line);
      line.clear();
    } else {
      line.push_back(static_cast<char>(c));
    }
  }
}

void Level::restore_coupling_pending(const io::H5Reader& r) {
  coupling_pending_restored_.clear();
  if (!r.has("coupling/pending_per_rank")) return;  // written before [coupling] lead: nothing pending
  const auto all = r.read<double>("coupling/pending_per_rank");
  const auto ranks = r.read<int32_t>("coupling/pending_ranks");
  if (all.empty() || ranks.size() != 1 || ranks[0] < 1 || all.size() % static_cast<size_t>(ranks[0]) != 0) return;
  coupling_pending_restored_ = rank_share(all, static_cast<size_t>(ranks[0]), comm_);
}

void Level::restore_probes(const io::H5Reader& r, const SceneMap& map) {
  const auto opens = r.read<double>("probes/open_mass_per_rank");
  const size_t saved = map.saved_probes;
  // This rank's part of each probe's open sample (its own if the rank count is the same, else all on rank 0).
  const std::vector<double> mine = rank_share(opens, saved == 0 ? 0 : opens.size() / saved, comm_);
  for (size_t k = 0; k < scene_.probes.size(); ++k) {
    auto& pr = scene_.probes[k];
    auto& s = pr.state();
    const int from = map.probes[k];
    if (from < 0) {  // added since the checkpoint: it measures from now on
      s.sample_start = time();
      for (size_t e = 0; e < scene_.events.size(); ++e)
        if (scene_.events[e].fired && cs_.events[e].name == scene_.probe_events[k]) {
          pr.params().window_start = scene_.events[e].fired_at + cs_.probes[k].window_start;
          pr.params().window_end = scene_.events[e].fired_at + cs_.probes[k].window_end;
          pr.params().window_known = true;
        }
      log_->info("probe '{}' is not in the checkpoint: it measures from t = {:.6g} s on", pr.params().name, time());
      continue;
    }
    const auto j = static_cast<size_t>(from);
    const std::string g = fmt::format("probes/{}", j);
    s.sample_start = r.attr_double(g, "sample_start");
    s.mass = j < mine.size() ? mine[j] : 0.0;
    s.total_mass = r.attr_double(g, "total_mass");
    pr.params().window_start = r.attr_double(g, "window_start");
    pr.params().window_end = r.attr_double(g, "window_end");
    pr.params().window_known = r.attr_int64(g, "window_known") != 0;
    const auto te = r.read<double>(g + "/t_end");
    const auto rate = r.read<double>(g + "/rate");
    check_length(r, g + "/rate", rate.size(), te.size(), "one per sample time in " + g + "/t_end");
    s.samples.clear();
    for (size_t q = 0; q < te.size(); ++q) s.samples.push_back({te[q], rate[q]});
  }
}

void Level::restore_grids(const io::H5Reader& r, const SceneMap& map) {
  for (size_t k = 0; k < scene_.grids.size(); ++k) {
    auto& gr = scene_.grids[k];
    auto& s = gr.grid.state();
    if (map.grids[k] < 0) {  // added since the checkpoint: its first average ends at the next whole output interval
      gr.next_output = (std::floor(time() / gr.output_interval + 1e-9) + 1.0) * gr.output_interval;
      log_->info("grid '{}' is not in the checkpoint: it averages from t = {:.6g} s on", cs_.grids[k].name, time());
      continue;
    }
    const std::string g = fmt::format("grids/{}", map.grids[k]);
    s.samples = r.attr_int64(g, "samples");
    gr.next_output = r.attr_double(g, "next_output");
    gr.outputs = r.attr_int64(g, "outputs");
    s.phi = r.read<double>(g + "/phi");
    s.mass = r.read<double>(g + "/mass");
    s.max_speed = r.read<double>(g + "/max_speed");
    s.stress6 = r.read<double>(g + "/stress6");
    s.count = r.read<double>(g + "/count");
    s.momentum = r.read_vec3(g + "/momentum");
    const size_t n = gr.grid.params().cells();
    for (const auto& [name, got, per] : {std::tuple{"phi", s.phi.size(), 1}, {"mass", s.mass.size(), 1},
                                         {"max_speed", s.max_speed.size(), 1}, {"count", s.count.size(), 1},
                                         {"stress6", s.stress6.size(), 6}, {"momentum", s.momentum.size(), 1}})
      check_length(r, g + "/" + name, got, static_cast<size_t>(per) * n, per == 1 ? "one per cell" : "6 per cell");
  }
}

}  // namespace mlcg
