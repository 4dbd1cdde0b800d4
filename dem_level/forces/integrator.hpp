#pragma once
// Velocity Verlet for translation and rotation of spheres (I = 2/5 m r^2):
//   first half:  v += dt/2 f/m,  w += dt/2 t/I,  x += dt v, then f = m g, t = 0
//   (contact forces added at the new positions)
//   second half: v += dt/2 f/m,  w += dt/2 t/I
// Both return a checksum of what they wrote, finite exactly when every value
// is, so the NaN/inf guard costs one test per step instead of one per particle.
// integrate_owed_kick_first_half does the last step's second half and this
// step's first half in one pass over the arrays (the same operations per value).
// Eight particles at a time in the arrays' layout (first_half8, second_half8), the
// remainder through the per-particle loops; both do the same operations per value.
#include <algorithm>
#include <vector>

#include "core/particles.hpp"

namespace mlcg {

struct FirstHalf {
  double checksum;   // finite exactly when every new position is
  double max_disp2;  // largest squared displacement since x_ref (0 without x_ref)
  double owed_checksum = 0.0;  // with an owed second half: finite exactly when its velocities and spins are
};

namespace integrator_detail {

// The arrays the integrator walks, as doubles (three per particle for the vectors), from one particle on.
struct KickArrays {
  double *x, *v, *w, *f, *t;
  const double *inv_mass, *inv_inertia, *mass;
  const double* x_ref;  // positions at the last list build; null without the displacement test

