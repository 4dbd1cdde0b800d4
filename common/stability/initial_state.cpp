#include "stability/initial_state.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <fmt/format.h>

#include "io/h5.hpp"

namespace mlcg {

namespace {

bool finite3(const Vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

}  // namespace

std::vector<ParticleInit> read_initial_particles(const config::InitialSpec& in, const config::DomainSpec& domain,
                                                 int material, double density) {
  const std::string where = fmt::format("{}: initial.file: {}", in.loc.str(), in.file);
  const io::H5Reader r(in.file);
  const auto x = r.read_vec3("position");
  const auto v = r.read_vec3("velocity");
  const auto w = r.read_vec3("omega");
  const auto rad = r.read<double>("radius");
  const auto ids = r.read<int64_t>("id");
  if (v.size() != x.size() || w.size() != x.size() || rad.size() != x.size() || ids.size() != x.size())
    throw std::runtime_error(fmt::format("{}: position, velocity, omega, radius and id have {}, {}, {}, {} and {} "
                                         "entries; a particle snapshot has one of each per particle",
                                         where, x.size(), v.size(), w.size(), rad.size(), ids.size()));
  std::vector<ParticleInit> out(x.size());
  for (size_t i = 0; i < x.size(); ++i) {
    const auto bad = [&](const std::string& what) {
      return std::runtime_error(fmt::format("{}: particle {} (id {}): {}", where, i, ids[i], what));
    };
    if (ids[i] < 0) throw bad("a negative id; ids are whole numbers >= 0");
    if (!finite3(x[i]) || !finite3(v[i]) || !finite3(w[i]) || !std::isfinite(rad[i]))
      throw bad("a position, velocity, omega or radius that is not a finite number");
    if (!(rad[i] > 0.0)) throw bad(fmt::format("radius {} m; a radius is > 0", rad[i]));
    for (int a = 0; a < 3; ++a)
      if (!(x[i][a] >= domain.min[a] && x[i][a] <= domain.max[a]))
        throw bad(fmt::format("its centre ({}, {}, {}) m lies outside the domain ({}, {}, {}) to ({}, {}, {}) m; "
                              "keep the particles inside [domain]",
                              x[i].x, x[i].y, x[i].z, domain.min.x, domain.min.y, domain.min.z, domain.max.x,
                              domain.max.y, domain.max.z));
    out[i] = ParticleInit{ids[i], material, rad[i], density, x[i], v[i], w[i]};
  }
  std::vector<int64_t> sorted = ids;
  std::sort(sorted.begin(), sorted.end());
  if (const auto dup = std::adjacent_find(sorted.begin(), sorted.end()); dup != sorted.end())
    throw std::runtime_error(fmt::format("{}: id {} is given to two particles; every particle has its own id", where,
                                         *dup));
  return out;
}

}  // namespace mlcg
