#include "coupling/cell_stats.hpp"

#include <algorithm>

namespace mlcg::coupling {

namespace {
GridParams box_of(const bus::CouplingGeometry& geo) {
  GridParams q;
  q.name = "coupling";
  q.origin = geo.origin();
  q.h = geo.cell_size();
  q.nx = static_cast<int>(geo.grid().nx());
  q.ny = static_cast<int>(geo.grid().ny());
  q.nz = static_cast<int>(geo.grid().nz());
  return q;  // CellGrid's flat index (iz ny + iy) nx + ix is the bus's i + nx (j + ny k)
}
}  // namespace

CellStats::CellStats(const bus::CouplingGeometry& geo) : grid_(box_of(geo)) {
  for (size_t c = 0; c < geo.cells(); ++c) {
    active_.push_back(geo.flat(c));
    inside_.push_back(geo.inside_volume(c));
  }
  // The coupler reads a cell's stress only where a boundary face lies (the top's and the open sides'
  // transition layers): the other cells' particles skip the stress sums.
  std::vector<char> wanted(grid_.params().cells(), 0);
  for (size_t f = 0; f < geo.faces(); ++f) wanted[geo.flat(geo.cell_of_face(f))] = 1;
  grid_.set_stress_cells(std::move(wanted));
}

void CellStats::sample(const Particles& p, const std::vector<double>& stress6, const Comm& comm,
                       const std::vector<uint32_t>* in_box) {
  constexpr size_t K = CellGrid::kSums;
  grid_.local_sample(p, stress6, sums_, maxs_, in_box);
  if (!comm.serial()) {
    // Only the active cells' sums go over the wire.
    const size_t na = active_.size();
    packed_.resize(K * na);
    packed_max_.resize(na);
    for (size_t c = 0; c < na; ++c) {
      std::copy_n(&sums_[K * active_[c]], K, &packed_[K * c]);
      packed_max_[c] = maxs_[active_[c]];
    }
    comm.sum_in_place(packed_.data(), packed_.size());
    comm.max_in_place(packed_max_.data(), packed_max_.size());
    std::fill(sums_.begin(), sums_.end(), 0.0);
    std::fill(maxs_.begin(), maxs_.end(), 0.0);
    for (size_t c = 0; c < na; ++c) {
      std::copy_n(&packed_[K * c], K, &sums_[K * active_[c]]);
      maxs_[active_[c]] = packed_max_[c];
    }
  }
  grid_.add_sample(sums_, maxs_);
}

CellMeans CellStats::take() {
  CellMeans m;
  m.samples = grid_.state().samples;
  const GridAverages a = grid_.take_averages();
  const size_t na = active_.size();
  m.stress.reserve(6 * na);
  m.volume_fraction.reserve(na);
  m.velocity.reserve(3 * na);
  m.max_speed.reserve(na);
  for (size_t c = 0; c < na; ++c) {
    const uint32_t f = active_[c];
    // Sums over the cell's inside volume, not the whole cube: a cell half outside the cone holds a
    // bed as dense as its neighbours'. A sliver is floored so that a few particles stay a few.
    const double inv = 1.0 / std::max(inside_[c], kMinInside);
    for (size_t k = 0; k < 6; ++k) m.stress.push_back(a.stress6[6 * f + k] * inv);
    m.volume_fraction.push_back(a.volume_fraction[f] * inv);
    for (int k = 0; k < 3; ++k) m.velocity.push_back(a.mean_velocity[f][k]);
    m.max_speed.push_back(a.max_speed[f]);
  }
  return m;
}

}  // namespace mlcg::coupling
