#pragma once
// Moving particles between ranks. At a neighbour-list rebuild, particles that
// left their rank's box migrate to the owner with everything the integrator
// and the contact history need; then every particle within the ghost cutoff
// (2 r_max + skin) of another rank's box is copied there as a ghost. Between
// rebuilds, forward() refreshes the ghosts' position, velocity and spin.
// Border pairs are computed on both sides (newton off): each rank keeps the
// force and the tangential history of its own particle.
#include <cstdint>
#include <vector>

#include "core/particles.hpp"
#include "parallel/comm.hpp"
#include "parallel/decomposition.hpp"

namespace mlcg {

// One particle with everything the integrator and its contact history need,
// as bytes (migration and checkpoint gathering use the same record).
void pack_particle(ByteWriter& w, const Particles& p, size_t i, const ContactHistory& pair_hist,
                   const ContactHistory& wall_hist);
// Appends the next record of r to p and the histories (no ghosts may be present).
void unpack_particle(ByteReader& r, Particles& p, ContactHistory& pair_hist, ContactHistory& wall_hist);

// Sends every local particle that another rank owns to it, with its pair and
// wall contact history; arrivals are appended. Needs no ghosts present.
// Returns the number of particles that left.
size_t migrate(const Comm& comm, const Decomposition& dec, Particles& p, ContactHistory& pair_hist,
               ContactHistory& wall_hist);

class GhostExchange {
 public:
  // Appends ghosts from every rank whose particles lie within cutoff of this rank's box.
  void build(const Comm& comm, const Decomposition& dec, Particles& p, double cutoff);
  // Refreshes the ghosts' x, v, omega from their owners (same particles as at build()).
  void forward(const Comm& comm, Particles& p);
  size_t sent() const;

 private:
  std::vector<int> peers_;                    // ranks exchanged with, ascending
  std::vector<std::vector<int32_t>> send_;    // per peer: local indices sent
  std::vector<size_t> recv_first_, recv_n_;   // per peer: first ghost index and count
  std::vector<std::vector<double>> sbuf_, rbuf_;
};

}  // namespace mlcg
