// The EDF of the Allan variance against the exact EDF of Gaussian second differences, the
// intervals, and the correlation of overlapping estimates against Monte Carlo and its kept table.
// (The χ² quantiles and the gamma function behind them: stats/tests/distributions_test.cpp.)
#include <stend/noise/edf.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

using namespace stend::noise;
using stend::stats::kOneSigma;

namespace {

// Exact EDF of s = (1/M) Σ d_k² when d_t = Σ_i k_i w_{t−i} with w white Gaussian:
// EDF = 2 E[s]² / Var[s] = M² c0² / Σ_{k,l} c(k−l)².
double exact_edf(const std::vector<double>& kernel, long M) {
  const long L = static_cast<long>(kernel.size());
  auto c = [&](long j) {
    double s = 0.0;
    for (long i = 0; i + j < L; ++i) s += kernel[static_cast<std::size_t>(i)] * kernel[static_cast<std::size_t>(i + j)];
    return s;
  };
  const double c0 = c(0);
  double sum = static_cast<double>(M) * c0 * c0;
  for (long j = 1; j < std::min(M, L); ++j) {
    const double cj = c(j);
    sum += 2.0 * static_cast<double>(M - j) * cj * cj;
  }
  return static_cast<double>(M) * static_cast<double>(M) * c0 * c0 / sum;
}

// Second difference x_k − 2x_{k−m} + x_{k−2m} of the phase as a filter on the *rate* samples
// (white rate noise) and on the rate increments (random-walk rate).
std::vector<double> white_kernel(long m) {
  std::vector<double> h(static_cast<std::size_t>(2 * m));
  for (long i = 0; i < m; ++i) {
    h[static_cast<std::size_t>(i)] = 1.0;
    h[static_cast<std::size_t>(m + i)] = -1.0;
  }
  return h;
}
std::vector<double> random_walk_kernel(long m) {
  auto h = white_kernel(m);
  double acc = 0.0;
  for (auto& v : h) {
    acc += v;
    v = acc;
  }
  return h;
}

}  // namespace

TEST(Edf, WhiteNoiseMatchesExactEdf) {
  for (long N : {151L, 1001L, 20001L}) {
    for (long m : {1L, 2L, 4L, 8L, 16L, 32L, 64L}) {
      if (2 * m >= N) continue;
      const double exact = exact_edf(white_kernel(m), N - 2 * m);
      // Stable32's rule models the phase as averaged over τ0 (F = m) while m(d+1) ≤ 100, i.e.
      // m ≤ 33: there it departs from the exact EDF of sampled white noise by −12 % … +17 %
      // (+17 % at m = 1); beyond (F = ∞) it is exact.
      const double ratio = edf_overlapping_adev(NoiseType::kWhite, static_cast<double>(N), static_cast<double>(m)) / exact;
      if (3 * m <= 100) {
        EXPECT_GT(ratio, 0.87) << "N=" << N << " m=" << m;
        EXPECT_LT(ratio, 1.18) << "N=" << N << " m=" << m;
      } else {
        EXPECT_NEAR(ratio, 1.0, 0.005) << "N=" << N << " m=" << m;
      }
      // The NIST SP 1065 closed form is close for white noise as well.
      EXPECT_NEAR(edf_overlapping_adev_simple(NoiseType::kWhite, static_cast<double>(N), static_cast<double>(m)) / exact,
                  1.0, 0.08);
    }
  }
}

TEST(Edf, RandomWalkMatchesExactEdfBeyondTheFirstOctaves) {
  // Greenhall's model is the continuous random walk; the sampled one differs at m ≤ 4 only.
  for (long N : {1001L, 20001L}) {
    for (long m : {8L, 16L, 32L, 64L}) {
      const double exact = exact_edf(random_walk_kernel(m), N - 2 * m);
      EXPECT_NEAR(edf_overlapping_adev(NoiseType::kRandomWalk, static_cast<double>(N), static_cast<double>(m)) / exact,
                  1.0, 0.02)
          << "N=" << N << " m=" << m;
    }
  }
}

TEST(Edf, LargeRecordsUseTheAsymptoticTable) {
  // r = M/m > 3 and J > 100: edf = r / (a0 − a1/r), white noise a0 = 2/3, a1 = 1/3.
  const double N = 1e6 + 1, m = 1000, M = N - 2 * m, r = M / m;
  EXPECT_NEAR(edf_overlapping_adev(NoiseType::kWhite, N, m), r / (2.0 / 3.0 - 1.0 / 3.0 / r), 1e-6);
  for (auto t : {NoiseType::kQuantization, NoiseType::kFlickerPhase, NoiseType::kWhite,
                 NoiseType::kFlicker, NoiseType::kRandomWalk}) {
    const double e = edf_overlapping_adev(t, N, m);
    EXPECT_TRUE(std::isfinite(e) && e > 0) << to_string(t);
  }
  EXPECT_TRUE(std::isnan(edf_overlapping_adev(NoiseType::kWhite, 10, 5)));  // no difference
}

TEST(Interval, CoversTheEstimateAndShrinksWithEdf) {
  const auto a = deviation_interval(1.0, 10, kOneSigma);
  const auto b = deviation_interval(1.0, 1000, kOneSigma);
  EXPECT_LT(a.lo, 1.0);
  EXPECT_GT(a.hi, 1.0);
  EXPECT_LT(b.hi - b.lo, a.hi - a.lo);
  // ±1/√(2·edf) for large edf.
  EXPECT_NEAR(b.hi - 1.0, 1.0 / std::sqrt(2.0 * 1000), 2e-3);
}

