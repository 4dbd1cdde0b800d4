// Fuzz target: the level's side of the bus. One frame from "the coupler" is decoded as the level's
// client decodes it (bus::decode); a Welcome is taken as Level::connect_coupler takes it (its interval in
// whole steps, the grids the level takes part in), commands as Level::coupling_begin_step applies them to
// the coarse and the fine level of the quickstart MLCG case (grids matched, insertion list parsed, traction,
// speed limits and accelerations set, then applied to particles in the region).
// Seeds: the quickstart coupler's real Welcomes and commands (fuzz_seeds). Bad input must be refused
// with std::invalid_argument / a decode error, never crash.
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <vector>

#include "bus/channel.hpp"
#include "core/time_steps.hpp"
#include "coupling/grid_link.hpp"
#include "fuzz_support.hpp"
#include "parallel/comm.hpp"

namespace {

using namespace mlcg;

struct LevelSide {
  std::string name;
  double dt = 0.0;
  std::vector<coupling::GridLink> links;
  Particles p;  // a few particles inside and around the region
};

std::vector<LevelSide> make_levels() {
  const auto& q = fuzz::quickstart_coupler();
  const auto c = q.make();
  std::vector<LevelSide> out;
  for (size_t l = 0; l < c->config().levels.size(); ++l) {
    LevelSide s;
    s.name = c->config().levels[l].name;
    s.dt = c->config().levels[l].dt;
    s.links = coupling::links_of(c->welcome(l, 0));
    const auto& geo = c->geometry(0);
    for (size_t cell = 0; cell < geo.cells(); cell += 3) {
      ParticleInit pi;
      pi.id = static_cast<int64_t>(cell);
      pi.radius = 1e-3;
      pi.density = 1000.0;
      pi.x = geo.cell_centre(cell);
      s.p.add(pi);
    }
    out.push_back(std::move(s));
  }
  return out;
}

void welcome(const bus::Welcome& w, const LevelSide& level) {
  whole_steps(w.coupling_interval(), level.dt);
  try {
    coupling::links_of(w);
  } catch (const std::invalid_argument&) {
  }
}

void commands(const bus::IntervalCommands& cmd, LevelSide& level, const Comm& comm) {
  try {
    const auto of = coupling::commands_of(cmd, level.links, level.name);
    for (size_t l = 0; l < level.links.size(); ++l) {
      auto& link = level.links[l];
      uint64_t count = 0;
      if (link.role() == coupling::Role::Fine && of[l] && of[l]->insert_size() > 0)
        count = coupling::GridLink::parse_inserts(*of[l], 0, 1000.0, 1000).size();
      link.begin_interval(of[l], level.p, comm, count, 0.0);
      link.add_forces(level.p);
      link.finish(level.p, comm, 1e-3);
    }
  } catch (const std::invalid_argument&) {
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static std::vector<LevelSide> levels = make_levels();
  static const Comm comm;  // serial: no MPI in a fuzzer
  const bus::Decoded d = bus::decode(data, size);
  if (!d.ok()) return 0;
  for (auto& level : levels) {
    if (d.env.has_welcome()) welcome(d.env.welcome(), level);
    if (d.env.has_commands()) commands(d.env.commands(), level, comm);
  }
  return 0;
}
