#pragma once
// What the force kernels report besides forces: the largest overlap relative
// to the smaller radius (the run stops if it passes the case's limit), the
// contact count, and when asked, per-particle stress contributions.
#include <cstdint>
#include <vector>

#include "core/vec3.hpp"

namespace mlcg {

struct ContactStats {
  double max_overlap_ratio = 0.0;
  int32_t worst_particle = -1;
  int64_t pair_contacts = 0;
  int pair_kernel = 0;  // the pair kernel's variant this step: 0 mixed, 1 one material, 2 one size (pair_kernel.hpp)
  int64_t wall_contacts = 0;
  double wall_power = 0.0;  // sum of F . v_wall over the contacts with moving walls [W]: the work they put in
};

// Symmetric part of branch (x) force, added into s[0..5] as xx yy zz xy xz yz.
inline void add_dyad(double* s, const Vec3& r, const Vec3& f) {
  s[0] += r.x * f.x;
  s[1] += r.y * f.y;
  s[2] += r.z * f.z;
  s[3] += 0.5 * (r.x * f.y + r.y * f.x);
  s[4] += 0.5 * (r.x * f.z + r.z * f.x);
  s[5] += 0.5 * (r.y * f.z + r.z * f.y);
}

}  // namespace mlcg
