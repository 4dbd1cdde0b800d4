#pragma once
// Eulerian statistics on a grid of cubic cells (paper §2.3, Eq. 8). A particle
// belongs to the cell holding its centre. Per sample, per cell:
//   volume fraction  phi = sum V_p / V_cell
//   Favre velocity   u = sum m v / sum m, and the largest particle speed
//   stress           sigma = (sum_i [sum_c b_ic (x) f_ic + m_i v'_i (x) v'_i]) / V_cell
// with b_ic the branch vector from contact c to the centre of i (r_ij/2 for a
// particle pair) and v' = v - u; compression is positive. Samples are averaged
// over an output interval (velocity mass-weighted, max speed as a maximum).
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "core/particles.hpp"

// The sample's sums in AVX-512 registers where the build has them (sum_vector), else one double at a time.
#if defined(__AVX512F__) && defined(__FMA__)
#define MLCG_VECTOR_SAMPLE 1
#else
#define MLCG_VECTOR_SAMPLE 0
#endif

namespace mlcg {

struct GridParams {
  std::string name;
  Vec3 origin;
  double h = 0.0;
  int nx = 1, ny = 1, nz = 1;
  size_t cells() const { return static_cast<size_t>(nx) * static_cast<size_t>(ny) * static_cast<size_t>(nz); }
};

struct GridAverages {
  std::vector<double> volume_fraction, max_speed, stress6, count;
  std::vector<Vec3> mean_velocity;
};

class CellGrid {
 public:
  struct State {  // running sums since the last output (checkpointed)
    int64_t samples = 0;
    std::vector<double> phi, mass, max_speed, stress6, count;
    std::vector<Vec3> momentum;
  };

  explicit CellGrid(GridParams prm);
  const GridParams& params() const { return prm_; }
  int cell_of(const Vec3& x) const {  // -1 outside; inline: the per-particle sampling loops call it
    const Vec3 r = (x - prm_.origin) * (1.0 / prm_.h);
    const int ix = static_cast<int>(std::floor(r.x));
    const int iy = static_cast<int>(std::floor(r.y));
    const int iz = static_cast<int>(std::floor(r.z));
    if (ix < 0 || iy < 0 || iz < 0 || ix >= prm_.nx || iy >= prm_.ny || iz >= prm_.nz) return -1;
    return (iz * prm_.ny + iy) * prm_.nx + ix;
  }

  // One sample in two parts so that ranks can sum their parts in between:
  // local_sample() fills `sums` (kSums values per cell, add over ranks) and
  // `max_speed` (take the maximum over ranks); add_sample() turns the global
  // sums into this sample's cell values. stress6: per-particle contact dyads
  // (6 per particle) accumulated by the force kernels.
  static constexpr size_t kSums = 20;  // mass, volume, count, momentum(3), sum m v v (6), contact (6)
  // only: null, or the local particles that may lie in the grid, in increasing order (the sums
  // are then the same to the last bit: the others add nothing).
  void local_sample(const Particles& p, const std::vector<double>& stress6, std::vector<double>& sums,
                    std::vector<double>& max_speed, const std::vector<uint32_t>* only = nullptr) const;
  // The same with the one-double-at-a-time loop whatever the build: the reference the vector loop is tested
  // against, bit for bit.
  void local_sample_scalar(const Particles& p, const std::vector<double>& stress6, std::vector<double>& sums,
                           std::vector<double>& max_speed, const std::vector<uint32_t>* only = nullptr) const;
  void add_sample(const std::vector<double>& sums, const std::vector<double>& max_speed);
  // Cells (flat index, non-zero = wanted) whose stress is summed; the others' stress stays 0 and their
  // particles skip the stress's 12 sums. Empty (the default): every cell.
  void set_stress_cells(std::vector<char> wanted);
  GridAverages take_averages();  // averages since the last call, then resets
  State& state() { return st_; }
  const State& state() const { return st_; }

 private:
  bool stress_wanted(int c) const { return stress_cells_.empty() || stress_cells_[static_cast<size_t>(c)] != 0; }
  void sample(const Particles& p, const std::vector<double>& stress6, std::vector<double>& sums,
              std::vector<double>& max_speed, const std::vector<uint32_t>* only, bool vector) const;
  // The per-particle loops of sample(): add to sums and square speeds zeroed by the caller.
  void sum_scalar(const Particles& p, const std::vector<double>& stress6, std::vector<double>& sums,
                  std::vector<double>& max_speed, const std::vector<uint32_t>* only) const;
  void sum_vector(const Particles& p, const std::vector<double>& stress6, std::vector<double>& sums,
                  std::vector<double>& max_speed, const std::vector<uint32_t>* only) const;
  GridParams prm_;
  State st_;
  std::vector<char> stress_cells_;
};

}  // namespace mlcg