  KickArrays from(size_t i) const {
    return {x + 3 * i,    v + 3 * i,           w + 3 * i, f + 3 * i, t + 3 * i,
            inv_mass + i, inv_inertia + i, mass + i,  x_ref ? x_ref + 3 * i : nullptr};
  }
};

// The first half over particles [0, n) as flat arrays (three doubles per particle). The checksum's
// additions may be reordered (omp simd reduction): it is only ever tested for finiteness, which no
// order changes for positions of simulation size; the largest displacement is exact in any order.
// Owed: first the second half of the last step (v += a f, w += b t with the forces still in f, t).
template <bool WithRef, bool Owed>
FirstHalf first_half(size_t n, double dt, const Vec3& g, const KickArrays& a) {
  double *__restrict x = a.x, *__restrict v = a.v, *__restrict w = a.w, *__restrict f = a.f, *__restrict t = a.t;
  const double *__restrict inv_mass = a.inv_mass, *__restrict inv_inertia = a.inv_inertia, *__restrict mass = a.mass,
               *__restrict x_ref = a.x_ref;
  const double h = 0.5 * dt;
  double sum = 0.0, disp2 = 0.0, owed = 0.0;
#pragma omp simd reduction(+ : sum, owed) reduction(max : disp2)
  for (size_t i = 0; i < n; ++i) {
    const double a = h * inv_mass[i];
    const double b = h * inv_inertia[i];
    double d2 = 0.0;
    for (size_t c = 0; c < 3; ++c) {
      const size_t k = 3 * i + c;
      if constexpr (Owed) {
        v[k] += a * f[k];
        w[k] += b * t[k];
        owed += v[k] + w[k];
      }
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
  return {sum, disp2, owed};
}

inline double second_half(size_t n, double dt, const KickArrays& a) {
  double *__restrict v = a.v, *__restrict w = a.w;
  const double *__restrict f = a.f, *__restrict t = a.t, *__restrict inv_mass = a.inv_mass,
               *__restrict inv_inertia = a.inv_inertia;
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

// Eight particles at a time in the arrays' own layout (x0 y0 z0 x1 ... : three 8-wide vectors per
// array), the per-particle factors spread to it by one permutation each: the loops above transpose
// every array in and out instead, which costs more than the arithmetic. Same operations per value.
using V8 = double __attribute__((vector_size(64)));
using I8 = long __attribute__((vector_size(64)));
inline V8 load8(const double* p) {
  V8 r;
  __builtin_memcpy(&r, p, sizeof r);
  return r;
}
inline void store8(double* p, V8 v) { __builtin_memcpy(p, &v, sizeof v); }
// Particle k's factor to its three lanes: vector q holds lanes 8q .. 8q + 7 of the 24.
inline void spread(V8 s, V8 out[3]) {
  out[0] = __builtin_shuffle(s, I8{0, 0, 0, 1, 1, 1, 2, 2});
  out[1] = __builtin_shuffle(s, I8{2, 3, 3, 3, 4, 4, 4, 5});
  out[2] = __builtin_shuffle(s, I8{5, 5, 6, 6, 6, 7, 7, 7});
}

template <bool WithRef, bool Owed>
FirstHalf first_half8(size_t n8, double dt, const Vec3& g, const KickArrays& a) {
  double *__restrict x = a.x, *__restrict v = a.v, *__restrict w = a.w, *__restrict f = a.f, *__restrict t = a.t;
  const double *__restrict inv_mass = a.inv_mass, *__restrict inv_inertia = a.inv_inertia, *__restrict mass = a.mass,
               *__restrict x_ref = a.x_ref;
  const double h = 0.5 * dt;
  const V8 G[3] = {{g.x, g.y, g.z, g.x, g.y, g.z, g.x, g.y},
                   {g.z, g.x, g.y, g.z, g.x, g.y, g.z, g.x},
                   {g.y, g.z, g.x, g.y, g.z, g.x, g.y, g.z}};
  V8 sum{}, disp2{}, owed{};
  for (size_t i = 0; i < n8; i += 8) {
    V8 a[3], b[3], m[3], d[3];
    spread(h * load8(inv_mass + i), a);
    spread(h * load8(inv_inertia + i), b);
    spread(load8(mass + i), m);
    for (size_t q = 0; q < 3; ++q) {
      const size_t k = 3 * i + 8 * q;
      const V8 fk = load8(f + k), tk = load8(t + k);
      V8 vk = load8(v + k), wk = load8(w + k);
      if constexpr (Owed) {
        vk = vk + a[q] * fk;
        wk = wk + b[q] * tk;
        owed += vk + wk;
      }
      vk = vk + a[q] * fk;
      const V8 xk = load8(x + k) + dt * vk;
      store8(v + k, vk);
      store8(w + k, wk + b[q] * tk);
      store8(x + k, xk);
      store8(f + k, m[q] * G[q]);
      store8(t + k, V8{});
      sum += xk;
      if constexpr (WithRef) d[q] = xk - load8(x_ref + k);
    }
    if constexpr (WithRef) {
      // The components of the eight displacements side by side, then |d|^2 as the loop above sums it.
      const V8 dx = __builtin_shuffle(d[0], d[1], I8{0, 3, 6, 9, 12, 15, 0, 0});
      const V8 dy = __builtin_shuffle(d[0], d[1], I8{1, 4, 7, 10, 13, 0, 0, 0});
      const V8 dz = __builtin_shuffle(d[0], d[1], I8{2, 5, 8, 11, 14, 0, 0, 0});
      const V8 ex = __builtin_shuffle(dx, d[2], I8{0, 1, 2, 3, 4, 5, 10, 13});
      const V8 ey = __builtin_shuffle(dy, d[2], I8{0, 1, 2, 3, 4, 8, 11, 14});
      const V8 ez = __builtin_shuffle(dz, d[2], I8{0, 1, 2, 3, 4, 9, 12, 15});
      V8 d2 = ex * ex;
      d2 += ey * ey;
      d2 += ez * ez;
      disp2 = d2 > disp2 ? d2 : disp2;
    }
  }
  double s = 0.0, m2 = 0.0, o = 0.0;
  for (int l = 0; l < 8; ++l) {
    s += sum[l];
    o += owed[l];
    m2 = std::max(m2, disp2[l]);
  }
  return {s, m2, o};
}

inline double second_half8(size_t n8, double dt, const KickArrays& a) {
  double *__restrict v = a.v, *__restrict w = a.w;
  const double *__restrict f = a.f, *__restrict t = a.t, *__restrict inv_mass = a.inv_mass,
               *__restrict inv_inertia = a.inv_inertia;
  const double h = 0.5 * dt;
  V8 sum{};
  for (size_t i = 0; i < n8; i += 8) {
    V8 a[3], b[3];
    spread(h * load8(inv_mass + i), a);
    spread(h * load8(inv_inertia + i), b);
    for (size_t q = 0; q < 3; ++q) {
      const size_t k = 3 * i + 8 * q;
      const V8 vk = load8(v + k) + a[q] * load8(f + k);
      const V8 wk = load8(w + k) + b[q] * load8(t + k);
      store8(v + k, vk);
      store8(w + k, wk);
      sum += vk + wk;
    }
  }
  double s = 0.0;
  for (int l = 0; l < 8; ++l) s += sum[l];
  return s;
}

// A Vec3 array as its doubles (x0 y0 z0 x1 ...); only for a non-empty array.
inline double* flat(std::vector<Vec3>& a) { return &a[0].x; }

inline KickArrays kick_arrays(Particles& p, const Vec3* x_ref) {
  return {flat(p.x),        flat(p.v),           flat(p.omega), flat(p.f), flat(p.torque),
          p.inv_mass.data(), p.inv_inertia.data(), p.mass.data(), x_ref ? &x_ref[0].x : nullptr};
}

template <bool Owed>
FirstHalf first_half_all(Particles& p, double dt, const Vec3& g, const Vec3* x_ref) {
  const size_t n = p.n_local();
  if (n == 0) return {0.0, 0.0};
  const size_t n8 = n - n % 8;
  const KickArrays a = kick_arrays(p, x_ref);
  const FirstHalf head = x_ref ? first_half8<true, Owed>(n8, dt, g, a) : first_half8<false, Owed>(n8, dt, g, a);
  const KickArrays rest = a.from(n8);
  const FirstHalf tail =
      x_ref ? first_half<true, Owed>(n - n8, dt, g, rest) : first_half<false, Owed>(n - n8, dt, g, rest);
  return {head.checksum + tail.checksum, std::max(head.max_disp2, tail.max_disp2),
          head.owed_checksum + tail.owed_checksum};
}

}  // namespace integrator_detail

// The first half, fused with the start of the next force computation (f = m g,
// torque = 0) and the neighbour list's displacement test against x_ref, so the
// particle arrays are walked once instead of three times per step.
inline FirstHalf integrate_first_half(Particles& p, double dt, const Vec3& g, const Vec3* x_ref) {
  return integrator_detail::first_half_all<false>(p, dt, g, x_ref);
}

// The last step's second half (its forces still in f and torque), then this step's first half, in
// one pass: a large level reads its arrays from memory once less per step. owed_checksum is the
// second half's checksum.
inline FirstHalf integrate_owed_kick_first_half(Particles& p, double dt, const Vec3& g, const Vec3* x_ref) {
  return integrator_detail::first_half_all<true>(p, dt, g, x_ref);
}

// The checksum as the first half's (finite exactly when every new velocity and spin is).
inline double integrate_second_half(Particles& p, double dt) {
  using namespace integrator_detail;
  const size_t n = p.n_local();
  if (n == 0) return 0.0;
  const size_t n8 = n - n % 8;
  const KickArrays a = kick_arrays(p, nullptr);
  return second_half8(n8, dt, a) + second_half(n - n8, dt, a.from(n8));
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
