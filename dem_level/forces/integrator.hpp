#pragma once
// Velocity Verlet for translation and rotation of spheres (I = 2/5 m r^2):
//   first half:  v += dt/2 f/m,  w += dt/2 t/I,  x += dt v
//   (forces at the new positions)
//   second half: v += dt/2 f/m,  w += dt/2 t/I
// Both return a checksum of what they wrote, finite exactly when every value
// is, so the NaN/inf guard costs one test per step instead of one per particle.
#include "core/particles.hpp"

namespace mlcg {

inline double integrate_first_half(Particles& p, double dt) {
  const double h = 0.5 * dt;
  const size_t n = p.n_local();
  double sum = 0.0;
  for (size_t i = 0; i < n; ++i) {
    const double a = h * p.inv_mass[i];
    const double b = h * p.inv_inertia[i];
    p.v[i] += a * p.f[i];
    p.omega[i] += b * p.torque[i];
    p.x[i] += dt * p.v[i];
    sum += p.x[i].x + p.x[i].y + p.x[i].z;
  }
  return sum;
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

// Forces start each step as gravity; torques as zero.
inline void init_forces(Particles& p, const Vec3& g) {
  const size_t n = p.size();
  for (size_t i = 0; i < n; ++i) {
    p.f[i] = p.mass[i] * g;
    p.torque[i] = {};
  }
}

}  // namespace mlcg
