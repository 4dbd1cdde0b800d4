#pragma once
// Brick domain decomposition: a px x py x pz grid of ranks, each owning the
// box between consecutive cut positions in every dimension. Cuts start
// uniform and are shifted to equalise particle counts (per dimension, at the
// quantiles of the particles' coordinates), the brick analogue of LIGGGHTS'
// `balance shift`. Positions outside the domain belong to the edge boxes.
#include <array>
#include <vector>

#include "core/vec3.hpp"
#include "parallel/comm.hpp"

namespace mlcg {

class Decomposition {
 public:
  Decomposition() = default;
  Decomposition(std::array<int, 3> grid, const Vec3& lo, const Vec3& hi);

  // The grid minimising the area of the interfaces between boxes of the domain,
  // counting the domain's extent along gravity as no more than its width (granular
  // beds rarely fill a tall domain) and, on ties, cutting across gravity, so that
  // a settled fill and its discharge stay balanced (the paper's 2 x 2 x 1).
  static std::array<int, 3> default_grid(int ranks, const Vec3& lo, const Vec3& hi, const Vec3& gravity);

  const std::array<int, 3>& grid() const { return grid_; }
  int ranks() const { return grid_[0] * grid_[1] * grid_[2]; }
  int owner(const Vec3& x) const;
  int rank_of(int ix, int iy, int iz) const { return (iz * grid_[1] + iy) * grid_[0] + ix; }
  std::array<int, 3> coords(int rank) const;
  Vec3 box_lo(int rank) const;
  Vec3 box_hi(int rank) const;
  // Distance from x to the box of rank (0 inside); the edge boxes extend to infinity outward.
  double distance_to_box(int rank, const Vec3& x) const;

  const std::array<std::vector<double>, 3>& cuts() const { return cuts_; }
  void set_cuts(const std::array<std::vector<double>, 3>& c) { cuts_ = c; }
  // Collective: moves the cuts to the quantiles of all ranks' particle positions.
  void balance(const Comm& comm, const std::vector<Vec3>& x, size_t n_local);
  // max / mean particles per rank (collective).
  double imbalance(const Comm& comm, size_t n_local) const;

 private:
  std::array<int, 3> grid_{1, 1, 1};
  Vec3 lo_, hi_;
  std::array<std::vector<double>, 3> cuts_;  // grid[d] + 1 values per dimension
};

}  // namespace mlcg
