#include "neighbor/neighbor_list.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace mlcg {

void CellBins::build(const std::vector<Vec3>& x, size_t count, double min_cell) {
  Vec3 lo{std::numeric_limits<double>::max(), std::numeric_limits<double>::max(),
          std::numeric_limits<double>::max()};
  Vec3 hi = -lo;
  for (size_t i = 0; i < count; ++i) {
    lo.x = std::min(lo.x, x[i].x); lo.y = std::min(lo.y, x[i].y); lo.z = std::min(lo.z, x[i].z);
    hi.x = std::max(hi.x, x[i].x); hi.y = std::max(hi.y, x[i].y); hi.z = std::max(hi.z, x[i].z);
  }
  if (count == 0) lo = hi = {};
  double h = min_cell > 0.0 ? min_cell : 1.0;
  const double cap = 8.0 * static_cast<double>(count) + 1000.0;
  auto cells_for = [&](double hh) {
    return (std::floor((hi.x - lo.x) / hh) + 1) * (std::floor((hi.y - lo.y) / hh) + 1) *
           (std::floor((hi.z - lo.z) / hh) + 1);
  };
  while (cells_for(h) > cap) h *= 1.26;
  h_ = h;
  inv_h_ = 1.0 / h;
  lo_ = lo;
  nx_ = static_cast<int>(std::floor((hi.x - lo.x) * inv_h_)) + 1;
  ny_ = static_cast<int>(std::floor((hi.y - lo.y) * inv_h_)) + 1;
  nz_ = static_cast<int>(std::floor((hi.z - lo.z) * inv_h_)) + 1;
  const size_t ncell = static_cast<size_t>(nx_) * static_cast<size_t>(ny_) * static_cast<size_t>(nz_);
  start_.assign(ncell + 1, 0);
  cell_.resize(count);
  for (size_t i = 0; i < count; ++i) {
    const int c = cell_of(x[i]);
    cell_[i] = c;
    ++start_[static_cast<size_t>(c) + 1];
  }
  for (size_t c = 0; c < ncell; ++c) start_[c + 1] += start_[c];
  sorted_.resize(count);
  std::vector<int32_t> fill(start_.begin(), start_.end() - 1);
  for (size_t i = 0; i < count; ++i) sorted_[static_cast<size_t>(fill[static_cast<size_t>(cell_[i])]++)] =
      static_cast<int32_t>(i);
}

void CellBins::cell_coords(const Vec3& p, int& ix, int& iy, int& iz) const {
  // Clamping keeps particles outside the box in the edge cells; it never
  // increases a distance, so true neighbours stay within one cell.
  ix = std::clamp(static_cast<int>(std::floor((p.x - lo_.x) * inv_h_)), 0, nx_ - 1);
  iy = std::clamp(static_cast<int>(std::floor((p.y - lo_.y) * inv_h_)), 0, ny_ - 1);
  iz = std::clamp(static_cast<int>(std::floor((p.z - lo_.z) * inv_h_)), 0, nz_ - 1);
}

int CellBins::cell_of(const Vec3& p) const {
  int ix, iy, iz;
  cell_coords(p, ix, iy, iz);
  return index(ix, iy, iz);
}

void NeighborList::note_sameness(const Particles& p, size_t from, size_t to) {
  for (size_t i = from; i < to; ++i) {
    if (p.material[i] != single_material_) single_material_ = -1;
    if (p.radius[i] != single_size_.radius || p.mass[i] != single_size_.mass) single_size_ = OneSize{};
  }
}

void NeighborList::build(const Particles& p, bool with_history) {
  const size_t n_all = p.size();
  const size_t n_local = p.n_local();
  double rmax = 0.0;
  for (size_t i = 0; i < n_all; ++i) rmax = std::max(rmax, p.radius[i]);
  single_material_ = n_all > 0 ? p.material[0] : -1;
  single_size_ = n_all > 0 ? OneSize{p.radius[0], p.mass[0]} : OneSize{};
  note_sameness(p, 0, n_all);
  bins_.build(p.x, n_all, 2.0 * rmax + skin_);

  first.assign(n_local + 1, 0);
  neigh.clear();
  const auto& start = bins_.start();
  const auto& sorted = bins_.sorted();
  // Positions and radii in bin order: x is the fastest cell index, so a row of three neighbouring
  // cells is one contiguous run of candidates, tested without an indirection or a branch.
  std::vector<double> xr(4 * n_all);
  for (size_t s = 0; s < n_all; ++s) {
    const auto j = static_cast<size_t>(sorted[s]);
    xr[4 * s] = p.x[j].x;
    xr[4 * s + 1] = p.x[j].y;
    xr[4 * s + 2] = p.x[j].z;
    xr[4 * s + 3] = p.radius[j];
  }
  for (size_t i = 0; i < n_local; ++i) {
    const Vec3 xi = p.x[i];
    const double ri = p.radius[i] + skin_;
    int cx, cy, cz;
    bins_.cell_coords(xi, cx, cy, cz);
    const int x_lo = std::max(cx - 1, 0), x_hi = std::min(cx + 1, bins_.nx() - 1);
    for (int z = std::max(cz - 1, 0); z <= std::min(cz + 1, bins_.nz() - 1); ++z)
      for (int y = std::max(cy - 1, 0); y <= std::min(cy + 1, bins_.ny() - 1); ++y) {
        const auto s0 = static_cast<size_t>(start[static_cast<size_t>(bins_.index(x_lo, y, z))]);
        const auto s1 = static_cast<size_t>(start[static_cast<size_t>(bins_.index(x_hi, y, z)) + 1]);
        const size_t at = neigh.size();
        neigh.resize(at + (s1 - s0));
        int32_t* out = neigh.data() + at;
        size_t kept = 0;
        for (size_t s = s0; s < s1; ++s) {
          const int32_t j = sorted[s];
          const double dx = xi.x - xr[4 * s], dy = xi.y - xr[4 * s + 1], dz = xi.z - xr[4 * s + 2];
          const double cut = ri + xr[4 * s + 3];
          out[kept] = j;
          kept += (j > static_cast<int32_t>(i)) & (dx * dx + dy * dy + dz * dz < cut * cut);
        }
        neigh.resize(at + kept);
      }
    // Sorted neighbours give a deterministic pair order independent of bin layout.
    std::sort(neigh.begin() + first[i], neigh.end());
    first[i + 1] = static_cast<int32_t>(neigh.size());
  }
  // Memory: the list keeps little slack, the bins are only needed while building.
  if (neigh.capacity() > neigh.size() + neigh.size() / 4) neigh.shrink_to_fit();
  if (with_history) {
    hist.assign(neigh.size(), Vec3f{});
    if (hist.capacity() > hist.size() + hist.size() / 4) hist.shrink_to_fit();
  } else {
    hist.clear();
  }
  bins_ = CellBins{};
  x_build_.assign(p.x.begin(), p.x.end());
  ++builds_;
}

