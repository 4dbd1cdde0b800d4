#include "measure/probe.hpp"

#include <cmath>
#include <sstream>

#include <fmt/format.h>

namespace mlcg {

void MassFlowProbe::refresh(const Particles& p, double band, size_t from) {
  const double lateral = prm_.radius + band;
  plane_.refresh(p, band, [&](const Vec3& x, double s) {
    return norm2(x - prm_.point - s * prm_.normal) <= lateral * lateral;
  }, from);
}

void MassFlowProbe::check(const Particles& p) {
  const double r2 = prm_.radius * prm_.radius;
  plane_.check(p, [&](size_t i, bool forward, double s, const Vec3&) {
    if (norm2(p.x[i] - prm_.point - s * prm_.normal) > r2) return;
    st_.mass += forward ? p.mass[i] : -p.mass[i];
  });
}

bool MassFlowProbe::sample_due(double t) const {
  // Within a small fraction of a step of the interval's end counts as reached.
  return t + 1e-12 * prm_.sample_interval >= st_.sample_start + prm_.sample_interval;
}

void MassFlowProbe::close_sample(double t, double global_mass) {
  const double span = t - st_.sample_start;
  st_.samples.push_back({t, span > 0.0 ? global_mass / span : 0.0});
  st_.total_mass += global_mass;
  st_.sample_start = t;
  st_.mass = 0.0;
}

MassFlowProbe::WindowStats MassFlowProbe::window_stats() const {
  WindowStats w;
  if (!prm_.window_known) return w;
  std::vector<double> rates;
  for (const auto& s : st_.samples) {
    const double t0 = s.t_end - prm_.sample_interval;
    if (t0 < prm_.window_start - 1e-9 || s.t_end > prm_.window_end + 1e-9) continue;
    rates.push_back(s.rate);
  }
  w.samples = rates.size();
  if (w.samples == 0) return w;
  double sum2 = 0.0;
  for (double r : rates) sum2 += r * r;
  w.ci = stats::batch_means_ci(rates);
  w.mean = w.ci.mean;
  const double var = sum2 / static_cast<double>(w.samples) - w.mean * w.mean;
  w.stddev = var > 0.0 ? std::sqrt(var) : 0.0;
  return w;
}

std::string MassFlowProbe::csv() const {
  std::string out = "t,mass_flow_kg_per_s\n";
  for (const auto& s : st_.samples) out += fmt::format("{:.6f},{:.9g}\n", s.t_end, s.rate);
  return out;
}

}  // namespace mlcg
