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
  top_faces_ = faces_.size();
  side_.assign(top_faces_, Side::Top);
  side_lookup_.assign(5 * cells_.size(), -1);
  for (int k = 0; k < g.side_faces_size(); ++k) {
    const uint32_t code = g.side_faces(k), c = code / 4, d = code % 4;
    if (c >= cells_.size())
      throw std::invalid_argument("coupling grid: side face " + std::to_string(code) + " names cell " +
                                  std::to_string(c) + " of " + std::to_string(cells_.size()));
    if (k > 0 && code <= g.side_faces(k - 1))
      throw std::invalid_argument("coupling grid: side faces not strictly ascending");
    const uint32_t f = cells_[c], i = f % g.nx(), j = (f / g.nx()) % g.ny();
    const bool on_box = d == 0 ? i == 0 : d == 1 ? i == g.nx() - 1 : d == 2 ? j == 0 : j == g.ny() - 1;
    if (!on_box)
      throw std::invalid_argument("coupling grid: side face " + std::to_string(code) +
                                  " is not on the side of the box");
    add_face(c, static_cast<Side>(d + 1));
  }
  for (int k = 0; k < g.bottom_faces_size(); ++k) {
    const uint32_t c = g.bottom_faces(k);
    if (c >= cells_.size())
      throw std::invalid_argument("coupling grid: bottom face names cell " + std::to_string(c) + " of " +
                                  std::to_string(cells_.size()));
    if (k > 0 && c <= g.bottom_faces(k - 1))
      throw std::invalid_argument("coupling grid: bottom faces not strictly ascending");
    if (cells_[c] >= layer)
      throw std::invalid_argument("coupling grid: bottom face of cell " + std::to_string(c) +
                                  ", which is not in the bottom layer");
    add_face(c, Side::Bottom);
    ++bottom_faces_;
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
  // The per-particle look-ups (the traction every step) read these instead of recomputing them.
  const double h = g_.cell_size();
  hi_ = origin() + Vec3{g_.nx() * h, g_.ny() * h, g_.nz() * h};
  inv_h_ = 1.0 / h;
  // Each column's top face, found at the column's centre with locate(): face_column() finds a point's column
  // with locate()'s own arithmetic, so it answers as locate() at the top layer would.
  for (uint32_t j = 0; j < g_.ny(); ++j)
    for (uint32_t i = 0; i < g_.nx(); ++i) {
      const int c = locate(origin() + Vec3{(i + 0.5) * h, (j + 0.5) * h, top() - 0.5 * h - g_.oz()});
      column_.push_back(c < 0 ? -1 : face_of_cell_[static_cast<size_t>(c)]);
    }
}

void CouplingGeometry::add_face(uint32_t c, Side s) {
  side_lookup_[5 * c + static_cast<size_t>(s) - 1] = static_cast<int>(faces_.size());
  faces_.push_back(c);
  side_.push_back(s);
  if (std::find(open_sides_.begin(), open_sides_.end(), s) == open_sides_.end()) open_sides_.push_back(s);
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
  const double fi = std::floor((x.x - g_.ox()) * inv_h_), fj = std::floor((x.y - g_.oy()) * inv_h_),
               fk = std::floor((x.z - g_.oz()) * inv_h_);
  if (!(fi >= 0 && fj >= 0 && fk >= 0 && fi < g_.nx() && fj < g_.ny() && fk < g_.nz())) return -1;
  const auto i = static_cast<uint32_t>(fi), j = static_cast<uint32_t>(fj), k = static_cast<uint32_t>(fk);
  return lookup_[i + g_.nx() * (j + g_.ny() * k)];
}

Vec3 CouplingGeometry::inward(Side s) {
  switch (s) {
    case Side::XLo: return {1.0, 0.0, 0.0};
    case Side::XHi: return {-1.0, 0.0, 0.0};
    case Side::YLo: return {0.0, 1.0, 0.0};
    case Side::YHi: return {0.0, -1.0, 0.0};
    case Side::Bottom: return {0.0, 0.0, 1.0};
    default: return {0.0, 0.0, -1.0};
  }
}

void CouplingGeometry::cell_slab(size_t c, Side s, double depth, Vec3& lo, Vec3& hi) const {
  const double h = g_.cell_size();
  lo = cell_lo(c);
  hi = lo + Vec3{h, h, h};
  switch (s) {
    case Side::Top:
      hi.z = top();  // the very same number as the boundary surface's height
      lo.z = hi.z - depth;
      break;
    case Side::XLo: hi.x = lo.x + depth; break;
    case Side::XHi: lo.x = hi.x - depth; break;
    case Side::YLo: hi.y = lo.y + depth; break;
    case Side::YHi: lo.y = hi.y - depth; break;
    case Side::Bottom: hi.z = lo.z + depth; break;
  }
}

