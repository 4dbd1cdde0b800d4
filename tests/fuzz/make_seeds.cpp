// fuzz_seeds OUT_DIR: the seed corpora that cannot be copied from the source tree, made by the real
// writers from the shipped quickstart cases: OUT_DIR/<target>/ for bus_level, bus_coupler,
// coupler_checkpoint, manifest, hostfile, level_checkpoint and initial. scripts/fuzz.sh calls it.
#include <cstdio>
#include <exception>
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "bus/channel.hpp"
#include "fuzz_support.hpp"
#include "io/snapshot_series.hpp"
#include "level/level.hpp"

namespace fs = std::filesystem;
using namespace mlcg;

namespace {

void seed(const fs::path& dir, const std::string& name, const std::string& bytes) {
  fs::create_directories(dir);
  fuzz::write_file(dir / name, bytes);
}

// The coupler's messages (bus_level), the levels' (bus_coupler) and the coupler's checkpoints.
void coupling_seeds(const fs::path& out) {
  const auto c = fuzz::quickstart_coupler().make();
  const auto& levels = c->config().levels;
  std::vector<bus::IntervalCommands> cmds = c->initial_commands();
  for (uint64_t k = 0; k < 4; ++k) {
    const auto stats = fuzz::plausible_stats(*c, k);
    for (size_t l = 0; l < levels.size(); ++l) {
      bus::Envelope e;
      *e.mutable_stats() = stats[l];
      if (k == 0 || k == 3)
        seed(out / "bus_coupler", "stats_" + levels[l].name + std::to_string(k), bus::encode(e, levels[l].name));
      e.Clear();
      *e.mutable_commands() = cmds[l];
      seed(out / "bus_level", "commands_" + levels[l].name + std::to_string(k), bus::encode(e, "coupler"));
    }
    cmds = c->advance(k, stats);
    bus::CouplerCheckpoint cp;
    cp.set_interval(k + 1);
    cp.set_sim_time(static_cast<double>(k + 1) * c->config().interval);
    cp.set_case_hash("0123456789abcdef");
    c->save(cp);
    for (const auto& cmd : cmds) *cp.add_commands() = cmd;
    seed(out / "coupler_checkpoint", "i" + std::to_string(k + 1) + ".pb", cp.SerializeAsString());
  }
  for (size_t l = 0; l < levels.size(); ++l) {
    bus::Envelope e;
    *e.mutable_welcome() = c->welcome(l, 0);
    seed(out / "bus_level", "welcome_" + levels[l].name, bus::encode(e, "coupler"));
    e.Clear();
    auto& r = *e.mutable_register_level();
    r.set_level_name(levels[l].name);
    r.set_alpha(levels[l].alpha);
    r.set_dt(levels[l].dt);
    r.set_ranks(1);
    r.set_case_hash("0123456789abcdef");
    seed(out / "bus_coupler", "register_" + levels[l].name, bus::encode(e, levels[l].name));
  }
  bus::Envelope hb;
  hb.mutable_heartbeat()->set_waiting_for("'fine'");
  seed(out / "bus_level", "heartbeat", bus::encode(hb, "coupler"));
  bus::Envelope bye;
  bye.mutable_bye()->set_reason("finished after interval 3");
  seed(out / "bus_coupler", "bye", bus::encode(bye, "fine"));
}

// Manifests as Service::write_checkpoint writes them (with and without a previous set).
void manifest_seeds(const fs::path& out) {
  nlohmann::json m;
  m["format"] = "mlcg-hierarchy-checkpoint";
  m["interval"] = 2;
  m["sim_time"] = 0.000192;
  m["case_hash"] = "0123456789abcdef";
  m["levels"] = {{"coarse", "i2/coarse.h5"}, {"fine", "i2/fine.h5"}};
  m["coupler"] = "i2/coupler.pb";
  seed(out / "manifest", "manifest", m.dump(2) + "\n");
  nlohmann::json previous = m;
  previous.erase("format");
  previous["interval"] = 1;
  previous["levels"] = {{"coarse", "i1/coarse.h5"}, {"fine", "i1/fine.h5"}};
  previous["coupler"] = "i1/coupler.pb";
  m["previous"] = previous;
  seed(out / "manifest", "manifest_previous", m.dump(2) + "\n");
  seed(out / "manifest", "launcher", nlohmann::json{{"case", "/work/cases/quickstart/mlcg.toml"}}.dump(2) + "\n");
}

// The README's hostfile and the tests' (test_hosts, test_netns).
void hostfile_seeds(const fs::path& out) {
  seed(out / "hostfile", "readme",
       "# hosts of a two-level run\n"
       "rsh_agent /bin/true            # optional: mpirun's --mca plm_rsh_agent\n"
       "mca oob_tcp_if_include 10.77.0.0/24\n"
       "h1 slots=1 coupler address=127.0.0.1\n"
       "h2 slots=2 levels=coarse\n"
       "h3 slots=4 levels=fine,finest\n");
  seed(out / "hostfile", "netns",
       "mlcg-h1 slots=1 coupler\nmlcg-h2 slots=1 levels=coarse\nmlcg-h3 slots=1 levels=fine\n");
  seed(out / "hostfile", "local", "localhost slots=4\n");
}

// Checkpoints and snapshots of the quickstart hopper while it fills.
void level_seeds(const fs::path& out) {
  const auto cs = fuzz::shipped_case("cases/quickstart/case.toml");
  LevelOptions opt;
  opt.quiet = true;
  opt.single_rank = true;
  Level level(cs, opt);
  const fs::path run = fuzz::scratch("seed_run");
  io::SnapshotSeries snapshots(run, "particles");
  for (int stage = 1; stage <= 2; ++stage) {
    for (int s = 0; s < 400; ++s) level.step_once();
    fs::create_directories(out / "level_checkpoint");
    level.write_checkpoint(out / "level_checkpoint" / ("quickstart" + std::to_string(stage) + ".h5"));
    const Particles& p = level.particles();
    snapshots.write(level.time(), level.step(), p.n_local(), p.x.data(), p.v.data(), p.omega.data(), p.radius.data(),
                    p.id.data());
  }
  fs::create_directories(out / "initial");
  for (const auto& e : fs::recursive_directory_iterator(run))
    if (e.path().extension() == ".h5") fs::copy_file(e.path(), out / "initial" / e.path().filename());
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: fuzz_seeds OUT_DIR\n");
    return 2;
  }
  try {
    const fs::path out = argv[1];
    coupling_seeds(out);
    manifest_seeds(out);
    hostfile_seeds(out);
    level_seeds(out);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "fuzz_seeds: %s\n", e.what());
    return 1;
  }
  return 0;
}
