#include "stats/series_stats.hpp"

#include <cmath>
#include <stdexcept>

#include <fmt/format.h>

namespace mlcg::stats {
namespace {

constexpr double kPi = 3.14159265358979323846;

// Means of the last B = n / b batches of b samples.
std::vector<double> batch_means(const std::vector<double>& x, size_t b) {
  const size_t nb = x.size() / b;
  const size_t skip = x.size() - nb * b;
  std::vector<double> m(nb, 0.0);
  for (size_t i = 0; i < nb; ++i) {
    double s = 0.0;
    for (size_t k = 0; k < b; ++k) s += x[skip + i * b + k];
    m[i] = s / static_cast<double>(b);
  }
  return m;
}

double sample_variance(const std::vector<double>& x) {
  if (x.size() < 2) return 0.0;
  double mean = 0.0;
  for (double v : x) mean += v;
  mean /= static_cast<double>(x.size());
  double ss = 0.0;
  for (double v : x) ss += (v - mean) * (v - mean);
  return ss / static_cast<double>(x.size() - 1);
}

// P(|T| <= t) with theta = atan(t / sqrt(dof)), A&S 26.7.3 (odd dof) and 26.7.4 (even dof).
double two_sided_probability(double theta, long dof) {
  const double s = std::sin(theta), c = std::cos(theta), c2 = c * c;
  if (dof % 2 == 1) {
    double sum = 0.0;
    if (dof > 1) {
      double term = c;  // c, (2/3) c^3, (2*4)/(3*5) c^5, ... up to c^(dof-2)
      sum = term;
      for (long j = 3; j <= dof - 2; j += 2) {
        term *= c2 * static_cast<double>(j - 1) / static_cast<double>(j);
        sum += term;
      }
    }
    return 2.0 / kPi * (theta + s * sum);
  }
  double term = 1.0, sum = 1.0;  // 1, (1/2) c^2, (1*3)/(2*4) c^4, ... up to c^(dof-2)
  for (long j = 2; j <= dof - 2; j += 2) {
    term *= c2 * static_cast<double>(j - 1) / static_cast<double>(j);
    sum += term;
  }
  return s * sum;
}

// Standard normal quantile by bisection on erfc (monotone, exact to rounding).
double normal_quantile(double p) {
  double lo = -40.0, hi = 40.0;
  for (int i = 0; i < 200 && hi - lo > 1e-15; ++i) {
    const double mid = 0.5 * (lo + hi);
    (0.5 * std::erfc(-mid / std::sqrt(2.0)) < p ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

// A&S 26.7.5: t = x + g1/v + g2/v^2 + g3/v^3 + g4/v^4 with x the normal quantile.
double cornish_fisher(double p, double v) {
  const double x = normal_quantile(p), x2 = x * x;
  const double g1 = (x2 + 1.0) * x / 4.0;
  const double g2 = ((5.0 * x2 + 16.0) * x2 + 3.0) * x / 96.0;
  const double g3 = (((3.0 * x2 + 19.0) * x2 + 17.0) * x2 - 15.0) * x / 384.0;
  const double g4 = ((((79.0 * x2 + 776.0) * x2 + 1482.0) * x2 - 1920.0) * x2 - 945.0) * x / 92160.0;
  return x + g1 / v + g2 / (v * v) + g3 / (v * v * v) + g4 / (v * v * v * v);
}

}  // namespace

double lag1_autocorrelation(const std::vector<double>& x) {
  if (x.size() < 2) return 0.0;
  double mean = 0.0;
  for (double v : x) mean += v;
  mean /= static_cast<double>(x.size());
  double num = 0.0, den = 0.0;
  for (size_t i = 0; i < x.size(); ++i) {
    den += (x[i] - mean) * (x[i] - mean);
    if (i + 1 < x.size()) num += (x[i] - mean) * (x[i + 1] - mean);
  }
  return den > 0.0 ? num / den : 0.0;
}

double student_t_quantile(double p, long dof) {
  if (!(p > 0.0 && p < 1.0)) throw std::invalid_argument(fmt::format("t quantile: p = {} is not in (0, 1)", p));
  if (dof < 1) throw std::invalid_argument(fmt::format("t quantile: {} degrees of freedom; need >= 1", dof));
  if (p < 0.5) return -student_t_quantile(1.0 - p, dof);
  if (p == 0.5) return 0.0;
  if (dof > 1000) return cornish_fisher(p, static_cast<double>(dof));
  // P(|T| <= t) = 2p - 1 is monotone in theta on [0, pi/2).
  const double target = 2.0 * p - 1.0;
  double lo = 0.0, hi = 0.5 * kPi;
  for (int i = 0; i < 200 && hi - lo > 1e-16; ++i) {
    const double mid = 0.5 * (lo + hi);
    (two_sided_probability(mid, dof) < target ? lo : hi) = mid;
  }
  return std::sqrt(static_cast<double>(dof)) * std::tan(0.5 * (lo + hi));
}

std::string MeanCI::method() const {
  return fmt::format("batch means, {} batches of {} samples", batches, batch_size);
}

MeanCI batch_means_ci(const std::vector<double>& x) {
  MeanCI r;
  r.samples = x.size();
  if (x.empty()) return r;
  for (double v : x) r.mean += v;
  r.mean /= static_cast<double>(x.size());
  if (x.size() < 2) return r;
  size_t b = 1;
  std::vector<double> m = x;
  r.lag1 = lag1_autocorrelation(m);
  // Double the batch size while neighbouring batch means are still correlated.
  while (r.lag1 > kLag1Limit && x.size() / (2 * b) >= kMinBatches) {
    b *= 2;
    m = batch_means(x, b);
    r.lag1 = lag1_autocorrelation(m);
  }
  r.batch_size = b;
  r.batches = m.size();
  const double var_b = sample_variance(m);
  r.ci95 = student_t_quantile(0.975, static_cast<long>(r.batches) - 1) * std::sqrt(var_b / static_cast<double>(r.batches));
  const double var_x = sample_variance(x);
  r.tau = var_x > 0.0 ? static_cast<double>(b) * var_b / var_x : 1.0;
  r.effective_samples = r.tau > 0.0 ? static_cast<double>(r.samples) / r.tau : static_cast<double>(r.samples);
  return r;
}

}  // namespace mlcg::stats
