// The batch-means confidence interval of a series' mean (stats/series_stats):
// coverage of the true mean over many synthetic series whose autocorrelation is
// known, against the naive s / sqrt(n) interval; the Student t quantile against
// printed tables; the batch rule on small hand-computed series.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "stats/series_stats.hpp"

namespace {

using mlcg::stats::batch_means_ci;
using mlcg::stats::student_t_quantile;

// Standard normal numbers from mt19937_64 (whose output the standard fixes) by Box-Muller, so the
// series are the same with every standard library.
class Normal {
 public:
  explicit Normal(uint64_t seed) : rng_(seed) {}
  double operator()() {
    if (have_spare_) {
      have_spare_ = false;
      return spare_;
    }
    const double u1 = uniform(), u2 = uniform();
    const double r = std::sqrt(-2.0 * std::log(u1)), a = 2.0 * M_PI * u2;
    spare_ = r * std::sin(a);
    have_spare_ = true;
    return r * std::cos(a);
  }

 private:
  double uniform() { return (static_cast<double>(rng_() >> 11) + 0.5) * 0x1.0p-53; }  // in (0, 1)
  std::mt19937_64 rng_;
  double spare_ = 0.0;
  bool have_spare_ = false;
};

// x_t = mu + phi (x_{t-1} - mu) + e_t, started from the stationary distribution.
std::vector<double> ar1(Normal& e, double phi, double mu, size_t n) {
  std::vector<double> x(n);
  double d = e() / std::sqrt(1.0 - phi * phi);
  for (size_t i = 0; i < n; ++i) {
    if (i > 0) d = phi * d + e();
    x[i] = mu + d;
  }
  return x;
}

struct Coverage {
  double batch = 0.0, naive = 0.0;  // share of series whose interval holds the true mean
  double tau = 0.0;                 // mean estimated integrated autocorrelation time
  size_t min_batches = SIZE_MAX;
};

Coverage coverage(double phi, double mu, size_t series, size_t n, uint64_t seed) {
  Normal e(seed);
  Coverage c;
  for (size_t s = 0; s < series; ++s) {
    const auto x = ar1(e, phi, mu, n);
    const auto r = batch_means_ci(x);
    double ss = 0.0;
    for (double v : x) ss += (v - r.mean) * (v - r.mean);
    const double naive = 1.96 * std::sqrt(ss / static_cast<double>(n - 1) / static_cast<double>(n));
    c.batch += std::abs(r.mean - mu) <= r.ci95;
    c.naive += std::abs(r.mean - mu) <= naive;
    c.tau += r.tau;
    c.min_batches = std::min(c.min_batches, r.batches);
  }
  c.batch /= static_cast<double>(series);
  c.naive /= static_cast<double>(series);
  c.tau /= static_cast<double>(series);
  return c;
}

// The point of the batch means: on an AR(1) series with phi = 0.9 (integrated autocorrelation time
// (1 + phi) / (1 - phi) = 19 samples) the interval still holds the true mean about 95 % of the time,
// where s / sqrt(n) misses it most of the time.
TEST(SeriesStats, Ar1CoverageOfTheTrueMeanIsNearNinetyFivePercentWhereTheNaiveIntervalFails) {
  const auto c = coverage(0.9, 3.0, 400, 2000, 20240611);
  std::printf("AR(1) phi 0.9, 400 x 2000 samples: batch means cover %.1f %%, s/sqrt(n) %.1f %%, tau %.1f "
              "(exact 19), at least %zu batches\n", 100.0 * c.batch, 100.0 * c.naive, c.tau, c.min_batches);
  EXPECT_GE(c.batch, 0.90);
  EXPECT_LE(c.batch, 0.99);
  EXPECT_LT(c.naive, 0.80);
  EXPECT_GE(c.min_batches, mlcg::stats::kMinBatches);
  // The autocorrelation time from the batches is close to the exact one (batches of finite size
  // see a little less of the correlation, so somewhat below).
  EXPECT_GT(c.tau, 14.0);
  EXPECT_LT(c.tau, 21.0);
}

TEST(SeriesStats, IndependentSamplesAreCoveredNinetyFivePercentWithTauNearOne) {
  const auto c = coverage(0.0, -1.5, 400, 2000, 77);
  std::printf("i.i.d., 400 x 2000 samples: batch means cover %.1f %%, s/sqrt(n) %.1f %%, tau %.2f\n",
              100.0 * c.batch, 100.0 * c.naive, c.tau);
  EXPECT_GE(c.batch, 0.92);
  EXPECT_LE(c.batch, 0.98);
  EXPECT_NEAR(c.tau, 1.0, 0.15);
}

// Quantiles of Student's t from printed tables (two-sided 95 % unless said).
TEST(SeriesStats, StudentTQuantileMatchesTables) {
  EXPECT_NEAR(student_t_quantile(0.975, 1), 12.706, 1e-3);
  EXPECT_NEAR(student_t_quantile(0.975, 2), 4.303, 1e-3);
  EXPECT_NEAR(student_t_quantile(0.975, 4), 2.776, 1e-3);
  EXPECT_NEAR(student_t_quantile(0.975, 9), 2.262, 1e-3);
  EXPECT_NEAR(student_t_quantile(0.975, 29), 2.045, 1e-3);
  EXPECT_NEAR(student_t_quantile(0.975, 120), 1.980, 1e-3);
  EXPECT_NEAR(student_t_quantile(0.975, 1000000), 1.960, 1e-3);
  EXPECT_NEAR(student_t_quantile(0.95, 10), 1.812, 1e-3);
  EXPECT_NEAR(student_t_quantile(0.995, 5), 4.032, 1e-3);
  EXPECT_NEAR(student_t_quantile(0.025, 9), -2.262, 1e-3);
  EXPECT_EQ(student_t_quantile(0.5, 7), 0.0);
  // Exact below 1001 degrees of freedom, Cornish-Fisher above: the two meet (t_{0.975,1000} = 1.962339).
  EXPECT_NEAR(student_t_quantile(0.975, 1000), 1.962339, 1e-6);
  EXPECT_LT(student_t_quantile(0.975, 1001), student_t_quantile(0.975, 1000));
  EXPECT_NEAR(student_t_quantile(0.975, 1001), student_t_quantile(0.975, 1000), 5e-6);
  EXPECT_THROW(student_t_quantile(1.0, 5), std::invalid_argument);
  EXPECT_THROW(student_t_quantile(0.9, 0), std::invalid_argument);
}

// Under 20 samples the batches are the samples: the plain t interval, computed here by hand.
TEST(SeriesStats, ShortSeriesGetThePlainTInterval) {
  const auto r = batch_means_ci({1.0, 2.0, 3.0, 4.0, 5.0});
  EXPECT_EQ(r.batch_size, 1u);
  EXPECT_EQ(r.batches, 5u);
  EXPECT_DOUBLE_EQ(r.mean, 3.0);
  EXPECT_NEAR(r.ci95, 2.776445 * std::sqrt(2.5) / std::sqrt(5.0), 1e-6);
  EXPECT_EQ(r.method(), "batch means, 5 batches of 1 samples");
  EXPECT_NEAR(mlcg::stats::lag1_autocorrelation({1.0, 2.0, 3.0, 4.0}), 0.25, 1e-15);
}

// Blocks of 8 equal samples: neighbouring batch means are correlated until a batch is one block
// (b = 1, 2, 4 give lag-1 correlations near 7/8, 3/4, 1/2); the block values alternate in sign, so
// at b = 8 the rule stops, and the half-width is the t interval of the block values, by hand here.
TEST(SeriesStats, BatchesGrowUntilTheBatchMeansAreUncorrelated) {
  std::vector<double> blocks, x;
  for (int k = 0; k < 100; ++k) blocks.push_back((k % 2 ? -1.0 : 1.0) * (1.0 + k % 3));
  for (double v : blocks) x.insert(x.end(), 8, v);
  const auto r = batch_means_ci(x);
  EXPECT_EQ(r.batch_size, 8u) << r.method();
  EXPECT_EQ(r.batches, 100u);
  double mean = 0.0, ss = 0.0;
  for (double v : blocks) mean += v / 100.0;
  for (double v : blocks) ss += (v - mean) * (v - mean);
  EXPECT_NEAR(r.ci95, 1.984217 * std::sqrt(ss / 99.0 / 100.0), 1e-6);  // t_{0.975, 99}
  EXPECT_NEAR(r.tau, 8.0 * (ss / 99.0) / (8.0 * ss / 799.0), 1e-9) << "b s_B^2 / s^2";
}

// A trend never decorrelates: the batch size stops where doubling would leave fewer than 10 batches
// (200 samples: b = 16, 12 batches, the first 8 samples left out).
TEST(SeriesStats, AtLeastTenBatchesStayAndDegenerateSeriesGiveNoNan) {
  std::vector<double> trend(200);
  for (size_t i = 0; i < trend.size(); ++i) trend[i] = static_cast<double>(i);
  const auto r = batch_means_ci(trend);
  EXPECT_EQ(r.batch_size, 16u) << r.method();
  EXPECT_EQ(r.batches, 12u);
  EXPECT_DOUBLE_EQ(r.mean, 99.5);
  const auto flat = batch_means_ci(std::vector<double>(50, 2.5));
  EXPECT_EQ(flat.ci95, 0.0);
  EXPECT_FALSE(std::isnan(flat.tau));
  EXPECT_TRUE(std::isnan(batch_means_ci({1.0}).ci95));
  EXPECT_EQ(batch_means_ci({}).samples, 0u);
}

}  // namespace
