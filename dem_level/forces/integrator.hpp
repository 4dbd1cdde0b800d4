#pragma once
// Velocity Verlet for translation and rotation of spheres (I = 2/5 m r^2):
//   first half:  v += dt/2 f/m,  w += dt/2 t/I,  x += dt v, then f = m g, t = 0
//   (contact forces added at the new positions)
//   second half: v += dt/2 f/m,  w += dt/2 t/I
// Both return a checksum of what they wrote, finite exactly when every value
// is, so the NaN/inf guard costs one test per step instead of one per particle.
#include <algorithm>
#include <vector>

#include "core/particles.hpp"

namespace mlcg {

struct FirstHalf {
  double checksum;   // finite exactly when every new position is
  double max_disp2;  // largest squared displacement since x_ref (0 without x_ref)
};

namespace integrator_detail {

// The first half over particles [0, n) as flat arrays (three doubles per particle). The checksum's
// additions may be reordered (omp simd reduction): it is only ever tested for finiteness, which no
// order changes for positions of simulation size; the largest displacement is exact in any order.
template <bool WithRef>
FirstHalf first_half(size_t n, double dt, const Vec3& g, double* __restrict x, double* __restrict v,
                     double* __restrict w, double* __restrict f, double* __restrict t,
                     const double* __restrict inv_mass, const double* __restrict inv_inertia,
                     const double* __restrict mass, const double* __restrict x_ref) {
  const double h = 0.5 * dt;
  double sum = 0.0, disp2 = 0.0;
#pragma omp simd reduction(+ : sum) reduction(max : disp2)
  for (size_t i = 0; i < n; ++i) {
    const double a = h * inv_mass[i];
    const double b = h * inv_inertia[i];
    double d2 = 0.0;
    for (size_t c = 0; c < 3; ++c) {
      const size_t k = 3 * i + c;
      v[k] += a * f[k];
      w[k] += b * t[k];
      x[k] += dt * v[k];
      f[k] = mass[i] * g[static_cast<int>(c)];
      t[k] = 0.0;
      if constexpr (WithRef) d2 += (x[k] - x_ref[k]) * (x[k] - x_ref[k]);
    }
    sum += x[3 * i] + x[3 * i + 1] + x[3 * i + 2];
    disp2 = std::max(disp2, d2);
  }
  return {sum, disp2};
}

inline double second_half(size_t n, double dt, double* __restrict v, double* __restrict w,
                          const double* __restrict f, const double* __restrict t,
                          const double* __restrict inv_mass, const double* __restrict inv_inertia) {
  const double h = 0.5 * dt;
  double sum = 0.0;
#pragma omp simd reduction(+ : sum)
  for (size_t i = 0; i < n; ++i) {
    const double a = h * inv_mass[i];
    const double b = h * inv_inertia[i];
    for (size_t c = 0; c < 3; ++c) {
      const size_t k = 3 * i + c;
      v[k] += a * f[k];
      w[k] += b * t[k];
    }
    sum += v[3 * i] + v[3 * i + 1] + v[3 * i + 2] + w[3 * i] + w[3 * i + 1] + w[3 * i + 2];
  }
  return sum;
}

// A Vec3 array as its doubles (x0 y0 z0 x1 ...); only for a non-empty array.
inline double* flat(std::vector<Vec3>& a) { return &a[0].x; }

}  // namespace integrator_detail

// The first half, fused with the start of the next force computation (f = m g,
// torque = 0) and the neighbour list's displacement test against x_ref, so the
// particle arrays are walked once instead of three times per step.
inline FirstHalf integrate_first_half(Particles& p, double dt, const Vec3& g, const Vec3* x_ref) {
  using integrator_detail::flat;
  const size_t n = p.n_local();
  if (n == 0) return {0.0, 0.0};
  if (x_ref)
    return integrator_detail::first_half<true>(n, dt, g, flat(p.x), flat(p.v), flat(p.omega), flat(p.f),
                                               flat(p.torque), p.inv_mass.data(), p.inv_inertia.data(),
                                               p.mass.data(), &x_ref[0].x);
  return integrator_detail::first_half<false>(n, dt, g, flat(p.x), flat(p.v), flat(p.omega), flat(p.f),
                                              flat(p.torque), p.inv_mass.data(), p.inv_inertia.data(),
                                              p.mass.data(), nullptr);
}

// The checksum as the first half's (finite exactly when every new velocity and spin is).
inline double integrate_second_half(Particles& p, double dt) {
  using integrator_detail::flat;
  const size_t n = p.n_local();
  if (n == 0) return 0.0;
  return integrator_detail::second_half(n, dt, flat(p.v), flat(p.omega), flat(p.f), flat(p.torque),
                                        p.inv_mass.data(), p.inv_inertia.data());
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
