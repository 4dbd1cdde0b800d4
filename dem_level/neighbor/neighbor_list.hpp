#pragma once
// Neighbour search: particles are binned into cubic cells no smaller than the
// largest interaction distance (2 r_max + skin), and a half Verlet list is
// built from the 27 surrounding cells: each pair (i, j) appears once, under
// the smaller index i, when |x_i - x_j| < r_i + r_j + skin (particles appended
// since the build: under the later one, see append()). Ghost particles
// (index >= n_local) only ever appear as j. The list is rebuilt when some
// particle has moved more than skin/2 since the last build.
//
// Tangential contact history lives beside the list (hist[k] for pair k) while
// the list is valid; across a rebuild it goes through a ContactHistory keyed by
// particle id, so it survives reordering, removal and migration.
#include <cstdint>
#include <vector>

#include "core/particles.hpp"
#include "core/spheres.hpp"
#include "core/vec3.hpp"

namespace mlcg {

class CellBins {
 public:
  // Bin particles [0, count) of x into cells of at least min_cell over their bounding box.
  // The number of cells is capped at about 8 per particle by enlarging the cells.
  void build(const std::vector<Vec3>& x, size_t count, double min_cell);
  int cell_of(const Vec3& p) const;
  void cell_coords(const Vec3& p, int& ix, int& iy, int& iz) const;
  int index(int ix, int iy, int iz) const { return (iz * ny_ + iy) * nx_ + ix; }
  int nx() const { return nx_; }
  int ny() const { return ny_; }
  int nz() const { return nz_; }
  double cell_size() const { return h_; }
  // Particles of cell c: sorted[start[c] .. start[c+1]).
  const std::vector<int32_t>& start() const { return start_; }
  const std::vector<int32_t>& sorted() const { return sorted_; }
  size_t bytes() const { return (start_.capacity() + sorted_.capacity() + cell_.capacity()) * sizeof(int32_t); }

 private:
  Vec3 lo_;
  double h_ = 1.0, inv_h_ = 1.0;
  int nx_ = 1, ny_ = 1, nz_ = 1;
  std::vector<int32_t> start_, sorted_, cell_;
};

// Calls f(k, j, d2) once for every pair of a new local particle k in [first_new, n_local) with a
// particle j < k, older or new, whose centres lie closer than r_k + r_j + reach (d2: their squared
// distance): the new ones hashed, one pass over the others in their slab. The insertion's overlap
// check and NeighborList::append both ask this.
template <class F>
void for_new_pairs(const Particles& p, size_t first_new, double reach, F&& f) {
  const size_t n = p.n_local();
  if (first_new >= n) return;
  double r_new = 0.0;
  for (size_t k = first_new; k < n; ++k) r_new = std::max(r_new, p.radius[k]);
  SphereHash fresh(2.0 * r_new + reach);
  // The box around the new ones within reach: an older particle outside it by more than its radius has
  // no partner among them (a slab in z alone let a whole layer of the level through, for one particle).
  Vec3 lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
  for (size_t k = first_new; k < n; ++k) {
    fresh.add(p.x[k], p.radius[k]);
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], p.x[k][a] - r_new - reach);
      hi[a] = std::max(hi[a], p.x[k][a] + r_new + reach);
    }
  }
  for (size_t j = 0; j < n; ++j) {
    if (j < first_new) {
      const Vec3& x = p.x[j];
      const double r = p.radius[j];
      if (x.z + r < lo.z || x.z - r > hi.z || x.x + r < lo.x || x.x - r > hi.x || x.y + r < lo.y || x.y - r > hi.y)
        continue;
    }
    fresh.find_near(p.x[j], p.radius[j] + reach, [&](size_t q, const Vec3& xk, double rk) {
      const double cut = rk + p.radius[j] + reach, d2 = norm2(xk - p.x[j]);
      if (first_new + q > j && d2 < cut * cut) f(first_new + q, j, d2);
      return false;
    });
  }
}

class NeighborList {
 public:
  std::vector<int32_t> first{0};  // n_local + 1 offsets into neigh
  std::vector<int32_t> neigh;
  std::vector<Vec3f> hist;        // one per pair when the model keeps history (single precision: see Vec3f)

  void set_skin(double skin) { skin_ = skin; }
  double skin() const { return skin_; }

  // Build the half list for the current positions; keeps x_build for the displacement test.
  void build(const Particles& p, bool with_history);
  // Lists the pairs of particles [first_new, n) appended since the last build or append, without
  // touching the other rows. Every pair of a new particle is listed under the later of the two, j < i
  // in those rows (the kernels apply each pair to both partners whatever their order). Only for a
  // list with no ghosts among the particles (one rank). A new particle's pairs reach r_i + r_j + 1.5 skin: until the next rebuild it moves at most
  // skin/2 from where it is inserted, an older particle at most skin/2 from its position at the
  // build, so up to a whole skin from where it is now.
  void append(const Particles& p, size_t first_new, bool with_history);
  bool needs_rebuild(const Particles& p) const;
  // Positions at the last build (for a fused displacement test); null if they do not match p.
  const Vec3* reference(const Particles& p) const { return x_build_.size() == p.size() ? x_build_.data() : nullptr; }
  // The list was built (or appended to) for exactly these particles.
  bool matches(const Particles& p) const { return x_build_.size() == p.size() && first.size() == p.n_local() + 1; }

  // Move the history of touching pairs into per-particle storage (both partners
  // get an entry: i holds +h under id_j, j holds -h under id_i).
  void save_history(const Particles& p, ContactHistory& out) const;
  // Fill hist[] for the freshly built list from per-particle storage.
  void load_history(const Particles& p, const ContactHistory& in);

  // The material every particle of the last build has (ghosts included), or -1 when they differ:
  // the pair kernel then holds one coefficient set for the whole list.
  int32_t single_material() const { return single_material_; }
  // The radius and mass every particle of the last build or append has (ghosts included), else
  // radius = -1: a list of one size, whose kernel holds them as loop invariants.
  struct OneSize {
    double radius = -1.0, mass = -1.0;
  };
  OneSize single_size() const { return single_size_; }

  size_t extra_bytes() const { return x_build_.capacity() * sizeof(Vec3); }
  size_t pairs() const { return neigh.size(); }
  uint64_t builds() const { return builds_; }
  void set_builds(uint64_t b) { builds_ = b; }

 private:
  double skin_ = 0.0;
  std::vector<Vec3> x_build_;
  CellBins bins_;
  uint64_t builds_ = 0;
  int32_t single_material_ = -1;
  OneSize single_size_;
  // Particles [from, to) against the list's one material and one size: one that differs ends either.
  void note_sameness(const Particles& p, size_t from, size_t to);
};

}  // namespace mlcg