// Monte Carlo of the correlation between overlapping AVAR estimates: 1000 records of 2^12
// samples of white or random-walk FM, AVAR at m = 1 … N/4 (phase x = Σ y, second differences).
class AvarCorrelationMonteCarlo : public ::testing::TestWithParam<NoiseType> {};

TEST_P(AvarCorrelationMonteCarlo, MatchesTheComputedCorrelation) {
  const NoiseType type = GetParam();
  constexpr long N = 1L << 12;
  constexpr int kRecords = 1000, kOctaves = 11;  // m = 1 … 1024 = N/4
  std::mt19937_64 rng(7);
  std::normal_distribution<double> normal;
  std::vector<std::vector<double>> avar(kOctaves, std::vector<double>(kRecords));
  std::vector<double> x(N + 1);
  for (int r = 0; r < kRecords; ++r) {
    double walk = 0.0;
    x[0] = 0.0;
    for (long i = 0; i < N; ++i) {
      walk = type == NoiseType::kRandomWalk ? walk + normal(rng) : normal(rng);
      x[static_cast<std::size_t>(i + 1)] = x[static_cast<std::size_t>(i)] + walk;
    }
    for (int k = 0; k < kOctaves; ++k) {
      const long m = 1L << k, M = N + 1 - 2 * m;
      double s = 0.0;
      for (long i = 0; i < M; ++i) {
        const double d = x[static_cast<std::size_t>(i + 2 * m)] - 2.0 * x[static_cast<std::size_t>(i + m)] +
                         x[static_cast<std::size_t>(i)];
        s += d * d;
      }
      avar[static_cast<std::size_t>(k)][static_cast<std::size_t>(r)] = s / (2.0 * double(m * m) * double(M));
    }
  }
  auto sample_correlation = [&](int i, int j) {
    const auto &a = avar[static_cast<std::size_t>(i)], &b = avar[static_cast<std::size_t>(j)];
    double ma = 0.0, mb = 0.0;
    for (int r = 0; r < kRecords; ++r) {
      ma += a[static_cast<std::size_t>(r)] / kRecords;
      mb += b[static_cast<std::size_t>(r)] / kRecords;
    }
    double sab = 0.0, saa = 0.0, sbb = 0.0;
    for (int r = 0; r < kRecords; ++r) {
      const double u = a[static_cast<std::size_t>(r)] - ma, v = b[static_cast<std::size_t>(r)] - mb;
      sab += u * v;
      saa += u * u;
      sbb += v * v;
    }
    return sab / std::sqrt(saa * sbb);
  };
  // Sampling error of a correlation from 1000 records: (1 − ρ²)/√1000 ≤ 0.032; 0.07 is > 2σ.
  for (int i = 0; i + 1 < kOctaves; ++i) {
    for (int j = i + 1; j < kOctaves && j <= i + 3; ++j) {
      const double m1 = std::ldexp(1.0, i), m2 = std::ldexp(1.0, j);
      EXPECT_NEAR(sample_correlation(i, j), avar_correlation(type, m1, m2, static_cast<double>(N)), 0.07)
          << to_string(type) << " m = " << m1 << ", " << m2;
    }
  }
  // The record's length matters for random walk at the longest τ: 0.79 against 0.89 for a long record.
  if (type == NoiseType::kRandomWalk) {
    EXPECT_LT(avar_correlation(type, N / 8, N / 4, static_cast<double>(N)), avar_correlation(type, N / 8, N / 4) - 0.05);
  }
}

INSTANTIATE_TEST_SUITE_P(WhiteAndRandomWalk, AvarCorrelationMonteCarlo,
                         ::testing::Values(NoiseType::kWhite, NoiseType::kRandomWalk),
                         [](const auto& p) { return p.param == NoiseType::kWhite ? "white" : "random_walk"; });

TEST(AvarCorrelation, IsOneOnTheDiagonalAndFallsWithTheRatio) {
  for (auto t : {NoiseType::kQuantization, NoiseType::kWhite, NoiseType::kFlicker, NoiseType::kRandomWalk}) {
    EXPECT_NEAR(avar_correlation(t, 8, 8), 1.0, 1e-12) << to_string(t);
    EXPECT_EQ(avar_correlation(t, 1, std::ldexp(1.0, kAvarCorrelationOctaves + 1)), 0.0);
  }
  for (auto t : {NoiseType::kWhite, NoiseType::kFlicker, NoiseType::kRandomWalk}) {
    EXPECT_GT(avar_correlation(t, 8, 16), avar_correlation(t, 8, 64)) << to_string(t);
  }
  // The flatter the spectrum's slope, the more the octaves share: white < flicker < random walk FM.
  EXPECT_LT(avar_correlation(NoiseType::kWhite, 16, 32), avar_correlation(NoiseType::kFlicker, 16, 32));
  EXPECT_LT(avar_correlation(NoiseType::kFlicker, 16, 32), avar_correlation(NoiseType::kRandomWalk, 16, 32));
}

TEST(AvarCorrelation, TheKeptTableIsTheComputation) {
  const auto computed = compute_avar_correlation_table();
  for (std::size_t ty = 0; ty < computed.size(); ++ty)
    for (std::size_t b = 0; b < computed[ty].size(); ++b)
      for (std::size_t k = 0; k < computed[ty][b].size(); ++k)
        EXPECT_NEAR(avar_correlation_table()[ty][b][k], computed[ty][b][k], 1e-15) << ty << " " << b << " " << k;
}
