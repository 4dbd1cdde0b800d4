#pragma once
// Particle state as a structure of arrays: one contiguous array per field.
// Indices [0, n_local) are owned particles; ghosts (copies of a neighbouring
// rank's particles, added by the MPI layer) follow at [n_local, size()).
// Every per-particle array is reordered together through permute(), so
// spatial sorting, removal and migration share one code path.
#include <cstdint>
#include <vector>

#include "core/vec3.hpp"

namespace mlcg {

struct ParticleInit {
  int64_t id = 0;
  int material = 0;
  double radius = 0.0;
  double density = 0.0;
  Vec3 x, v, omega;
};

class Particles {
 public:
  std::vector<Vec3> x, v, f, omega, torque;
  std::vector<double> radius, mass, inv_mass, inv_inertia;
  std::vector<int64_t> id;
  std::vector<int32_t> material;

  size_t size() const { return x.size(); }
  size_t n_local() const { return n_local_; }

  void add(const ParticleInit& p);  // a local particle; only while there are no ghosts
  // A copy of another rank's particle, after the local ones (forces stay zero).
  void add_ghost(const Vec3& x, const Vec3& v, const Vec3& omega, double radius, double mass, int64_t id,
                 int32_t material);
  void drop_ghosts();
  size_t n_ghost() const { return x.size() - n_local_; }
  // Keep only the particles listed, in that order: new index k holds old index new_to_old[k].
  void permute(const std::vector<int32_t>& new_to_old);
  void clear_forces();
  void reserve(size_t n);

 private:
  size_t n_local_ = 0;
};

// Per-particle lists of (partner key, tangential overlap) for contacts that
// must survive neighbour-list rebuilds, reordering and migration. A partner
// key is a particle id (>= 0) or a wall key (< 0). Compressed row storage.
struct ContactHistory {
  std::vector<int32_t> first{0};  // size n+1
  std::vector<int64_t> key;
  std::vector<Vec3> value;

  void clear(size_t n) { first.assign(n + 1, 0); key.clear(); value.clear(); }
  size_t particles() const { return first.size() - 1; }
  // Overlap stored for particle i with partner k; zero when none.
  Vec3 find(size_t i, int64_t partner) const {
    for (int32_t s = first[i]; s < first[i + 1]; ++s)
      if (key[static_cast<size_t>(s)] == partner) return value[static_cast<size_t>(s)];
    return {};
  }
  void permute(const std::vector<int32_t>& new_to_old, size_t n_new_total);
  void truncate(size_t n) {
    first.resize(n + 1);
    key.resize(static_cast<size_t>(first[n]));
    value.resize(static_cast<size_t>(first[n]));
  }
  // Appends one particle's list at the end.
  void append(const int64_t* keys, const Vec3* values, size_t count) {
    key.insert(key.end(), keys, keys + count);
    value.insert(value.end(), values, values + count);
    first.push_back(static_cast<int32_t>(key.size()));
  }
};

}  // namespace mlcg
