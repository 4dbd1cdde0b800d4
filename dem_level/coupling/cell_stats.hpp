#pragma once
// Both roles of a coupling grid: interval means per active coupling cell of the
// granular stress (paper Eq. 8, compression positive), the volume fraction, the
// mass-weighted mean velocity and the largest particle speed (GridStats cell_*
// fields, in the order of CouplingGrid.cells). The statistics are those of the
// case's cell grids: a CellGrid over the coupling box does the per-particle
// work, and only the active cells' sums travel between ranks. Stress and
// volume fraction are over the part of each cell inside the walls
// (CouplingGrid.cell_inside), floored at kMinInside of the cube. The stress is
// summed only in the cells of the boundary faces (top and open sides: the only
// ones whose stress the coupler reads); it is 0 in the others.
#include <cstdint>
#include <vector>

#include "bus/coupling_grid.hpp"
#include "core/particles.hpp"
#include "measure/cell_grid.hpp"
#include "parallel/comm.hpp"

namespace mlcg::coupling {

struct CellMeans {
  std::vector<double> stress;           // 6 per cell: xx yy zz xy xz yz [Pa]
  std::vector<double> volume_fraction;  // 1 per cell
  std::vector<double> velocity;         // 3 per cell [m/s]
  std::vector<double> max_speed;        // 1 per cell [m/s]
  int64_t samples = 0;
};

class CellStats {
 public:
  static constexpr double kMinInside = 0.05;

  explicit CellStats(const bus::CouplingGeometry& geo);

  // Collective: one sample of this rank's particles, summed over all ranks.
  // stress6: the per-particle contact dyads of this step's force computation
  // (the force kernels fill them when asked for stress).
  // in_box: null, or the local particles that may lie in the grid's box (increasing order).
  void sample(const Particles& p, const std::vector<double>& stress6, const Comm& comm,
              const std::vector<uint32_t>* in_box = nullptr);
  // The means over the samples since the last call (every rank gets them); resets.
  CellMeans take();
  int64_t samples() const { return grid_.state().samples; }

 private:
  std::vector<uint32_t> active_;  // flat indices of the active cells
  std::vector<double> inside_;    // their fractions inside the walls
  CellGrid grid_;
  std::vector<double> sums_, maxs_, packed_, packed_max_;  // scratch
};

}  // namespace mlcg::coupling
