#include "parallel/exchange.hpp"

#include <algorithm>

namespace mlcg {

void pack_particle(ByteWriter& w, const Particles& p, size_t i, const ContactHistory& pair_hist,
                   const ContactHistory& wall_hist) {
  w.put(p.x[i]); w.put(p.v[i]); w.put(p.f[i]); w.put(p.omega[i]); w.put(p.torque[i]);
  w.put(p.radius[i]); w.put(p.mass[i]); w.put(p.inv_mass[i]); w.put(p.inv_inertia[i]);
  w.put(p.id[i]); w.put(p.material[i]);
  for (const ContactHistory* h : {&pair_hist, &wall_hist}) {
    const int32_t b = h->first[i], e = h->first[i + 1];
    w.put(e - b);
    w.put_n(h->key.data() + b, static_cast<size_t>(e - b));
    w.put_n(h->value.data() + b, static_cast<size_t>(e - b));
  }
}

void unpack_particle(ByteReader& r, Particles& p, ContactHistory& pair_hist, ContactHistory& wall_hist) {
  ParticleInit pi;
  pi.x = r.get<Vec3>();
  pi.v = r.get<Vec3>();
  const Vec3 f = r.get<Vec3>();
  pi.omega = r.get<Vec3>();
  const Vec3 t = r.get<Vec3>();
  pi.radius = r.get<double>();
  const double mass = r.get<double>(), inv_m = r.get<double>(), inv_i = r.get<double>();
  pi.id = r.get<int64_t>();
  pi.material = r.get<int32_t>();
  pi.density = 1.0;  // the sender's exact mass values are restored below
  p.add(pi);
  p.f.back() = f;
  p.torque.back() = t;
  p.mass.back() = mass;
  p.inv_mass.back() = inv_m;
  p.inv_inertia.back() = inv_i;
  static thread_local std::vector<int64_t> keys;
  static thread_local std::vector<Vec3> values;
  for (ContactHistory* h : {&pair_hist, &wall_hist}) {
    const auto c = static_cast<size_t>(r.get<int32_t>());
    keys.resize(c);
    values.resize(c);
    r.get_n(keys.data(), c);
    r.get_n(values.data(), c);
    h->append(keys.data(), values.data(), c);
  }
}

size_t migrate(const Comm& comm, const Decomposition& dec, Particles& p, ContactHistory& pair_hist,
               ContactHistory& wall_hist) {
  if (comm.serial()) return 0;
  const size_t n = p.n_local();
  const auto nr = static_cast<size_t>(comm.size());
  std::vector<std::vector<char>> out(nr);
  std::vector<int32_t> keep;
  keep.reserve(n);
  for (size_t i = 0; i < n; ++i) {
    const int o = dec.owner(p.x[i]);
    if (o == comm.rank()) {
      keep.push_back(static_cast<int32_t>(i));
      continue;
    }
    ByteWriter w(out[static_cast<size_t>(o)]);
    pack_particle(w, p, i, pair_hist, wall_hist);
  }
  const size_t left = n - keep.size();
  const auto in = comm.alltoall(out);
  if (left > 0) {
    p.permute(keep);
    pair_hist.permute(keep, keep.size());
    wall_hist.permute(keep, keep.size());
  }
  for (const auto& buf : in) {
    ByteReader r(buf);
    while (!r.done()) unpack_particle(r, p, pair_hist, wall_hist);
  }
  return left;
}

void GhostExchange::build(const Comm& comm, const Decomposition& dec, Particles& p, double cutoff) {
  peers_.clear();
  send_.clear();
  recv_first_.clear();
  recv_n_.clear();
  if (comm.serial()) return;
  const auto nr = static_cast<size_t>(comm.size());
  const int me = comm.rank();
  std::vector<std::vector<int32_t>> lists(nr);
  const Vec3 lo = dec.box_lo(me), hi = dec.box_hi(me);
  for (size_t i = 0; i < p.n_local(); ++i) {
    const Vec3& x = p.x[i];
    // Only particles near their own box's faces can be within reach of another box.
    if (x.x - lo.x > cutoff && hi.x - x.x > cutoff && x.y - lo.y > cutoff && hi.y - x.y > cutoff &&
        x.z - lo.z > cutoff && hi.z - x.z > cutoff)
      continue;
    for (int r = 0; r < comm.size(); ++r)
      if (r != me && dec.distance_to_box(r, x) < cutoff) lists[static_cast<size_t>(r)].push_back(static_cast<int32_t>(i));
  }
  std::vector<std::vector<char>> out(nr);
  for (size_t r = 0; r < nr; ++r) {
    ByteWriter w(out[r]);
    for (int32_t i : lists[r]) {
      const auto k = static_cast<size_t>(i);
      w.put(p.x[k]); w.put(p.v[k]); w.put(p.omega[k]);
      w.put(p.radius[k]); w.put(p.mass[k]); w.put(p.id[k]); w.put(p.material[k]);
    }
  }
  const auto in = comm.alltoall(out);
  // Room for every ghost at once: appending to exactly sized arrays would double them.
  size_t incoming = 0;
  for (const auto& buf : in) incoming += buf.size();
  constexpr size_t kGhostBytes = 3 * sizeof(Vec3) + 2 * sizeof(double) + sizeof(int64_t) + sizeof(int32_t);
  p.reserve(p.size() + incoming / kGhostBytes);
  for (size_t r = 0; r < nr; ++r) {
    const size_t first = p.size();
    ByteReader rd(in[r]);
    while (!rd.done()) {
      const Vec3 x = rd.get<Vec3>(), v = rd.get<Vec3>(), w = rd.get<Vec3>();
      const double radius = rd.get<double>(), mass = rd.get<double>();
      const auto id = rd.get<int64_t>();
      const auto mat = rd.get<int32_t>();
      p.add_ghost(x, v, w, radius, mass, id, mat);
    }
    if (!lists[r].empty() || p.size() > first) {
      peers_.push_back(static_cast<int>(r));
      send_.push_back(std::move(lists[r]));
      recv_first_.push_back(first);
      recv_n_.push_back(p.size() - first);
    }
  }
  sbuf_.resize(peers_.size());
  rbuf_.resize(peers_.size());
  for (size_t k = 0; k < peers_.size(); ++k) {
    sbuf_[k].resize(9 * send_[k].size());
    rbuf_[k].resize(9 * recv_n_[k]);
  }
}

void GhostExchange::forward(const Comm& comm, Particles& p) {
  if (peers_.empty()) return;
  for (size_t k = 0; k < peers_.size(); ++k) {
    double* b = sbuf_[k].data();
    for (int32_t i : send_[k]) {
      const auto q = static_cast<size_t>(i);
      const Vec3 &x = p.x[q], &v = p.v[q], &w = p.omega[q];
      b[0] = x.x; b[1] = x.y; b[2] = x.z;
      b[3] = v.x; b[4] = v.y; b[5] = v.z;
      b[6] = w.x; b[7] = w.y; b[8] = w.z;
      b += 9;
    }
  }
  comm.exchange(peers_, sbuf_, rbuf_);
  for (size_t k = 0; k < peers_.size(); ++k) {
    const double* b = rbuf_[k].data();
    for (size_t g = recv_first_[k]; g < recv_first_[k] + recv_n_[k]; ++g, b += 9) {
      p.x[g] = {b[0], b[1], b[2]};
      p.v[g] = {b[3], b[4], b[5]};
      p.omega[g] = {b[6], b[7], b[8]};
    }
  }
}

size_t GhostExchange::sent() const {
  size_t s = 0;
  for (const auto& l : send_) s += l.size();
  return s;
}

}  // namespace mlcg