int CouplingGeometry::side_face(size_t c, Side s) const {
  if (s == Side::Top) return face_of_cell_[c];
  return side_lookup_[5 * c + static_cast<size_t>(s) - 1];
}

double CouplingGeometry::depth_inside(Side s, const Vec3& x) const {
  switch (s) {
    case Side::XLo: return x.x - g_.ox();
    case Side::XHi: return hi_.x - x.x;
    case Side::YLo: return x.y - g_.oy();
    case Side::YHi: return hi_.y - x.y;
    case Side::Bottom: return x.z - g_.oz();
    default: return top() - x.z;
  }
}

int CouplingGeometry::face_column(const Vec3& x) const {
  const double fi = std::floor((x.x - g_.ox()) * inv_h_), fj = std::floor((x.y - g_.oy()) * inv_h_);
  if (!(fi >= 0 && fj >= 0 && fi < g_.nx() && fj < g_.ny())) return -1;
  return column_[static_cast<uint32_t>(fi) + g_.nx() * static_cast<uint32_t>(fj)];
}

}  // namespace mlcg::bus

namespace mlcg::bus {

CouplingGeometry::Beyond CouplingGeometry::beyond(const Vec3& x) const {
  // By the side it is furthest beyond: above the top, or beside the box next to a cell of it.
  const Vec3 lo = box_lo(), hi = box_hi();
  const double ex = std::max({lo.x - x.x, x.x - hi.x, 0.0}), ey = std::max({lo.y - x.y, x.y - hi.y, 0.0}),
               ez = std::max(x.z - top(), 0.0), eb = bottom_faces_ > 0 ? std::max(lo.z - x.z, 0.0) : 0.0;
  const double eps = 1e-9 * g_.cell_size();
  const Vec3 in{std::clamp(x.x, lo.x + eps, hi.x - eps), std::clamp(x.y, lo.y + eps, hi.y - eps),
                std::clamp(x.z, lo.z + eps, top() - eps)};
  Beyond b;
  if (ez > 0.0 && ez >= ex && ez >= ey) {
    b.where = Beyond::Above;
  } else if (eb > 0.0 && eb >= ex && eb >= ey) {
    // Under the box: below a bottom face it left the region downward; elsewhere (under a closed bottom, the
    // outflow under an outlet) it is not beyond the region as before.
    const int c = locate(in);
    const int f = c < 0 ? -1 : side_face(static_cast<size_t>(c), Side::Bottom);
    if (f >= 0) {
      b.where = Beyond::Below;
      b.face = f;
    }
  } else if (ex > 0.0 || ey > 0.0) {
    const int c = locate(in);
    const Side s = ex >= ey ? (x.x < lo.x ? Side::XLo : Side::XHi) : (x.y < lo.y ? Side::YLo : Side::YHi);
    b.where = Beyond::Beside;
    b.face = c < 0 ? -1 : side_face(static_cast<size_t>(c), s);
  }
  return b;
}

bool CouplingGeometry::below_a_bottom_face(const Vec3& x) const {
  return bottom_faces_ > 0 && beyond(x).where == Beyond::Below;
}

bool CouplingGeometry::beside_a_closed_side(const Vec3& x) const {
  const Beyond b = beyond(x);
  return b.where == Beyond::Beside && b.face < 0;
}

int CouplingGeometry::exit_face(const Vec3& x) const {
  if (faces_.empty()) return -1;
  const Beyond b = beyond(x);  // above the top, its column's face; beside the box, the side face next to it
  if (b.where == Beyond::Above) {
    const int f = face_column(x);
    if (f >= 0) return f;
  } else if ((b.where == Beyond::Beside || b.where == Beyond::Below) && b.face >= 0) {
    return b.face;
  }
  int best = -1;  // otherwise the nearest face (rare): brute force
  double best_d2 = 0.0;
  for (size_t q = 0; q < faces_.size(); ++q) {
    Vec3 a, b;
    face_slab(q, 0.0, a, b);
    const double dx = std::max({a.x - x.x, 0.0, x.x - b.x}), dy = std::max({a.y - x.y, 0.0, x.y - b.y}),
                 dz = std::max({a.z - x.z, 0.0, x.z - b.z});
    const double d2 = dx * dx + dy * dy + dz * dz;
    if (best < 0 || d2 < best_d2) {
      best = static_cast<int>(q);
      best_d2 = d2;
    }
  }
  return best;
}

}  // namespace mlcg::bus
