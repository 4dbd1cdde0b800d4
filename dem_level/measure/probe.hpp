#pragma once
// Mass-flow probe: a disk (centre, normal, radius). Mass crossing it in the
// normal's direction counts positive, against it negative; the net mass per
// sampling interval divided by the interval's length is one sample [kg/s].
//
// The crossings are counted by PlaneCrossings (a short candidate list near the
// plane, refreshed at every rebuild).
#include <cstdint>
#include <string>
#include <vector>

#include "core/particles.hpp"
#include "measure/plane_crossings.hpp"
#include "stats/series_stats.hpp"

namespace mlcg {

struct ProbeParams {
  std::string name;
  Vec3 point, normal;  // normal: unit
  double radius = 0.0;
  double sample_interval = 0.01;
  double window_start = 0.0, window_end = 0.0;  // absolute, once known
  bool window_known = true;                      // false until its event fired
};

class MassFlowProbe {
 public:
  struct Sample {
    double t_end;
    double rate;  // kg/s
  };
  struct State {  // everything a checkpoint needs
    double sample_start = 0.0;
    double mass = 0.0;             // this rank's part of the open sample
    std::vector<Sample> samples;   // closed samples (global)
    double total_mass = 0.0;       // net mass of the closed samples (global)
  };

  explicit MassFlowProbe(ProbeParams prm) : prm_(std::move(prm)), plane_(prm_.point, prm_.normal) {}

  // After a rebuild: remember which side of the plane each nearby particle is on.
  void refresh(const Particles& p, double band, size_t from = 0);  // from: see PlaneCrossings::refresh
  // After positions changed: count crossings of the candidates (this rank's particles).
  void check(const Particles& p);
  // At time t, is the open sample's interval over? (the same answer on every rank)
  bool sample_due(double t) const;
  // Mass counted by this rank in the open sample.
  double open_mass() const { return st_.mass; }
  // Closes the open sample with the mass summed over all ranks.
  void close_sample(double t, double global_mass);

  ProbeParams& params() { return prm_; }
  const ProbeParams& params() const { return prm_; }
  State& state() { return st_; }
  const State& state() const { return st_; }

  struct WindowStats {
    size_t samples = 0;
    double mean = 0.0, stddev = 0.0;
    stats::MeanCI ci;  // the mean's 95 % interval by batch means (the samples are autocorrelated)
  };
  WindowStats window_stats() const;
  std::string csv() const;

 private:
  ProbeParams prm_;
  State st_;
  PlaneCrossings plane_;
};

}  // namespace mlcg
