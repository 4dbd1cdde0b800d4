#pragma once
// Coarse -> fine insertion for one coupling region (paper section 2.3).
//
// Per boundary face the planner keeps the coarse mass that crossed it and has
// not yet been inserted as fine particles (the remainder). Each interval it
// adds the coarse level's net crossing, then places fine particles while the
// remainder covers the next particle's mass: radius = a coarse radius drawn
// from the face's size histogram, divided by the coarse-grain ratio; position
// by simple sequential inhibition (SSI) in the slab just inside the face, free
// of overlap with the fine particles already there, with each other, and with
// the walls; velocity = the face's Favre (mass-weighted) velocity. A face
// whose slab has no room keeps its remainder for the next interval. Fine mass
// that leaves the region through a face (a particle bouncing up out of the
// transition layer, a bed spreading out through an open side) is returned to
// that face and inserted again: the coarse level stays the authority on what
// lies outside the region, so the fine region holds what the coarse level
// handed in. Per face:
//   coarse mass crossed + fine mass returned = fine mass inserted + remainder.
// Every random draw comes from a generator seeded by (seed, face, interval):
// the plan depends on the inputs and the seed only.
#include <cstdint>
#include <functional>
#include <optional>
#include <random>
#include <vector>

#include "bus/coupling_grid.hpp"
#include "core/spheres.hpp"
#include "core/vec3.hpp"

namespace mlcg::coupling {

struct Insert {
  Vec3 x;
  double r;
  Vec3 v;
  int face = -1;  // the face whose mass it carries (-1: unknown, found from x)
};

struct PlannerParams {
  double ratio = 2.0;              // alpha_coarse / alpha_fine
  double density = 1000.0;         // of the inserted particles [kg/m^3]
  double insert_depth = 0.01;      // slab depth inside the boundary surface [m]
  std::vector<double> radius_bins; // coarse radius bin edges (size bins + 1; equal edges = one radius)
  int attempts = 300;              // SSI candidates per particle before the face gives up this interval
  int attempts_when_full = 30;     // the same for a face whose slab was full last time
  // A face whose slab was full tries again at intervals that are multiples of this ([coupling]
  // retry_full_every). Above 1 the fine level reports only the slabs of the faces that may try.
  uint64_t retry_full_every = 1;
  uint64_t seed = 1;
};

struct FaceState {
  double crossed = 0.0;      // total net coarse mass crossed [kg]
  double inserted = 0.0;     // total fine mass inserted [kg]
  double returned = 0.0;     // total fine mass that left the region through this face [kg]
  double remainder = 0.0;    // crossed + returned - inserted, recomputed so the identity holds to one rounding
  uint64_t placed = 0;
  Vec3 velocity;             // Favre velocity of the latest interval with a crossing
  Vec3 anchor;               // mass-weighted crossing point: known to lie inside the geometry
  bool seen = false;         // any coarse mass crossed yet
  std::vector<int64_t> histogram;  // net crossing counts per bin, all intervals so far
  double next_radius = 0.0;  // drawn, not yet placed; 0 = draw one
  uint64_t short_intervals = 0;  // intervals that ended with room lacking for the next particle
  uint64_t short_streak = 0;     // consecutive such intervals (0 after a placement)
  double last_crossed = 0.0;     // net coarse mass of the latest interval [kg]
  uint64_t bounded = 0;          // intervals whose net mean velocity exceeded the crossings' mean speed
};

// Accepts a sphere centre x, radius r, given a point `anchor` known to be
// inside the geometry: false if the sphere touches a wall or x is not reachable
// from the anchor without crossing one.
using FitsGeometry = std::function<bool(const Vec3& anchor, const Vec3& x, double r)>;
// Places the walls FitsGeometry tests where they stand at time t [s] (meshes that turn as a whole).
using PoseWalls = std::function<void(double t)>;

class InsertionPlanner {
 public:
  InsertionPlanner(const bus::CouplingGeometry& geo, PlannerParams prm, FitsGeometry fits);

  // Adds one interval of the coarse level's face statistics (GridStats fields
  // face_mass, face_momentum, face_moment, face_histogram; face_gross_mass and face_speed_mass,
  // empty = not sent). A face's velocity is the net crossing's mean, its speed no more than the mean
  // speed of every crossing that interval, both ways: crossings that nearly cancel leave a small net
  // mass under a large momentum, whose ratio would insert a particle at tens of m/s.
  void add_crossings(const std::vector<double>& mass, const std::vector<double>& momentum,
                     const std::vector<double>& moment, const std::vector<int64_t>& histogram,
                     const std::vector<double>& gross_mass = {}, const std::vector<double>& speed_mass = {});
  // Adds one interval of the fine level's mass that left the region, per face (GridStats
  // face_returned_mass); empty = none.
  void add_returned(const std::vector<double>& mass);
  // Places what the remainders cover, given the fine particles in the slabs of `reported` (the faces
  // whose slabs the fine level reported; empty = every face's). A face not reported waits.
  std::vector<Insert> plan(uint64_t interval, const std::vector<Sphere>& occupants,
                           const std::vector<uint32_t>& reported = {});
  // Whether the fine level should report its slabs' particles at the end of `interval`: some face
  // will likely have a particle's mass to place (its remainder plus one more interval's crossing).
  // Faces whose slabs were full are retried every 4th interval only.
  bool wants_occupants(uint64_t interval) const;
  // The faces whose slabs the fine level reports at the end of `interval` for the plan of interval + 1:
  // empty = every face's (retry_full_every = 1). Otherwise those likely to have a particle's mass to place,
  // a face whose slab was full only when interval + 1 is a multiple of retry_full_every.
  std::vector<uint32_t> occupant_faces(uint64_t interval) const;
  // A placed particle that was never inserted (the run ended first): its mass goes back to its face.
  void unplace(const Insert& p);

  const std::vector<FaceState>& faces() const { return faces_; }
  std::vector<FaceState>& faces_mut() { return faces_; }
  double mass_of(double r) const;

 private:
  template <class Rng> double draw_radius(const FaceState& f, Rng& rng) const;
  std::mt19937_64& rng(uint64_t interval, size_t f);  // face f's generator for this interval's plan
  std::vector<char> draw_pending(uint64_t interval, const std::vector<uint32_t>& reported);  // per face: tries now
  bool likely_to_place(const FaceState& s) const;  // its remainder plus one more interval's crossing cover a particle
  void fill_hash(const std::vector<Sphere>& occupants, const std::vector<char>& tries);
  bool anchored_on(size_t f, const Vec3& a) const;  // a crossing point mean may serve face f as its anchor
  bool reachable(const Vec3& a) const;              // ... and lies inside the walls, seen from the inside point

  const bus::CouplingGeometry& geo_;
  PlannerParams prm_;
  FitsGeometry fits_;
  std::vector<FaceState> faces_;
  SphereHash hash_;  // the slabs' occupants and this plan's particles; reused from plan to plan
  std::vector<std::optional<std::mt19937_64>> rngs_;  // per face, seeded on first use in a plan
};

}  // namespace mlcg::coupling
