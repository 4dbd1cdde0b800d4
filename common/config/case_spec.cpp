#include "config/case_spec.hpp"

#include <algorithm>

namespace mlcg::config {

double RadiusSpec::largest() const {
  switch (kind) {
    case RadiusKind::Constant: return value;
    case RadiusKind::Uniform: return max;
    case RadiusKind::Discrete: return values.empty() ? 0.0 : *std::max_element(values.begin(), values.end());
  }
  return value;
}

double RadiusSpec::mean() const {
  switch (kind) {
    case RadiusKind::Constant: return value;
    case RadiusKind::Uniform: return 0.5 * (min + max);
    case RadiusKind::Discrete: {
      double m = 0.0;
      for (size_t i = 0; i < values.size(); ++i) m += values[i] * fractions[i];
      return m;
    }
  }
  return value;
}

double RadiusSpec::smallest() const {
  switch (kind) {
    case RadiusKind::Constant: return value;
    case RadiusKind::Uniform: return min;
    case RadiusKind::Discrete: return values.empty() ? 0.0 : *std::min_element(values.begin(), values.end());
  }
  return value;
}

double RadiusSpec::mean_volume_factor() const {
  switch (kind) {
    case RadiusKind::Constant: return value * value * value;
    case RadiusKind::Uniform: {  // E[r^3] for r ~ U(a, b)
      const double a = min, b = max;
      if (b <= a) return a * a * a;
      return (b * b * b * b - a * a * a * a) / (4.0 * (b - a));
    }
    case RadiusKind::Discrete: {
      double s = 0.0;
      for (size_t k = 0; k < values.size() && k < fractions.size(); ++k)
        s += fractions[k] * values[k] * values[k] * values[k];
      return s;
    }
  }
  return value * value * value;
}

}  // namespace mlcg::config
