#include "bus/coupling_grid.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace mlcg::bus {

CouplingGeometry::CouplingGeometry(const CouplingGrid& g) : g_(g) {
  if (!(g.cell_size() > 0.0) || g.nx() == 0 || g.ny() == 0 || g.nz() == 0)
    throw std::invalid_argument("coupling grid: cell size and cell counts must be positive");
  const uint64_t n = uint64_t{g.nx()} * g.ny() * g.nz();
  if (n > (uint64_t{1} << 26)) throw std::invalid_argument("coupling grid: more than 2^26 cells");
  lookup_.assign(n, -1);
  const uint32_t layer = g.nx() * g.ny();
  for (int k = 0; k < g.cells_size(); ++k) {
    const uint32_t f = g.cells(k);
    if (f >= n) throw std::invalid_argument("coupling grid: cell " + std::to_string(f) + " outside the box");
    if (k > 0 && f <= g.cells(k - 1)) throw std::invalid_argument("coupling grid: cells not strictly ascending");
    lookup_[f] = static_cast<int>(cells_.size());
    cells_.push_back(f);
    const bool top_layer = f / layer == g.nz() - 1;
    face_of_cell_.push_back(top_layer ? static_cast<int>(faces_.size()) : -1);
    if (top_layer) faces_.push_back(cells_.size() - 1);
  }
  const auto fractions = [](const auto& a, size_t want, const char* what) {
    if (a.size() != 0 && static_cast<size_t>(a.size()) != want)
      throw std::invalid_argument(std::string("coupling grid: ") + what + " has " + std::to_string(a.size()) +
                                  " values, expected " + std::to_string(want));
    for (double v : a)
      if (!(v > 0.0 && v <= 1.0))
        throw std::invalid_argument(std::string("coupling grid: ") + what + " value " + std::to_string(v) +
                                    " outside (0, 1]");
  };
  fractions(g.cell_inside(), cells_.size(), "cell_inside");
  fractions(g.face_inside(), faces_.size(), "face_inside");
}

Vec3 CouplingGeometry::box_hi() const {
  const double h = g_.cell_size();
  return origin() + Vec3{g_.nx() * h, g_.ny() * h, g_.nz() * h};
}

Vec3 CouplingGeometry::cell_lo(size_t c) const {
  const uint32_t f = cells_[c], nx = g_.nx(), ny = g_.ny();
  const double h = g_.cell_size();
  return origin() + Vec3{(f % nx) * h, ((f / nx) % ny) * h, (f / (nx * ny)) * h};
}

Vec3 CouplingGeometry::cell_centre(size_t c) const {
  const double h = 0.5 * g_.cell_size();
  return cell_lo(c) + Vec3{h, h, h};
}

int CouplingGeometry::locate(const Vec3& x) const {
  const double inv = 1.0 / g_.cell_size();
  const double fi = std::floor((x.x - g_.ox()) * inv), fj = std::floor((x.y - g_.oy()) * inv),
               fk = std::floor((x.z - g_.oz()) * inv);
  if (!(fi >= 0 && fj >= 0 && fk >= 0 && fi < g_.nx() && fj < g_.ny() && fk < g_.nz())) return -1;
  const auto i = static_cast<uint32_t>(fi), j = static_cast<uint32_t>(fj), k = static_cast<uint32_t>(fk);
  return lookup_[i + g_.nx() * (j + g_.ny() * k)];
}

int CouplingGeometry::face_column(const Vec3& x) const {
  const double h = g_.cell_size();
  const int c = locate({x.x, x.y, top() - 0.5 * h});
  return c < 0 ? -1 : face_of_cell_[static_cast<size_t>(c)];
}

}  // namespace mlcg::bus

namespace mlcg::bus {

int CouplingGeometry::exit_face(const Vec3& x) const {
  const int f = face_column(x);
  if (f >= 0 || faces_.empty()) return f;
  const double h = g_.cell_size(), z = top();
  int best = -1;
  double best_d2 = 0.0;
  for (size_t q = 0; q < faces_.size(); ++q) {  // rare (a particle beside the faces): brute force
    const Vec3 lo = cell_lo(faces_[q]);
    const double dx = std::max({lo.x - x.x, 0.0, x.x - lo.x - h}), dy = std::max({lo.y - x.y, 0.0, x.y - lo.y - h});
    const double d2 = dx * dx + dy * dy + (x.z - z) * (x.z - z);
    if (best < 0 || d2 < best_d2) {
      best = static_cast<int>(q);
      best_d2 = d2;
    }
  }
  return best;
}

}  // namespace mlcg::bus