void NeighborList::append(const Particles& p, size_t first_new, bool with_history) {
  const size_t n = p.n_local();
  if (p.size() != n || first.size() != first_new + 1 || x_build_.size() != first_new || first_new > n)
    throw std::logic_error("NeighborList::append: the list does not end where the new particles start");
  if (first_new == n) return;
  note_sameness(p, first_new, n);
  std::vector<std::vector<int32_t>> rows(n - first_new);
  for_new_pairs(p, first_new, 1.5 * skin_,
                [&](size_t k, size_t j, double) { rows[k - first_new].push_back(static_cast<int32_t>(j)); });
  for (auto& row : rows) {
    std::sort(row.begin(), row.end());  // the order a build would give a row: deterministic
    neigh.insert(neigh.end(), row.begin(), row.end());
    first.push_back(static_cast<int32_t>(neigh.size()));
  }
  if (with_history) hist.resize(neigh.size(), Vec3f{});
  x_build_.insert(x_build_.end(), p.x.begin() + static_cast<std::ptrdiff_t>(first_new), p.x.end());
}

bool NeighborList::needs_rebuild(const Particles& p) const {
  // Local particles only: a ghost's owner checks it.
  if (x_build_.size() != p.size()) return true;
  const double limit = 0.25 * skin_ * skin_;
  for (size_t i = 0; i < p.n_local(); ++i)
    if (norm2(p.x[i] - x_build_[i]) > limit) return true;
  return false;
}

void NeighborList::save_history(const Particles& p, ContactHistory& out) const {
  const size_t n = p.size();
  out.clear(n);
  if (hist.empty()) return;
  const size_t n_local = first.size() - 1;
  std::vector<int32_t> count(n + 1, 0);
  for (size_t i = 0; i < n_local; ++i)
    for (int32_t k = first[i]; k < first[i + 1]; ++k)
      if (!(hist[static_cast<size_t>(k)] == Vec3{})) {
        ++count[i + 1];
        ++count[static_cast<size_t>(neigh[static_cast<size_t>(k)]) + 1];
      }
  for (size_t i = 0; i < n; ++i) count[i + 1] += count[i];
  out.first = count;
  out.key.resize(static_cast<size_t>(count[n]));
  out.value.resize(static_cast<size_t>(count[n]));
  std::vector<int32_t> fill(count.begin(), count.end() - 1);
  for (size_t i = 0; i < n_local; ++i)
    for (int32_t k = first[i]; k < first[i + 1]; ++k) {
      const Vec3 h = hist[static_cast<size_t>(k)];
      if (h == Vec3{}) continue;
      const auto j = static_cast<size_t>(neigh[static_cast<size_t>(k)]);
      auto si = static_cast<size_t>(fill[i]++);
      out.key[si] = p.id[j];
      out.value[si] = h;
      auto sj = static_cast<size_t>(fill[j]++);
      out.key[sj] = p.id[i];
      out.value[sj] = -h;
    }
}

void NeighborList::load_history(const Particles& p, const ContactHistory& in) {
  if (hist.empty()) return;
  const size_t n_local = first.size() - 1;
  for (size_t i = 0; i < n_local; ++i) {
    if (i >= in.particles() || in.first[i] == in.first[i + 1]) continue;
    for (int32_t k = first[i]; k < first[i + 1]; ++k)
      hist[static_cast<size_t>(k)] = Vec3f(in.find(i, p.id[static_cast<size_t>(neigh[static_cast<size_t>(k)])]));
  }
}

}  // namespace mlcg
