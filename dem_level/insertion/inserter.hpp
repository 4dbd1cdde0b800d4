#pragma once
// Pouring particles into a region by simple sequential inhibition (SSI):
// candidates are drawn uniformly in the region and rejected while they overlap
// a particle (already present or placed in this batch) or a wall, or while
// the vertical line from them up to the region's ceiling crosses a wall (a
// poured particle cannot reach a place under a wall, e.g. outside a cone). Particles are
// requested at a rate, in batches; a particle that cannot be placed in its
// batch is carried to the next one, and only counted as failed when the
// insertion stops making progress or ends. Nothing is dropped uncounted:
//   requested = placed + pending + failed.
#include <cstdint>
#include <functional>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "core/particles.hpp"
#include "core/spheres.hpp"
#include "walls/wall_set.hpp"

namespace mlcg {

struct InsertionParams {
  std::string name;
  int material = 0;
  double density = 0.0;
  bool cylinder = false;   // region: box [lo, hi], or cylinder (cx, cy, radius) x [lo.z, hi.z]
  Vec3 lo, hi;
  double cx = 0.0, cy = 0.0, cyl_radius = 0.0;
  // radii (already scaled by alpha)
  enum class Dist { Constant, Uniform, Discrete } dist = Dist::Constant;
  double r_const = 0.0, r_min = 0.0, r_max = 0.0;
  std::vector<double> values, cumulative;  // discrete: radii and cumulative number fractions
  int64_t target = 0;      // particles to request in total
  double rate = -1.0;      // particles/s; < 0: all in the first batch
  double start = 0.0;
  double interval = 0.0;   // batch period
  Vec3 velocity;
  double follow_gap = -1.0;
  double follow_height = 0.0;    // height of the slab used when following the heap
  int max_attempts = 200;
  int max_stalled_batches = 50;
};

// One batch is computed in three steps so that every MPI rank can run the same
// SSI on the same data (identical random draws, identical result):
//   heap_top (reduced with max over ranks) -> batch_region -> nearby (gathered
//   from all ranks) -> place_batch.
class Inserter {
 public:
  struct State {  // checkpointed
    int64_t requested = 0, placed = 0, failed = 0, pending = 0;
    double placed_mass = 0.0, failed_mass_estimate = 0.0;
    int64_t batch = 0;
    int stalled = 0;
    bool done = false;
  };

  explicit Inserter(InsertionParams prm) : prm_(std::move(prm)) {}
  const InsertionParams& params() const { return prm_; }
  State& state() { return st_; }
  const State& state() const { return st_; }

  double next_batch_time() const { return prm_.start + static_cast<double>(st_.batch) * prm_.interval; }
  bool due(double t, double dt) const { return !st_.done && t + 0.5 * dt >= next_batch_time(); }
  bool follows_heap() const { return prm_.follow_gap >= 0.0; }

  // Top of the resting heap under the region among these particles (-inf if none).
  double heap_top(const Particles& p, double g_mag) const;
  // The part of the region this batch fills, given the heap top over all ranks.
  void batch_region(double heap_top, Vec3& lo, Vec3& hi) const;
  // Particles of p that a candidate in [lo, hi] could touch (reach: largest diameter).
  void nearby(const Particles& p, const Vec3& lo, const Vec3& hi, double reach, std::vector<Sphere>& out) const;
  // SSI for this batch against `obstacles`; returns the placed particles (ids from next_id).
  // nullopt when `stop` turned true before the batch was done (a signal: one batch of a large count
  // without a rate can take hours); the state, rng and next_id are then part-way through the batch:
  // the caller puts back the copies it kept. `progress(tried, wanted)` is called every kProgressEvery
  // particles, so the caller can show that a long batch moves.
  static constexpr int64_t kProgressEvery = 4096;
  std::optional<std::vector<ParticleInit>> place_batch(const std::vector<Sphere>& obstacles, double reach,
                                                       const Vec3& lo, const Vec3& hi, const WallSet& walls,
                                                       std::mt19937_64& rng, int64_t& next_id,
                                                       const std::function<bool()>& stop = {},
                                                       const std::function<void(int64_t, int64_t)>& progress = {});
  // Stop inserting: pending particles and those never requested count as failed.
  void finish();
  // The run ends: particles still waiting for a place count as failed.
  void abandon_pending();
  double particle_mass(double r) const;

 private:
  bool in_footprint(const Vec3& x, double margin, const Vec3& lo, const Vec3& hi) const;
  double draw_radius(std::mt19937_64& rng) const;
  InsertionParams prm_;
  State st_;
};

}  // namespace mlcg
