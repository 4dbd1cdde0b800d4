#pragma once
// Velocity Verlet for translation and rotation of spheres (I = 2/5 m r^2):
//   first half:  v += dt/2 f/m,  w += dt/2 t/I,  x += dt v, then f = m g, t = 0
//   (contact forces added at the new positions)
//   second half: v += dt/2 f/m,  w += dt/2 t/I
// Both return a checksum of what they wrote, finite exactly when every value
// is, so the NaN/inf guard costs one test per step instead of one per particle.
#include <algorithm>

#include "core/particles.hpp"

namespace mlcg {

struct FirstHalf {
  double checksum;   // finite exactly when every new position is
  double max_disp2;  // largest squared displacement since x_ref (0 without x_ref)
};

// The first half, fused with the start of the next force computation (f = m g,
// torque = 0) and the neighbour list's displacement test against x_ref, so the
// particle arrays are walked once instead of three times per step.
inline FirstHalf integrate_first_half(Particles& p, double dt, const Vec3& g, const Vec3* x_ref) {
  const double h = 0.5 * dt;
  const size_t n = p.n_local();
  double sum = 0.0, disp2 = 0.0;
  for (size_t i = 0; i < n; ++i) {
    const double a = h * p.inv_mass[i];
    const double b = h * p.inv_inertia[i];
    p.v[i] += a * p.f[i];
    p.omega[i] += b * p.torque[i];
    p.x[i] += dt * p.v[i];
    p.f[i] = p.mass[i] * g;
    p.torque[i] = {};
    sum += p.x[i].x + p.x[i].y + p.x[i].z;
    if (x_ref) disp2 = std::max(disp2, norm2(p.x[i] - x_ref[i]));
  }
  return {sum, disp2};
}

inline double integrate_second_half(Particles& p, double dt) {
  const double h = 0.5 * dt;
  const size_t n = p.n_local();
  double sum = 0.0;
  for (size_t i = 0; i < n; ++i) {
    const double a = h * p.inv_mass[i];
    const double b = h * p.inv_inertia[i];
    p.v[i] += a * p.f[i];
    p.omega[i] += b * p.torque[i];
    sum += p.v[i].x + p.v[i].y + p.v[i].z + p.omega[i].x + p.omega[i].y + p.omega[i].z;
  }
  return sum;
}

// Ghosts carry no force of their own (their owner integrates them); the kernels
// add into their slots, which are cleared here.
inline void clear_ghost_forces(Particles& p) {
  for (size_t i = p.n_local(); i < p.size(); ++i) {
    p.f[i] = {};
    p.torque[i] = {};
  }
}

}  // namespace mlcg
