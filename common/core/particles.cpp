#include "core/particles.hpp"

#include <stdexcept>

#include "core/spheres.hpp"

namespace mlcg {

void Particles::add(const ParticleInit& p) {
  if (x.size() != n_local_) throw std::logic_error("Particles::add with ghosts present: drop them first");
  const double m = sphere_mass(p.density, p.radius);
  x.push_back(p.x);
  v.push_back(p.v);
  f.push_back({});
  omega.push_back(p.omega);
  torque.push_back({});
  radius.push_back(p.radius);
  mass.push_back(m);
  inv_mass.push_back(1.0 / m);
  inv_inertia.push_back(1.0 / (0.4 * m * p.radius * p.radius));
  id.push_back(p.id);
  material.push_back(p.material);
  n_local_ = x.size();
}

void Particles::add_ghost(const Vec3& xg, const Vec3& vg, const Vec3& wg, double r, double m, int64_t idg,
                          int32_t mat) {
  x.push_back(xg);
  v.push_back(vg);
  f.push_back({});
  omega.push_back(wg);
  torque.push_back({});
  radius.push_back(r);
  mass.push_back(m);
  inv_mass.push_back(1.0 / m);
  inv_inertia.push_back(1.0 / (0.4 * m * r * r));
  id.push_back(idg);
  material.push_back(mat);
}

void Particles::drop_ghosts() {
  const size_t n = n_local_;
  x.resize(n); v.resize(n); f.resize(n); omega.resize(n); torque.resize(n);
  radius.resize(n); mass.resize(n); inv_mass.resize(n); inv_inertia.resize(n);
  id.resize(n); material.resize(n);
}

namespace {
template <class T>
void apply(std::vector<T>& a, const std::vector<int32_t>& new_to_old) {
  std::vector<T> out(new_to_old.size());
  for (size_t k = 0; k < new_to_old.size(); ++k) out[k] = a[static_cast<size_t>(new_to_old[k])];
  a.swap(out);
}
}  // namespace

void Particles::permute(const std::vector<int32_t>& n2o) {
  apply(x, n2o); apply(v, n2o); apply(f, n2o); apply(omega, n2o); apply(torque, n2o);
  apply(radius, n2o); apply(mass, n2o); apply(inv_mass, n2o); apply(inv_inertia, n2o);
  apply(id, n2o); apply(material, n2o);
  n_local_ = x.size();
}

void Particles::clear_forces() {
  for (auto& a : f) a = {};
  for (auto& a : torque) a = {};
}

void Particles::reserve(size_t n) {
  x.reserve(n); v.reserve(n); f.reserve(n); omega.reserve(n); torque.reserve(n);
  radius.reserve(n); mass.reserve(n); inv_mass.reserve(n); inv_inertia.reserve(n);
  id.reserve(n); material.reserve(n);
}

void ContactHistory::permute(const std::vector<int32_t>& n2o, size_t n_new_total) {
  ContactHistory out;
  out.first.assign(n_new_total + 1, 0);
  for (size_t k = 0; k < n2o.size(); ++k) {
    const auto o = static_cast<size_t>(n2o[k]);
    for (int32_t s = first[o]; s < first[o + 1]; ++s) {
      out.key.push_back(key[static_cast<size_t>(s)]);
      out.value.push_back(value[static_cast<size_t>(s)]);
    }
    out.first[k + 1] = static_cast<int32_t>(out.key.size());
  }
  for (size_t k = n2o.size(); k < n_new_total; ++k) out.first[k + 1] = out.first[k];
  *this = std::move(out);
}

}  // namespace mlcg
