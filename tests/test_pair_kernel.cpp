// The pair kernel's variants give the same forces: a list whose particles share one material, radius and
// mass runs with them as loop invariants (Same::Size) and must give the general kernels' forces, torques,
// tangential history, stress dyads and largest overlap to the last bit, for each contact model, with and
// without stress, with and without prefetching. And the list knows when it is of one size: one ghost or one
// appended particle of another radius or mass takes that away.
#include <gtest/gtest.h>

#include <cstring>
#include <random>

#include "contact/model.hpp"
#include "forces/pair_kernel.hpp"
#include "neighbor/neighbor_list.hpp"

namespace {

using namespace mlcg;

constexpr double kRadius = 1e-3;

// A dense random pack of one size with random velocities, spins and stored tangential overlaps.
Particles one_size_pack(size_t n, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 0.022), uv(-0.5, 0.5);
  Particles p;
  for (size_t i = 0; i < n; ++i) {
    ParticleInit pi;
    pi.id = static_cast<int64_t>(i);
    pi.radius = kRadius;
    pi.density = 2500.0;
    pi.x = {u(rng), u(rng), u(rng)};
    pi.v = {uv(rng), uv(rng), uv(rng)};
    pi.omega = {100.0 * uv(rng), 100.0 * uv(rng), 100.0 * uv(rng)};
    p.add(pi);
  }
  return p;
}

struct Result {
  std::vector<Vec3> f, t;
  std::vector<Vec3f> hist;
  std::vector<double> stress6;
  int64_t contacts = 0;
  double worst = 0.0;
  int32_t worst_i = -1;
};

template <class Model, bool Stress, bool Prefetch, Same S>
Result run_variant(Particles p, NeighborList nl, const MaterialTable& mt) {
  Result r;
  r.stress6.assign(6 * p.size(), 0.0);
  const size_t n = p.n_local();
  const PairArrays a{p.x.data(),      p.v.data(),       p.omega.data(), p.radius.data(),
                                  p.mass.data(),   p.material.data(), p.f.data(),    p.torque.data(),
                                  nl.first.data(), nl.neigh.data(),  Model::has_history ? nl.hist.data() : nullptr,
                                  mt.size(),       S,                nl.single_size(),
                                  Prefetch,        std::max(0, nl.first[n] - 1)};
  r.contacts = pair_detail::run_blocks<Model, Stress, Prefetch, S>(a, nl.first[n], mt.pairs().data(), 1e-6,
                                                                   r.stress6.data(), r.worst, r.worst_i);
  r.f = p.f;
  r.t = p.torque;
  r.hist = nl.hist;
  return r;
}

template <class T>
bool same_bits(const std::vector<T>& a, const std::vector<T>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0;
}

void expect_same(const Result& one, const Result& general, const std::string& what) {
  EXPECT_GT(one.contacts, 3000) << what;
  EXPECT_EQ(one.contacts, general.contacts) << what;
  EXPECT_TRUE(same_bits(one.f, general.f)) << what << ": forces";
  EXPECT_TRUE(same_bits(one.t, general.t)) << what << ": torques";
  EXPECT_TRUE(same_bits(one.hist, general.hist)) << what << ": history";
  EXPECT_TRUE(same_bits(one.stress6, general.stress6)) << what << ": stress";
  EXPECT_EQ(std::memcmp(&one.worst, &general.worst, sizeof(double)), 0) << what << ": largest overlap";
  EXPECT_EQ(one.worst_i, general.worst_i) << what;
}

template <class Model, bool Stress, bool Prefetch>
void check_model(const std::string& name) {
  MaterialTable mt({Material{"glass", 2.5e7, 0.25, 2500.0}});
  mt.set_interaction(0, 0, {0.5, 0.5, 0.1});
  const Particles p = one_size_pack(2000, 5);
  NeighborList nl;
  nl.set_skin(0.2e-3);
  nl.build(p, Model::has_history);
  ASSERT_EQ(nl.single_size().radius, kRadius);
  std::mt19937_64 rng(6);
  std::uniform_real_distribution<float> uh(-2e-5f, 2e-5f);
  for (auto& h : nl.hist) h = Vec3f({uh(rng), uh(rng), uh(rng)});  // some pairs slide, some stick
  const std::string what = name + (Stress ? ", stress" : "") + (Prefetch ? ", prefetch" : "");
  const Result one = run_variant<Model, Stress, Prefetch, Same::Size>(p, nl, mt);
  expect_same(one, run_variant<Model, Stress, Prefetch, Same::Material>(p, nl, mt), what + " against one material");
  expect_same(one, run_variant<Model, Stress, Prefetch, Same::Nothing>(p, nl, mt), what + " against mixed");
}

TEST(PairKernel, AListOfOneSizeGivesTheGeneralKernelsResultsBitForBit) {
  using Hist = ContactModel<HertzNormal<false>, TangentialHistory, NoRolling>;
  using Roll = ContactModel<HertzNormal<false>, TangentialHistory, RollingCDT>;
  using Clamped = ContactModel<HertzNormal<true>, NoTangential, NoRolling>;
  check_model<Hist, false, false>("history");
  check_model<Hist, true, false>("history");
  check_model<Hist, false, true>("history");
  check_model<Roll, true, false>("rolling");
  check_model<Clamped, false, false>("clamped, no tangential");
}

TEST(PairKernel, OneGhostOrAppendedParticleOfAnotherSizeOrMassMakesTheListMixed) {
  Particles p = one_size_pack(200, 7);
  NeighborList nl;
  nl.set_skin(0.2e-3);
  nl.build(p, false);
  ASSERT_EQ(nl.single_size().radius, kRadius);
  EXPECT_EQ(nl.single_size().mass, p.mass[0]);
  p.add_ghost({0.01, 0.01, 0.01}, {}, {}, kRadius, p.mass[0], 9999, 0);
  nl.build(p, false);
  EXPECT_EQ(nl.single_size().radius, kRadius);  // a ghost of the same size keeps it
  p.add_ghost({0.011, 0.01, 0.01}, {}, {}, kRadius, 1.01 * p.mass[0], 10000, 0);
  nl.build(p, false);
  EXPECT_LT(nl.single_size().radius, 0.0);  // same radius, another mass
  p.drop_ghosts();
  nl.build(p, false);
  ASSERT_EQ(nl.single_size().radius, kRadius);
  ParticleInit pi;
  pi.id = 20000;
  pi.radius = 0.9 * kRadius;
  pi.density = 2500.0;
  pi.x = {0.03, 0.03, 0.03};
  p.add(pi);
  nl.append(p, p.size() - 1, false);
  EXPECT_LT(nl.single_size().radius, 0.0);
}

}  // namespace
