#pragma once
// Particle-particle forces over the half neighbour list. Instantiated once per
// contact model and per "accumulate stress" choice, so a step without
// measurements or a model without history/rolling carries none of that code.
//
// The list is processed in blocks of 640 listed pairs. The touching pairs of a block are
// first found (indices only: about half the listed pairs do not touch), then
// gathered into small structure-of-arrays buffers (they fit in L2), then
// the contact law runs over them in one flat loop without branches, which the
// compiler vectorizes (one contact alone is a long chain of dependent square
// roots and divisions), then forces, torques and history are scattered back.
// The law is the same composed sub-models (contact/); a contact's result does
// not depend on its place in the block.
#include <algorithm>
#include <cmath>
#include <memory>
#include <vector>

#include "contact/inline.hpp"
#include "contact/model.hpp"
#include "core/material.hpp"
#include "core/particles.hpp"
#include "forces/contact_stats.hpp"
#include "neighbor/neighbor_list.hpp"

namespace mlcg {

// Listed pairs per block: the buffers of one block stay in L2, and every buffer is a fixed-size member
// of one struct, so the kernels address them all from one base register (separate vectors needed a
// register each, and the find pass spilled). The 8 spare slots keep the buffers from starting a
// multiple of 4 KiB apart: a store to one buffer then stalls the loads of another at the same index
// (1024 pairs without them: bed +25 %).
inline constexpr int32_t kBlockPairs = 640;
inline constexpr int32_t kSlots = kBlockPairs + 8;

// Three arrays, one per axis.
struct XyzArrays {
  double x[kSlots], y[kSlots], z[kSlots];
};

// The gathered contacts of one block (per thread, reused across steps).
struct ContactBlock {
  int32_t i[kSlots], j[kSlots], k[kSlots], cix[kSlots];
  double ri[kSlots], rj[kSlots], mi[kSlots], mj[kSlots];
  XyzArrays d;       // x_i - x_j
  XyzArrays dv;      // v_i - v_j
  XyzArrays ws;      // r_i w_i + r_j w_j
  XyzArrays wr;      // w_i - w_j (rolling only)
  XyzArrays h;       // tangential overlap, in and out
  XyzArrays f;       // force on i
  XyzArrays t;       // n x f_t (torques are -r (n x f_t))
  XyzArrays m;       // rolling torque on i
  double delta[kSlots];
};

inline ContactBlock& scratch_contacts() {
  static thread_local std::unique_ptr<ContactBlock> b = std::make_unique<ContactBlock>();
  return *b;
}

// What every particle of a list shares, decided once per call: nothing; one material (one coefficient
// set, a loop invariant); or one material, one radius and one mass (a level of one particle size, most
// levels: the radii, masses, effective radius and mass are loop invariants too, so the kernel loads no
// radius or mass and makes two divisions fewer per contact; each invariant is computed as the per-contact
// expression would be, so the forces are the same to the last bit).
enum class Same { Nothing, Material, Size };
using OneSize = NeighborList::OneSize;  // the radius and mass of a list of one size

// The contact law over contacts [0, n) of a block: one flat loop, no branches.
// The arrays are parameters because GCC honours __restrict only there, and without it the
// loop is not vectorized.
template <class Model, Same S>
void contact_law_loop(int32_t n, const PairCoeffs* coeffs, OneSize one, const int32_t* __restrict cix, double dt,
                      const double* __restrict dx, const double* __restrict dy, const double* __restrict dz,
                      const double* __restrict ri, const double* __restrict rj, const double* __restrict mi,
                      const double* __restrict mj, const double* __restrict dvx, const double* __restrict dvy,
                      const double* __restrict dvz, const double* __restrict wsx, const double* __restrict wsy,
                      const double* __restrict wsz, const double* __restrict wrx, const double* __restrict wry,
                      const double* __restrict wrz, double* __restrict hx, double* __restrict hy,
                      double* __restrict hz, double* __restrict fx, double* __restrict fy, double* __restrict fz,
                      double* __restrict tx, double* __restrict ty, double* __restrict tz, double* __restrict mx,
                      double* __restrict my, double* __restrict mz, double* __restrict delta) {
  const PairCoeffs c0 = coeffs[0];
  const double radsum0 = one.radius + one.radius, m_eff0 = one.mass * one.mass / (one.mass + one.mass),
               r_eff0 = one.radius * one.radius / radsum0;
  for (int32_t c = 0; c < n; ++c) {
    const double r = std::sqrt(dx[c] * dx[c] + dy[c] * dy[c] + dz[c] * dz[c]);
    const double rinv = 1.0 / r;
    ContactInput in;
    in.n = {dx[c] * rinv, dy[c] * rinv, dz[c] * rinv};
    if constexpr (S == Same::Size) {
      in.delta = radsum0 - r;
      in.m_eff = m_eff0;
      in.r_eff = r_eff0;
    } else {
      in.delta = ri[c] + rj[c] - r;
      in.m_eff = mi[c] * mj[c] / (mi[c] + mj[c]);
      in.r_eff = ri[c] * rj[c] / (ri[c] + rj[c]);
    }
    in.v_rel = Vec3{dvx[c], dvy[c], dvz[c]} - cross(Vec3{wsx[c], wsy[c], wsz[c]}, in.n);
    if constexpr (Model::has_rolling) in.w_rel = {wrx[c], wry[c], wrz[c]};
    Vec3 h{hx[c], hy[c], hz[c]};
    Vec3 force, ft, roll;
    double fn;
    if constexpr (S != Same::Nothing) Model::eval_into(c0, dt, in, h, force, ft, roll, fn);
    else Model::eval_into(coeffs[cix[c]], dt, in, h, force, ft, roll, fn);
    if constexpr (Model::has_history) {
      hx[c] = h.x;
      hy[c] = h.y;
      hz[c] = h.z;
    }
    fx[c] = force.x;
    fy[c] = force.y;
    fz[c] = force.z;
    tx[c] = in.n.y * ft.z - in.n.z * ft.y;
    ty[c] = in.n.z * ft.x - in.n.x * ft.z;
    tz[c] = in.n.x * ft.y - in.n.y * ft.x;
    if constexpr (Model::has_rolling) {
      mx[c] = roll.x;
      my[c] = roll.y;
      mz[c] = roll.z;
    }
    delta[c] = in.delta;
  }
}

template <class Model, Same S>
void block_contact_forces(ContactBlock& b, int32_t n, const PairCoeffs* coeffs, OneSize one, double dt) {
  contact_law_loop<Model, S>(n, coeffs, one, b.cix, dt, b.d.x, b.d.y, b.d.z, b.ri, b.rj, b.mi, b.mj, b.dv.x, b.dv.y,
                                   b.dv.z, b.ws.x, b.ws.y, b.ws.z, b.wr.x, b.wr.y, b.wr.z, b.h.x, b.h.y, b.h.z, b.f.x,
                                   b.f.y, b.f.z, b.t.x, b.t.y, b.t.z, b.m.x, b.m.y, b.m.z, b.delta);
}

// The arrays the pair kernel reads and writes, taken once per call.
struct PairArrays {
  const Vec3* x;
  const Vec3* v;
  const Vec3* w;
  const double* rad;
  const double* mass;
  const int32_t* mat;
  Vec3* f;
  Vec3* t;
  const int32_t* first;  // the list's offsets
  const int32_t* neigh;
  Vec3f* hist;           // null without history
  int nmat;
  Same same;      // Material: cix is not written; Size: neither are ri, rj, mi, mj
  OneSize one;    // with Same::Size
  bool prefetch;  // start the partner's loads early (large levels)
  int32_t last;   // the last listed pair
};

// Below this many particles on a rank (ghosts included) the arrays stay in the caches, where
// prefetching costs more than it saves. Force time with / without, 2026-12-03: 30,000 +7 %,
// 60,000 +4 %, 135,000 (a 270,000 bed on 2 ranks) -5 to -10 %, 270,000 -8 %, 1,080,000 -13 %.
inline constexpr size_t kPrefetchAbove = 100000;

namespace pair_detail {

// The find pass waits on x_j and r_j from memory on large levels: their loads start this many listed pairs
// ahead (about 25 particles). 1,080,000 particles: force 60.3 -> 58.6 ns per particle-step; 16, 48, 256 and
// 640 ahead gained less; on 30,000 (no Prefetch) it was slower.
inline constexpr int32_t kAheadPairs = 128;

// 1a. The touching pairs among listed pairs [k0, k1), as (i, k) in list order with x_i - x_j; returns their
// count. i is the particle that owns pair k0 (the first with first[i + 1] > k0); it is advanced to the
// owner of k1.
// Branch-free: whether a listed pair touches is unpredictable, so every pair is written to the next
// slot and the slot only advances if it touches. A listed pair that does not touch costs one test, and
// as few stores as possible (j and r_j, cheap to load again for the touching ones, are not kept).
template <bool Prefetch, Same S>
MLCG_INLINE int32_t find_touching(const PairArrays& a, size_t& i, int32_t k0, int32_t k1, ContactBlock& b) {
  const Vec3* __restrict x = a.x;
  const double* __restrict rad = a.rad;
  const int32_t* __restrict neigh = a.neigh;
  int32_t nc = 0;
  for (int32_t k = k0; k < k1; ++i) {
    const Vec3 xi = x[i];
    const double ri = S == Same::Size ? a.one.radius : rad[i];
    for (const int32_t end = std::min(a.first[i + 1], k1); k < end; ++k) {
      const auto j = static_cast<size_t>(neigh[k]);
      // The gather and the scatter read and write the partner's other arrays in a moment:
      // start those loads now when they come from memory, and x, r of a pair further on.
      if constexpr (Prefetch) {
        const auto jf = static_cast<size_t>(neigh[std::min(k + kAheadPairs, a.last)]);
        __builtin_prefetch(&x[jf]);
        if constexpr (S != Same::Size) __builtin_prefetch(&rad[jf]);
        __builtin_prefetch(&a.v[j]);
        __builtin_prefetch(&a.w[j]);
        if constexpr (S != Same::Size) __builtin_prefetch(&a.mass[j]);
        __builtin_prefetch(&a.f[j], 1);
        __builtin_prefetch(&a.t[j], 1);
      }
      const double rj = S == Same::Size ? a.one.radius : rad[j];
      const double radsum = ri + rj;
      const Vec3 d = xi - x[j];
      const bool touch = norm2(d) < radsum * radsum;
      // The slot is written for every pair and kept for the touching.
      const auto c = static_cast<size_t>(nc);
      b.i[c] = static_cast<int32_t>(i);
      b.k[c] = k;
      b.d.x[c] = d.x;
      b.d.y[c] = d.y;
      b.d.z[c] = d.z;
      nc += touch ? 1 : 0;
    }
  }
  // The last particle's pairs may go on in the next block.
  if (k1 > k0 && a.first[i] > k1) --i;
  return nc;
}

// 1b. What the contact law needs, for the nc touching pairs found.
template <class Model, Same S>
MLCG_INLINE void gather_touching(const PairArrays& a, int32_t nc, ContactBlock& b) {
  const Vec3* __restrict v = a.v;
  const Vec3* __restrict w = a.w;
  const double* __restrict rad = a.rad;
  const double* __restrict mass = a.mass;
  for (int32_t q = 0; q < nc; ++q) {
    const auto c = static_cast<size_t>(q);
    const auto i = static_cast<size_t>(b.i[c]);
    const auto j = static_cast<size_t>(a.neigh[b.k[c]]);
    const double ri = S == Same::Size ? a.one.radius : rad[i], rj = S == Same::Size ? a.one.radius : rad[j];
    b.j[c] = static_cast<int32_t>(j);
    if constexpr (S == Same::Nothing) b.cix[c] = a.mat[i] * a.nmat + a.mat[j];  // one material: the law never reads it
    if constexpr (S != Same::Size) {
      b.rj[c] = rj;
      b.ri[c] = ri;
      b.mi[c] = mass[i];
      b.mj[c] = mass[j];
    }
    const Vec3 dv = v[i] - v[j];
    const Vec3 ws = ri * w[i] + rj * w[j];
    b.dv.x[c] = dv.x;
    b.dv.y[c] = dv.y;
    b.dv.z[c] = dv.z;
    b.ws.x[c] = ws.x;
    b.ws.y[c] = ws.y;
    b.ws.z[c] = ws.z;
    if constexpr (Model::has_rolling) {
      const Vec3 wr = w[i] - w[j];
      b.wr.x[c] = wr.x;
      b.wr.y[c] = wr.y;
      b.wr.z[c] = wr.z;
    }
    if constexpr (Model::has_history) {
      const Vec3 h = a.hist[b.k[c]];
      b.h.x[c] = h.x;
      b.h.y[c] = h.y;
      b.h.z[c] = h.z;
    }
  }
}

// The block's history is in the buffers after the gather: it is cleared in the list, and the scatter
// writes it back for the touching pairs, so the others are reset. Then the next block's history, a
// stream the law's time hides, is prefetched.
template <class Model, bool Prefetch>
MLCG_INLINE void reset_history(const PairArrays& a, int32_t k0, int32_t k1, int32_t k2) {
  if constexpr (Model::has_history) {
    std::fill(a.hist + k0, a.hist + k1, Vec3f{});
    if constexpr (Prefetch) {
      const char* h1 = reinterpret_cast<const char*>(a.hist + k1);
      const char* h2 = reinterpret_cast<const char*>(a.hist + k2);
      for (const char* c = h1; c < h2; c += 64) __builtin_prefetch(c, 1);
    }
  }
}

// 3. Forces, torques and history back to the particles and the list; the largest overlap and, with
// Stress, the stress contributions (branch r_ij/2 per Eq. 8) on the way.
template <class Model, bool Stress, Same S>
MLCG_INLINE void scatter_block(const PairArrays& a, int32_t nc, const ContactBlock& b, double* stress6,
                               double& worst, int32_t& worst_i) {
  Vec3* __restrict f = a.f;
  Vec3* __restrict t = a.t;
  for (int32_t q = 0; q < nc; ++q) {
    const auto c = static_cast<size_t>(q);
    const auto i = static_cast<size_t>(b.i[c]);
    const auto j = static_cast<size_t>(b.j[c]);
    const Vec3 force{b.f.x[c], b.f.y[c], b.f.z[c]};
    const Vec3 tor{b.t.x[c], b.t.y[c], b.t.z[c]};
    const double ri = S == Same::Size ? a.one.radius : b.ri[c], rj = S == Same::Size ? a.one.radius : b.rj[c];
    f[i] += force;
    f[j] -= force;
    t[i] -= ri * tor;
    t[j] -= rj * tor;
    if constexpr (Model::has_rolling) {
      const Vec3 roll{b.m.x[c], b.m.y[c], b.m.z[c]};
      t[i] += roll;
      t[j] -= roll;
    }
    if constexpr (Model::has_history) a.hist[b.k[c]] = Vec3f({b.h.x[c], b.h.y[c], b.h.z[c]});
    const double rmin = std::min(ri, rj);
    if (b.delta[c] > worst * rmin) {  // divide only for a new largest overlap
      worst = b.delta[c] / rmin;
      worst_i = static_cast<int32_t>(i);
    }
    if constexpr (Stress) {
      const Vec3 half{0.5 * b.d.x[c], 0.5 * b.d.y[c], 0.5 * b.d.z[c]};
      add_dyad(stress6 + 6 * i, half, force);
      add_dyad(stress6 + 6 * j, half, force);  // (-d/2) x (-F)
    }
  }
}

// The list in blocks of kBlockPairs listed pairs (a particle's pairs may span two blocks): find, gather,
// law, scatter. Prefetch and Uniform are chosen once per call, so the block loops test neither.
// Returns the number of contacts.
template <class Model, bool Stress, bool Prefetch, Same S>
int64_t run_blocks(const PairArrays& a, int32_t pairs, const PairCoeffs* coeffs, double dt, double* stress6,
                   double& worst, int32_t& worst_i) {
  ContactBlock& b = scratch_contacts();
  int64_t contacts = 0;
  size_t i = 0;
  for (int32_t k0 = 0; k0 < pairs; k0 += kBlockPairs) {
    const int32_t k1 = std::min(pairs, k0 + kBlockPairs), k2 = std::min(pairs, k1 + kBlockPairs);
    const int32_t nc = find_touching<Prefetch, S>(a, i, k0, k1, b);
    gather_touching<Model, S>(a, nc, b);
    reset_history<Model, Prefetch>(a, k0, k1, k2);
    block_contact_forces<Model, S>(b, nc, coeffs, a.one, dt);  // 2. the contact law, vectorized
    scatter_block<Model, Stress, S>(a, nc, b, stress6, worst, worst_i);
    contacts += nc;
  }
  return contacts;
}

}  // namespace pair_detail

// stress6: 6 values per particle (only read when Stress).
namespace pair_detail {
template <class Model, bool Stress, bool Prefetch>
auto run_for(Same s) {
  return s == Same::Size       ? &run_blocks<Model, Stress, Prefetch, Same::Size>
         : s == Same::Material ? &run_blocks<Model, Stress, Prefetch, Same::Material>
                               : &run_blocks<Model, Stress, Prefetch, Same::Nothing>;
}
}  // namespace pair_detail

// stress6: 6 values per particle (only read when Stress).
template <class Model, bool Stress>
void pair_forces(Particles& p, NeighborList& nl, const MaterialTable& mt, double dt, double* stress6,
                 ContactStats& st) {
  const size_t n = p.n_local();
  const int nmat = mt.size();
  // One material among the particles (walls may have others): its coefficients are a loop invariant.
  const int32_t single = nl.single_material();
  const PairCoeffs* coeffs = mt.pairs().data() + (single >= 0 ? single * nmat + single : 0);
  const OneSize size = nl.single_size();
  const Same same = !(nmat == 1 || single >= 0) ? Same::Nothing : size.radius > 0.0 ? Same::Size : Same::Material;
  const PairArrays a{p.x.data(),      p.v.data(),       p.omega.data(), p.radius.data(),
                     p.mass.data(),   p.material.data(), p.f.data(),    p.torque.data(),
                     nl.first.data(), nl.neigh.data(),  Model::has_history ? nl.hist.data() : nullptr,
                     nmat,            same,             size,
                     p.size() > kPrefetchAbove,         std::max(0, nl.first[n] - 1)};
  double worst = st.max_overlap_ratio;
  int32_t worst_i = st.worst_particle;
  using pair_detail::run_for;
  const auto run = a.prefetch ? run_for<Model, Stress, true>(same) : run_for<Model, Stress, false>(same);
  const int64_t contacts = run(a, nl.first[n], coeffs, dt, stress6, worst, worst_i);
  st.max_overlap_ratio = worst;
  st.worst_particle = worst_i;
  st.pair_contacts += contacts;
  st.pair_kernel = static_cast<int>(same);
}

}  // namespace mlcg
