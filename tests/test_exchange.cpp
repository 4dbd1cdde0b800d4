// The byte records particles travel in between ranks (migration, checkpoint gathering): a particle
// and its contact lists survive the round trip, and a short buffer is refused.
#include <gtest/gtest.h>

#include <stdexcept>
#include <thread>

#include "parallel/exchange.hpp"

using namespace mlcg;

namespace {
Particles one_particle() {
  Particles p;
  ParticleInit pi;
  pi.id = 42;
  pi.material = 1;
  pi.radius = 0.002;
  pi.density = 2500.0;
  pi.x = {0.1, 0.2, 0.3};
  pi.v = {1.0, -2.0, 0.5};
  p.add(pi);
  return p;
}
}  // namespace

// A particle without contacts is the common case. In a fresh thread the reader's reusable buffers are
// still empty, so their data() is null: copying 0 bytes there must not reach memcpy (undefined
// behaviour that UBSan reported in the 2-rank tests; scripts/sanitize.sh).
TEST(Exchange, ParticleWithoutContactsRoundTripsInAFreshThread) {
  const Particles src = one_particle();
  ContactHistory pair, wall;
  pair.clear(1);
  wall.clear(1);
  std::vector<char> bytes;
  ByteWriter w(bytes);
  pack_particle(w, src, 0, pair, wall);

  Particles dst;
  ContactHistory pair_in, wall_in;
  std::thread([&] {
    ByteReader r(bytes);
    unpack_particle(r, dst, pair_in, wall_in);
    EXPECT_TRUE(r.done());
  }).join();
  ASSERT_EQ(dst.size(), 1u);
  EXPECT_EQ(dst.id[0], 42);
  EXPECT_EQ(dst.material[0], 1);
  EXPECT_EQ(dst.mass[0], src.mass[0]);
  EXPECT_EQ(dst.v[0].y, -2.0);
  EXPECT_EQ(pair_in.first, (std::vector<int32_t>{0, 0}));
  EXPECT_EQ(wall_in.first, (std::vector<int32_t>{0, 0}));
}

TEST(Exchange, ContactListsRoundTripAndAShortBufferIsRefused) {
  const Particles src = one_particle();
  ContactHistory pair, wall;
  pair.clear(0);
  pair.append(std::vector<int64_t>{7, 9}.data(), std::vector<Vec3>{{1e-6, 0, 0}, {0, 2e-6, 0}}.data(), 2);
  wall.clear(0);
  wall.append(std::vector<int64_t>{-3}.data(), std::vector<Vec3>{{0, 0, 3e-6}}.data(), 1);
  std::vector<char> bytes;
  ByteWriter w(bytes);
  pack_particle(w, src, 0, pair, wall);

  Particles dst;
  ContactHistory pair_in, wall_in;
  ByteReader r(bytes);
  unpack_particle(r, dst, pair_in, wall_in);
  EXPECT_EQ(pair_in.key, (std::vector<int64_t>{7, 9}));
  EXPECT_EQ(pair_in.find(0, 9).y, 2e-6);
  EXPECT_EQ(wall_in.find(0, -3).z, 3e-6);

  Particles cut;
  ContactHistory pair_cut, wall_cut;
  ByteReader short_reader(bytes.data(), bytes.size() - 1);
  EXPECT_THROW(unpack_particle(short_reader, cut, pair_cut, wall_cut), std::runtime_error);
}
