#include "coupling/grid_link.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>
#include <type_traits>

namespace mlcg::coupling {

const char* to_string(Role r) { return r == Role::Coarse ? "coarse" : "fine"; }

GridLink::GridLink(uint32_t index, const bus::CouplingGrid& grid, Role role)
    : index_(index), role_(role), geo_(grid), top_(geo_.top()), lo_(geo_.box_lo()), hi_(geo_.box_hi()), flux_(geo_),
      cells_(geo_), forces_(geo_), returned_(geo_.faces(), 0.0) {
  if (role == Role::Coarse && grid.radius_bins_size() < 2)
    throw std::invalid_argument("grid " + std::to_string(index) + ": radius_bins has " +
                                std::to_string(grid.radius_bins_size()) +
                                " edges; the coarse level needs at least 2 (one bin) for the face size histograms");
}

std::vector<ParticleInit> GridLink::parse_inserts(const bus::GridCommands& c, int material, double density,
                                                  int64_t first_id) {
  const auto& a = c.insert();
  if (a.size() % 7 != 0)
    throw std::invalid_argument("grid " + std::to_string(c.grid()) + ": insert has " + std::to_string(a.size()) +
                                " values, not a multiple of 7 (x y z r vx vy vz per particle)");
  std::vector<ParticleInit> out;
  out.reserve(static_cast<size_t>(a.size() / 7));
  for (int k = 0; k < a.size(); k += 7) {
    for (int j = 0; j < 7; ++j)
      if (!std::isfinite(a[k + j]))
        throw std::invalid_argument("grid " + std::to_string(c.grid()) + ": insert particle " + std::to_string(k / 7) +
                                    " has a non-finite value");
    if (!(a[k + 3] > 0.0))
      throw std::invalid_argument("grid " + std::to_string(c.grid()) + ": insert particle " + std::to_string(k / 7) +
                                  " has radius " + std::to_string(a[k + 3]));
    ParticleInit pi;
    pi.id = first_id + k / 7;
    pi.material = material;
    pi.density = density;
    pi.x = {a[k], a[k + 1], a[k + 2]};
    pi.radius = a[k + 3];
    pi.v = {a[k + 4], a[k + 5], a[k + 6]};
    out.push_back(pi);
  }
  return out;
}

void GridLink::refresh(const Particles& p, double band, size_t from) {
  if (role_ == Role::Coarse) flux_.refresh(p, band, from);
  else forces_.refresh(p, band, from);
  if (from == 0) in_box_.clear();
  for (size_t i = from; i < p.n_local(); ++i)
    if (bus::near_box(p.x[i], lo_, hi_, band)) in_box_.push_back(static_cast<uint32_t>(i));
  in_box_valid_ = true;
}

void GridLink::count_removed(const Vec3& x, double mass) {
  removed_ += 1.0;
  removed_mass_ += mass;
  const int f = geo_.exit_face(x);
  if (f >= 0) returned_[static_cast<size_t>(f)] += mass;
}

void GridLink::begin_interval(const bus::GridCommands* c, const Particles& p, const Comm& comm, uint64_t inserted,
                              double inserted_mass) {
  const std::string where = "grid " + std::to_string(index_) + " (" + to_string(role_) + " level): ";
  try {
    if (role_ == Role::Fine) {
      forces_.set_traction(c ? std::vector<double>(c->traction().begin(), c->traction().end()) : std::vector<double>{},
                           c ? std::vector<double>(c->speed_limit().begin(), c->speed_limit().end())
                             : std::vector<double>{});
      forces_.normalise(p, comm);
    } else {
      forces_.set_acceleration(c ? std::vector<double>(c->acceleration().begin(), c->acceleration().end())
                                 : std::vector<double>{});
    }
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(where + e.what());
  }
  want_occupants_ = c == nullptr || c->want_occupants();
  occupant_faces_.clear();
  if (c)
    for (const uint32_t f : c->occupant_faces()) {
      if (f >= geo_.faces())
        throw std::invalid_argument("occupant_faces names face " + std::to_string(f) + " of " +
                                    std::to_string(geo_.faces()));
      occupant_faces_.push_back(f);
    }
  inserted_ = inserted;
  inserted_mass_ = inserted_mass;
}

std::vector<double> GridLink::pending() const {
  std::vector<double> v;
  for (const auto* s : flux_.double_sums()) v.insert(v.end(), s->begin(), s->end());
  for (const int64_t h : flux_.histogram) v.push_back(static_cast<double>(h));  // counts far below 2^53
  v.push_back(removed_);
  v.push_back(removed_mass_);
  v.insert(v.end(), returned_.begin(), returned_.end());
  return v;
}

double GridLink::pending_mass() const {
  double m = removed_mass_;
  for (const double f : flux_.mass) m += std::abs(f);
  return m;
}

void GridLink::set_pending(const std::vector<double>& v) {
  const size_t want = pending_size();
  if (v.size() != want)
    throw std::invalid_argument("grid " + std::to_string(index_) + ": " + std::to_string(v.size()) +
                                " pending sums, the grid has " + std::to_string(want));
  auto at = v.begin();
  const auto take = [&](auto& out) {
    for (auto& x : out) x = static_cast<std::remove_reference_t<decltype(x)>>(*at++);
  };
  for (auto* s : flux_.double_sums()) take(*s);
  take(flux_.histogram);
  removed_ = *at++;
  removed_mass_ = *at++;
  returned_.assign(at, v.end());
}

bus::GridStats GridLink::finish(const Particles& p, const Comm& comm, double r_max, double ahead) {
  bus::GridStats g;
  g.set_grid(index_);
  if (role_ == Role::Coarse) {
    flux_.reduce(comm);
    g.mutable_face_mass()->Assign(flux_.mass.begin(), flux_.mass.end());
    g.mutable_face_momentum()->Assign(flux_.momentum.begin(), flux_.momentum.end());
    g.mutable_face_moment()->Assign(flux_.moment.begin(), flux_.moment.end());
    g.mutable_face_histogram()->Assign(flux_.histogram.begin(), flux_.histogram.end());
    g.mutable_face_gross_mass()->Assign(flux_.gross_mass.begin(), flux_.gross_mass.end());
    g.mutable_face_speed_mass()->Assign(flux_.speed_mass.begin(), flux_.speed_mass.end());
  }
  const CellMeans m = cells_.take();
  g.mutable_cell_stress()->Assign(m.stress.begin(), m.stress.end());
  g.mutable_cell_volume_fraction()->Assign(m.volume_fraction.begin(), m.volume_fraction.end());
  g.mutable_cell_velocity()->Assign(m.velocity.begin(), m.velocity.end());
  g.mutable_cell_max_speed()->Assign(m.max_speed.begin(), m.max_speed.end());
  if (role_ == Role::Fine && want_occupants_) {
    const std::vector<char> all = comm.gather0(occupants(p, r_max, ahead));
    g.mutable_occupants()->Resize(static_cast<int>(all.size() / sizeof(double)), 0.0);
    if (!all.empty()) std::memcpy(g.mutable_occupants()->mutable_data(), all.data(), all.size());
    g.set_occupants_sent(true);
    g.mutable_occupant_faces()->Assign(occupant_faces_.begin(), occupant_faces_.end());
  }
  {  // both roles: the mass in the region, independent of the crossing counts (a mass check)
    double m[2] = {0.0, 0.0};  // in the region; out of it and due for removal at the next rebuild
    // The coarse role removes nothing: only the particles of its box can count.
    const std::vector<uint32_t>* only = role_ == Role::Coarse ? box_list() : nullptr;
    const size_t n = only ? only->size() : p.n_local();
    for (size_t q = 0; q < n; ++q) {
      const size_t i = only ? (*only)[q] : q;
      if (geo_.locate(p.x[i]) >= 0) m[0] += p.mass[i];
      else if (leaves(p.x[i])) m[1] += p.mass[i];
    }
    comm.sum_in_place(m, 2);
    g.set_mass_in_region(m[0]);
    g.set_mass_leaving(m[1]);
  }
  if (role_ == Role::Fine) {
    returned_.resize(geo_.faces(), 0.0);
    comm.sum_in_place(returned_.data(), returned_.size());
    g.mutable_face_returned_mass()->Assign(returned_.begin(), returned_.end());
    double removed[2] = {removed_, removed_mass_};
    comm.sum_in_place(removed, 2);
    g.set_inserted(inserted_);
    g.set_inserted_mass(inserted_mass_);
    g.set_removed(static_cast<uint64_t>(std::llround(removed[0])));
    g.set_removed_mass(removed[1]);
  }
  flux_.reset();
  removed_ = removed_mass_ = 0.0;
  returned_.assign(geo_.faces(), 0.0);
  return g;
}

std::vector<char> GridLink::occupants(const Particles& p, double r_max, double ahead) const {
  // Centres within r_max of the slabs inside the boundary surface, where their velocity takes them by the
  // insertion (x y z r each).
  const double depth = geo_.grid().insert_depth(), zlo = top_ - depth - r_max, zhi = top_ + r_max;
  const auto near_open_side = [&](const Vec3& x) {
    if (x.z < lo_.z - r_max || x.z > zhi || x.x < lo_.x - r_max || x.x > hi_.x + r_max || x.y < lo_.y - r_max ||
        x.y > hi_.y + r_max)
      return false;
    for (const bus::Side s : geo_.open_sides()) {
      const double d = geo_.depth_inside(s, x);
      if (d >= -r_max && d <= depth + r_max) return true;
    }
    return false;
  };
  // Only some faces' slabs: a candidate centre lies in its face's slab, its sphere reaches r_max beyond it, so
  // an occupant it may touch lies within 2 r_max of that slab.
  std::vector<Vec3> box_lo, box_hi;
  Vec3 all_lo{1e300, 1e300, 1e300}, all_hi{-1e300, -1e300, -1e300};  // around every asked slab: most fail it
  for (const uint32_t f : occupant_faces_) {
    Vec3 a, b;
    geo_.face_slab(f, depth, a, b);
    box_lo.push_back(a);
    box_hi.push_back(b);
    for (int k = 0; k < 3; ++k) {
      all_lo[k] = std::min(all_lo[k], a[k]);
      all_hi[k] = std::max(all_hi[k], b[k]);
    }
  }
  const auto near_a_slab = [&](const Vec3& x) {
    if (!bus::near_box(x, all_lo, all_hi, 2.0 * r_max)) return false;
    for (size_t b = 0; b < box_lo.size(); ++b)
      if (bus::near_box(x, box_lo[b], box_hi[b], 2.0 * r_max)) return true;
    return false;
  };
  std::vector<char> buf;
  ByteWriter w(buf);
  const bool some = !occupant_faces_.empty();
  for (size_t i = 0; i < p.n_local(); ++i) {
    const Vec3 x = ahead > 0.0 ? p.x[i] + p.v[i] * ahead : p.x[i];
    if (some) {
      if (!near_a_slab(x)) continue;
    } else {
      const bool below_top = !(x.z < zlo || x.z > zhi || x.x < lo_.x || x.x > hi_.x || x.y < lo_.y || x.y > hi_.y);
      if (!below_top && !(!geo_.open_sides().empty() && near_open_side(x))) continue;
    }
    const double q[4] = {x.x, x.y, x.z, p.radius[i]};
    w.put_n(q, 4);
  }
  return buf;
}

std::vector<GridLink> links_of(const bus::Welcome& w) {
  std::vector<GridLink> out;
  for (int g = 0; g < w.grids_size(); ++g) {
    const auto& grid = w.grids(g);
    const bool coarse = grid.coarse_level() == w.level_index(), fine = grid.fine_level() == w.level_index();
    if (coarse || fine) out.emplace_back(static_cast<uint32_t>(g), grid, coarse ? Role::Coarse : Role::Fine);
  }
  return out;
}

std::vector<const bus::GridCommands*> commands_of(const bus::IntervalCommands& c, const std::vector<GridLink>& links,
                                                  const std::string& level) {
  std::vector<const bus::GridCommands*> of(links.size(), nullptr);
  for (const auto& g : c.grids()) {
    const auto it = std::find_if(links.begin(), links.end(), [&](const GridLink& l) { return l.index() == g.grid(); });
    if (it == links.end())
      throw std::invalid_argument("the coupler sent commands for grid " + std::to_string(g.grid()) +
                                  ", in which level '" + level + "' takes no part");
    of[static_cast<size_t>(it - links.begin())] = &g;
  }
  return of;
}

}  // namespace mlcg::coupling
