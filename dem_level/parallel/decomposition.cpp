#include "parallel/decomposition.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace mlcg {

Decomposition::Decomposition(std::array<int, 3> grid, const Vec3& lo, const Vec3& hi) : grid_(grid), lo_(lo), hi_(hi) {
  for (int d = 0; d < 3; ++d) {
    auto& c = cuts_[static_cast<size_t>(d)];
    c.resize(static_cast<size_t>(grid_[static_cast<size_t>(d)]) + 1);
    for (size_t k = 0; k < c.size(); ++k)
      c[k] = lo[d] + (hi[d] - lo[d]) * static_cast<double>(k) / static_cast<double>(grid_[static_cast<size_t>(d)]);
  }
}

std::array<int, 3> Decomposition::default_grid(int ranks, const Vec3& lo, const Vec3& hi, const Vec3& gravity) {
  Vec3 L = hi - lo;
  int down = -1;  // the axis gravity mostly points along
  const double gmax = std::max({std::fabs(gravity.x), std::fabs(gravity.y), std::fabs(gravity.z)});
  if (gmax > 0.0)
    for (int d = 0; d < 3; ++d)
      if (std::fabs(gravity[d]) == gmax) down = d;
  if (down >= 0) {
    double width = 0.0;
    for (int d = 0; d < 3; ++d)
      if (d != down) width = std::max(width, L[d]);
    L[down] = std::min(L[down], width);
  }
  std::array<int, 3> best{ranks, 1, 1};
  double best_area = std::numeric_limits<double>::max();
  int best_down = ranks + 1;
  for (int px = 1; px <= ranks; ++px) {
    if (ranks % px) continue;
    for (int py = 1; py <= ranks / px; ++py) {
      if ((ranks / px) % py) continue;
      const int pz = ranks / px / py;
      const std::array<int, 3> g{px, py, pz};
      const double area = (px - 1) * L.y * L.z + (py - 1) * L.x * L.z + (pz - 1) * L.x * L.y;
      const int along = down >= 0 ? g[static_cast<size_t>(down)] : 1;
      const double tol = 1e-9 * std::max(area, best_area < 1e300 ? best_area : area);
      if (area < best_area - tol || (std::fabs(area - best_area) <= tol && along < best_down)) {
        best_area = area;
        best = g;
        best_down = along;
      }
    }
  }
  return best;
}

int Decomposition::owner(const Vec3& x) const {
  int c[3];
  for (int d = 0; d < 3; ++d) {
    const auto& cut = cuts_[static_cast<size_t>(d)];
    // cut[1..n-1] are interior; upper_bound over them gives the box index.
    c[d] = static_cast<int>(std::upper_bound(cut.begin() + 1, cut.end() - 1, x[d]) - (cut.begin() + 1));
  }
  return rank_of(c[0], c[1], c[2]);
}

std::array<int, 3> Decomposition::coords(int rank) const {
  return {rank % grid_[0], (rank / grid_[0]) % grid_[1], rank / (grid_[0] * grid_[1])};
}

Vec3 Decomposition::box_lo(int rank) const {
  const auto c = coords(rank);
  return {cuts_[0][static_cast<size_t>(c[0])], cuts_[1][static_cast<size_t>(c[1])], cuts_[2][static_cast<size_t>(c[2])]};
}

Vec3 Decomposition::box_hi(int rank) const {
  const auto c = coords(rank);
  return {cuts_[0][static_cast<size_t>(c[0]) + 1], cuts_[1][static_cast<size_t>(c[1]) + 1],
          cuts_[2][static_cast<size_t>(c[2]) + 1]};
}

double Decomposition::distance_to_box(int rank, const Vec3& x) const {
  const auto c = coords(rank);
  double d2 = 0.0;
  for (int d = 0; d < 3; ++d) {
    const auto k = static_cast<size_t>(c[static_cast<size_t>(d)]);
    const auto& cut = cuts_[static_cast<size_t>(d)];
    const bool first = k == 0, last = k + 1 == cut.size() - 1;
    double gap = 0.0;
    if (!first && x[d] < cut[k]) gap = cut[k] - x[d];
    if (!last && x[d] > cut[k + 1]) gap = x[d] - cut[k + 1];
    d2 += gap * gap;
  }
  return std::sqrt(d2);
}

void Decomposition::balance(const Comm& comm, const std::vector<Vec3>& x, size_t n_local) {
  constexpr size_t kBins = 4096;
  for (int d = 0; d < 3; ++d) {
    const int parts = grid_[static_cast<size_t>(d)];
    if (parts == 1) continue;
    const double lo = lo_[d], hi = hi_[d], w = (hi - lo) / kBins;
    std::vector<int64_t> hist(kBins, 0);
    for (size_t i = 0; i < n_local; ++i) {
      const auto b = static_cast<size_t>(std::clamp((x[i][d] - lo) / w, 0.0, static_cast<double>(kBins - 1)));
      ++hist[b];
    }
    comm.sum_in_place(hist.data(), hist.size());
    int64_t total = 0;
    for (int64_t h : hist) total += h;
    if (total == 0) continue;
    auto& cut = cuts_[static_cast<size_t>(d)];
    int64_t acc = 0;
    size_t b = 0;
    for (int k = 1; k < parts; ++k) {
      const double target = static_cast<double>(total) * k / parts;
      while (b < kBins && static_cast<double>(acc + hist[b]) < target) acc += hist[b++];
      const double frac = hist[b] > 0 ? (target - static_cast<double>(acc)) / static_cast<double>(hist[b]) : 0.5;
      cut[static_cast<size_t>(k)] = lo + (static_cast<double>(b) + std::clamp(frac, 0.0, 1.0)) * w;
    }
    // Keep the cuts strictly increasing.
    for (size_t k = 1; k + 1 < cut.size(); ++k) cut[k] = std::max(cut[k], cut[k - 1] + 1e-9 * (hi - lo));
  }
}

double Decomposition::imbalance(const Comm& comm, size_t n_local) const {
  const double n = static_cast<double>(n_local);
  const double total = comm.sum(n);
  const double mx = comm.max(n);
  return total > 0.0 ? mx / (total / comm.size()) : 1.0;
}

}  // namespace mlcg
