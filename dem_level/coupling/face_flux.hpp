#pragma once
// Coarse role of a coupling grid: the net mass crossing each boundary face
// inward during one coupling interval (the top faces of the transition cells,
// in the plane z = top, and the open side faces in the box's side planes),
// with the sums the coupler needs to insert fine particles in its place
// (paper section 2.3; GridStats face_* fields):
//   inward crossing:   mass += m, momentum += m v, moment += m x_c, histogram[bin(r)] += 1
//   outward crossing:  the same subtracted
// x_c is where the centre crossed the plane, v the velocity that carried it
// there. The crossings are counted like a mass-flow probe's (PlaneCrossings:
// candidates near the plane, refreshed at every neighbour-list rebuild).
#include <array>
#include <cstdint>
#include <vector>

#include "bus/coupling_grid.hpp"
#include "core/particles.hpp"
#include "measure/plane_crossings.hpp"
#include "parallel/comm.hpp"

namespace mlcg::coupling {

// Bin of radius r among bin edges e (size bins + 1, ascending): e[b] <= r < e[b+1];
// r below the first edge goes to bin 0, r at or above the last edge to the last
// bin, so equal edges make a single bin. -1 with fewer than 2 edges.
int face_radius_bin(const std::vector<double>& edges, double r);

class FaceFlux {
 public:
  explicit FaceFlux(const bus::CouplingGeometry& geo);

  size_t faces() const { return nf_; }
  size_t bins() const { return nb_; }

  // After a neighbour-list rebuild (band: the skin; no centre moves further before the next one).
  void refresh(const Particles& p, double band, size_t from = 0);  // from: see PlaneCrossings::refresh
  // After the drift of every step: counts the crossings of this rank's particles.
  void check(const Particles& p);
  // A particle of this rank created inside the region below the boundary surface (by the
  // level's own insertion) enters the fine region as if it had crossed its face's column.
  void add_born(const Vec3& x, const Vec3& v, double m, double r);
  // Zeroes the sums (start of a coupling interval); the candidates stay.
  void reset();
  // Collective: the sums over all ranks (every rank gets them).
  void reduce(const Comm& comm);

  // This rank's sums (after reduce(): every rank's), in the GridStats layout.
  std::vector<double> mass, momentum, moment;  // nf, 3 nf, 3 nf
  std::vector<int64_t> histogram;              // nf x bins, face-major
  // Both ways added, not netted: sum m and sum m |v| per face. The coupler bounds the speed of the net
  // crossing's mean velocity by their ratio (near-cancelling crossings make momentum / mass arbitrary).
  std::vector<double> gross_mass, speed_mass;  // nf, nf
  // The double sums above, in one order: what reduce() sums and a checkpoint keeps (GridLink::pending).
  std::array<std::vector<double>*, 5> double_sums() { return {&mass, &momentum, &moment, &gross_mass, &speed_mass}; }
  std::array<const std::vector<double>*, 5> double_sums() const {
    return {&mass, &momentum, &moment, &gross_mass, &speed_mass};
  }

 private:
  void add(size_t f, double m, const Vec3& v, const Vec3& x, double r, int sign);  // m < 0: outward
  void check_sides(const Particles& p);
  bus::CouplingGeometry geo_;
  size_t nf_ = 0, nb_ = 0;
  std::vector<double> edges_;
  PlaneCrossings plane_;  // the top
  struct SidePlane {
    bus::Side side;
    PlaneCrossings plane;  // normal pointing into the box
  };
  std::vector<SidePlane> sides_;  // only the box sides that have open faces
};

}  // namespace mlcg::coupling
