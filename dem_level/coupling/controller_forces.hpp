#pragma once
// The coupler's forces on a level's particles, added every step after the
// contact forces (paper section 2.3).
//
// Fine role, per transition cell c (face f) with traction T_f [Pa] and speed
// limit vmax_f: a particle whose centre lies in the cell's column at depth
// s = top - z in [0, D) (D = grid.fade_depth) has the weight w = V (1 - s/D) and
// gets   F = -z T_f A_f w / W_f,   W_f = sum of the weights over all ranks, taken
// once at the start of the interval, so that the forces of a cell add up to
// T_f A_f there (A_f: the face's area inside the walls). An open side face
// (a region that does not span the vessel) is pressed the same way along its
// inward normal, with s the depth inside the box's side. A particle at or
// above vmax_f loses the component of F along its velocity that would make it faster.
//
// Coarse role, per active cell c with acceleration a_c: every particle whose
// centre is in the cell gets F = m a_c.
#include <cstdint>
#include <vector>

#include "bus/coupling_grid.hpp"
#include "core/particles.hpp"
#include "parallel/comm.hpp"

namespace mlcg::coupling {

class ControllerForces {
 public:
  explicit ControllerForces(const bus::CouplingGeometry& geo);

  // Fine role: per face traction [Pa] and speed limit [m/s]; empty = none (all zero / no limit).
  void set_traction(std::vector<double> traction, std::vector<double> speed_limit);
  // Coarse role: 3 per active cell [m/s^2]; empty = none.
  void set_acceleration(std::vector<double> acceleration);
  // Collective (fine role): the weight sums W_f over all ranks at the current positions.
  void normalise(const Particles& p, const Comm& comm);
  // Fine role, after a neighbour-list rebuild: the particles that may enter a faded column
  // before the next one (depth below D + band). Without a refresh apply() visits every particle.
  void refresh(const Particles& p, double band, size_t from = 0);  // from > 0: [from, n) appended since
  // Adds the forces to this rank's particles (p.f). in_box: null, or the particles that may lie in
  // the grid's box (the coarse role's accelerations visit only those).
  void apply(Particles& p, const std::vector<uint32_t>* in_box = nullptr) const;
  bool active() const { return traction_on_ || accel_on_; }

  // Fade weight of a centre x (radius r) and its face; 0 and face -1 outside every faded column.
  double weight(const Vec3& x, double r, int& face) const;
  // The same below the open side `side` of the box. cell: the centre's coupling cell, located on the
  // first call that needs it (pass -2 before), kept for the particle's other sides.
  double side_weight(const Vec3& x, double r, bus::Side side, int& cell, int& face) const;
  const std::vector<double>& weight_sums() const { return wsum_; }

 private:
  void apply_sides(Particles& p) const;
  Vec3 limited(const Vec3& F, const Vec3& v, size_t f) const;  // without the part beyond the speed limit
  // The open sides (bit k: open_sides()[k]) whose faces x, moving less than band, may come within the
  // fade depth of: the only sides apply() and normalise() look at for it until the next refresh.
  uint32_t sides_within_reach(const Vec3& x, double band) const;
  bus::CouplingGeometry geo_;
  double top_ = 0.0, depth_ = 0.0;
  std::vector<double> area_;  // per face: its area inside the walls [m^2]
  std::vector<double> traction_, vmax_, wsum_;
  std::vector<Vec3> accel_;
  bool traction_on_ = false, accel_on_ = false;
  // refresh(): candidates for the traction on the top faces and on the open sides. Every step visits
  // them, so each list holds only the particles its loop can press.
  std::vector<uint32_t> near_top_, near_side_;
  std::vector<uint32_t> near_side_mask_;  // per near_side_ entry: sides_within_reach()
  bool near_valid_ = false;
};

}  // namespace mlcg::coupling
