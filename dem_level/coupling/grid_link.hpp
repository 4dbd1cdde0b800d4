#pragma once
// One coupling grid as a level sees it: its role there (coarse or fine), the
// measurements it owes the coupler each interval and the commands it applies.
//
//   coarse role: face crossings (FaceFlux), cell means (CellStats), and the
//                correcting accelerations of the active cells (ControllerForces)
//   fine role:   cell means, the insertion list, the transition-layer traction
//                (ControllerForces), the removal of particles that leave the
//                region upward or sideways, and the occupants of the insertion slabs
//
// Every rank holds one GridLink per grid; every call is made on every rank
// (those marked collective communicate). Every rank builds the same GridStats
// except for the occupants, which are gathered on rank 0, the rank that sends.
#include <cstdint>
#include <string>
#include <vector>

#include "bus/coupling_grid.hpp"
#include "core/particles.hpp"
#include "coupling/cell_stats.hpp"
#include "coupling/controller_forces.hpp"
#include "coupling/face_flux.hpp"
#include "mlcg/bus.pb.h"
#include "parallel/comm.hpp"

namespace mlcg::coupling {

enum class Role { Coarse, Fine };
const char* to_string(Role r);

class GridLink {
 public:
  // Throws std::invalid_argument on an inconsistent grid (a coarse role needs >= 2 radius bin edges).
  GridLink(uint32_t index, const bus::CouplingGrid& grid, Role role);

  uint32_t index() const { return index_; }
  Role role() const { return role_; }
  const bus::CouplingGeometry& geometry() const { return geo_; }

  // The particles of an insertion list (x y z r vx vy vz each), ids first_id,
  // first_id + 1, ... in list order. Throws std::invalid_argument on a list
  // that is not a whole number of particles or has a radius <= 0 or a non-finite value.
  static std::vector<ParticleInit> parse_inserts(const bus::GridCommands& c, int material, double density,
                                                 int64_t first_id);

  // Collective. Start of an interval, after the insertion (its count and mass):
  // takes the commands (null = none: no forces) and the controller's weight
  // sums. Throws std::invalid_argument on commands that do not fit the grid.
  void begin_interval(const bus::GridCommands* c, const Particles& p, const Comm& comm, uint64_t inserted,
                      double inserted_mass);
  // After a neighbour-list rebuild (band: the skin; until the next rebuild no particle moves half of it), or
  // with from > 0 after particles [from, n_local) were appended without one (the others' lists stand).
  void refresh(const Particles& p, double band, size_t from = 0);
  void after_drift(const Particles& p) {  // after the positions moved
    if (role_ == Role::Coarse) flux_.check(p);
  }
  // Coarse role: particle i, just inserted by the level, counts as having entered the fine region
  // when it was born inside it (the coupler must hand its mass to the fine level too).
  void born(const Particles& p, size_t i) {
    if (role_ == Role::Coarse) flux_.add_born(p.x[i], p.v[i], p.mass[i], p.radius[i]);
  }
  void add_forces(Particles& p) const {
    if (forces_.active()) forces_.apply(p, box_list());
  }
  // Fine role: a centre above the boundary surface or beside the box has left the region, into the coarse
  // level's part of the vessel. Beside a side that is no boundary face (outside the vessel: the stream off a
  // belt's end, out of a side-wall hole) it has left the vessel: it stays a fine particle until it leaves the
  // domain, and its mass is not handed back to a face to be placed again under the region's top.
  // Under an open bottom (a fine layer over a coarse bulk) it left the region downward, the same way.
  bool leaves(const Vec3& x) const {
    if (role_ != Role::Fine) return false;
    if (x.z > top_ || x.x < lo_.x || x.x > hi_.x || x.y < lo_.y || x.y > hi_.y) return !geo_.beside_a_closed_side(x);
    return x.z < lo_.z && geo_.below_a_bottom_face(x);
  }
  // Fine role: a particle at x left the region (removed by the level); its mass goes back to its face.
  void count_removed(const Vec3& x, double mass);
  // Collective: one sample of the cell statistics.
  void sample(const Particles& p, const std::vector<double>& stress6, const Comm& comm) {
    cells_.sample(p, stress6, comm, box_list());
  }
  // Collective: the interval's statistics (the same on every rank), and the sums start again from zero: what
  // happens between finish() and the interval's end (a level that sends early) counts into the next one.
  // r_max: the level's largest radius (the occupant slab reaches that far beyond the insertion slab). ahead:
  // the simulated time from now to the interval's end; the occupants are sent where their velocity takes them
  // by then, for the insertion at the next interval's start.
  bus::GridStats finish(const Particles& p, const Comm& comm, double r_max, double ahead = 0.0);
  // This rank's sums since the last finish() (crossings, removals, returned mass), for a checkpoint at an
  // interval's end, and their restoration; set_pending throws std::invalid_argument on a size that does not fit.
  std::vector<double> pending() const;
  void set_pending(const std::vector<double>& v);
  size_t pending_size() const {
    size_t n = flux_.histogram.size() + 2 + returned_.size();
    for (const auto* s : flux_.double_sums()) n += s->size();
    return n;
  }
  // The mass those sums carry, this rank's: crossed both ways (coarse role) and removed (fine role) [kg].
  double pending_mass() const;

  const FaceFlux& flux() const { return flux_; }
  const ControllerForces& forces() const { return forces_; }

 private:
  // The particles within the band of the grid's box at the last refresh (null before one): only they
  // can be in a cell before the next rebuild. A coarse level's region is a small part of it, and the
  // per-step passes (accelerations, cell samples) would otherwise visit every particle.
  const std::vector<uint32_t>* box_list() const { return in_box_valid_ ? &in_box_ : nullptr; }
  // Fine role: this rank's occupants of the slabs the coupler asked for (x y z r each, as bytes).
  std::vector<char> occupants(const Particles& p, double r_max, double ahead) const;

  uint32_t index_;
  Role role_;
  bus::CouplingGeometry geo_;
  double top_;
  Vec3 lo_, hi_;
  FaceFlux flux_;
  bool want_occupants_ = true;  // the coupler asked for the slabs' particles this interval
  std::vector<uint32_t> occupant_faces_;  // ... of these faces' slabs only (empty: every face's)
  CellStats cells_;
  ControllerForces forces_;
  uint64_t inserted_ = 0;
  double inserted_mass_ = 0.0;
  double removed_ = 0.0, removed_mass_ = 0.0;  // this rank's, this interval
  std::vector<double> returned_;               // per face, this rank's, this interval [kg]
  std::vector<uint32_t> in_box_;
  bool in_box_valid_ = false;
};

// The grids of the coupler's Welcome in which the welcomed level (Welcome.level_index) takes part, each with
// its role there, in Welcome order. Throws std::invalid_argument naming the grid when one is inconsistent.
std::vector<GridLink> links_of(const bus::Welcome& w);

// The commands of interval k for each of `links` (null where the coupler sent none), in link order. Throws
// std::invalid_argument on commands for a grid in which level `level` takes no part.
std::vector<const bus::GridCommands*> commands_of(const bus::IntervalCommands& c, const std::vector<GridLink>& links,
                                                  const std::string& level);

}  // namespace mlcg::coupling
