// Special functions and distribution functions against published values (scipy.stats, the
// standard tables) and exact identities: closed forms, symmetry, quantile ∘ cdf = identity.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <stdexcept>

#include "stend/stats/distributions.hpp"
#include "stend/stats/special_functions.hpp"

using namespace stend::stats;

TEST(GammaP, ClosedForms) {
  // Integer a: P(a, x) = 1 − e^{−x} Σ_{k<a} x^k/k!, both branches (x < a + 1 and beyond).
  for (double x : {0.3, 4.0, 9.5, 30.0}) {
    double sum = 0, term = 1;
    for (int k = 0; k < 6; ++k) {
      sum += term;
      term *= x / (k + 1);
    }
    EXPECT_NEAR(gamma_p(6.0, x), 1.0 - std::exp(-x) * sum, 1e-14) << x;
  }
  EXPECT_EQ(gamma_p(2.0, 0.0), 0.0);
  EXPECT_EQ(gamma_p(2.0, INFINITY), 1.0);
  EXPECT_THROW(gamma_p(0.0, 1.0), std::domain_error);
  EXPECT_THROW(gamma_p(1.0, -1.0), std::domain_error);
  EXPECT_THROW(gamma_p(1.0, NAN), std::domain_error);
}

TEST(BetaI, ClosedFormsAndSymmetry) {
  for (double x : {0.01, 0.2, 0.5, 0.77, 0.99}) {
    EXPECT_NEAR(beta_i(1.0, 1.0, x), x, 1e-15);
    EXPECT_NEAR(beta_i(3.5, 1.0, x), std::pow(x, 3.5), 1e-14);
    EXPECT_NEAR(beta_i(1.0, 2.5, x), 1.0 - std::pow(1.0 - x, 2.5), 1e-14);
    // I_x(a, b) = 1 − I_{1−x}(b, a)
    EXPECT_NEAR(beta_i(2.3, 7.1, x), 1.0 - beta_i(7.1, 2.3, 1.0 - x), 1e-14);
  }
  EXPECT_NEAR(beta_i(4.2, 4.2, 0.5), 0.5, 1e-15);
  EXPECT_EQ(beta_i(2.0, 3.0, 0.0), 0.0);
  EXPECT_EQ(beta_i(2.0, 3.0, 1.0), 1.0);
}

TEST(Normal, ConstantsAndRoundTrip) {
  EXPECT_NEAR(normal_quantile(0.975), kZ95, 1e-15);
  EXPECT_NEAR(normal_cdf(1.0) - normal_cdf(-1.0), kOneSigma, 1e-15);
  for (double p : {1e-6, 0.01, 0.3, 0.7, 0.999}) EXPECT_NEAR(normal_cdf(normal_quantile(p)), p, 1e-14 * std::max(1.0, p / (1 - p)));
  EXPECT_THROW(normal_quantile(0.0), std::domain_error);
}

TEST(StudentT, MatchesTables) {
  EXPECT_NEAR(student_t_quantile(0.975, 1), 12.7062047, 1e-6);
  EXPECT_NEAR(student_t_quantile(0.975, 2), 4.30265273, 1e-7);
  EXPECT_NEAR(student_t_quantile(0.975, 3), 3.18244631, 1e-7);
  EXPECT_NEAR(student_t_quantile(0.975, 10), 2.22813885, 1e-7);
  EXPECT_NEAR(student_t_quantile(0.975, 20), 2.08596345, 1e-7);
  EXPECT_NEAR(student_t_quantile(0.995, 5), 4.03214298, 1e-7);
  EXPECT_NEAR(student_t_quantile(0.025, 10), -2.22813885, 1e-7);
  EXPECT_NEAR(student_t_quantile(0.975, 1e7), 1.95996398, 1e-5);
  EXPECT_NEAR(student_t_quantile(0.975, INFINITY), kZ95, 1e-15);
  EXPECT_NEAR(student_t_cdf(2.22813885, 10), 0.975, 1e-8);
  EXPECT_NEAR(student_t_cdf(0.0, 3), 0.5, 1e-15);
  // One degree of freedom is the Cauchy distribution: F(t) = 1/2 + atan(t)/π.
  for (double t : {-3.0, 0.4, 7.0}) EXPECT_NEAR(student_t_cdf(t, 1.0), 0.5 + std::atan(t) / std::numbers::pi, 1e-14);
  EXPECT_THROW(student_t_quantile(0.5, 0.0), std::domain_error);
}

TEST(ChiSquared, MatchesTableValues) {
  struct Row {
    double p, nu, x;
  };
  // Standard chi-squared table (7 significant digits).
  const Row table[] = {{0.025, 1, 0.000982069}, {0.975, 1, 5.023886},  {0.05, 10, 3.940299},
                       {0.95, 10, 18.30704},     {0.5, 2, 1.386294},    {0.01, 100, 70.06489},
                       {0.99, 100, 135.8067},    {0.1, 5, 1.610308},    {0.9, 5, 9.236357},
                       {0.005, 1000, 888.5635},  {0.995, 1000, 1118.948}, {0.05, 3, 0.3518463},
                       {0.95, 3, 7.814728},      {0.001, 20, 5.921040}, {0.999, 20, 45.31475}};
  for (const auto& r : table) {
    EXPECT_NEAR(chi2_quantile(r.p, r.nu) / r.x, 1.0, 2e-6) << "p=" << r.p << " nu=" << r.nu;
  }
}

TEST(ChiSquared, InvertsTheCdfForNonIntegerAndLargeDegrees) {
  for (double nu : {0.3, 1.7, 7.5, 50.5, 1e4, 1e6}) {
    for (double p : {1e-6, 0.0228, 0.1587, 0.5, 0.8413, 0.9772, 0.999999}) {
      const double x = chi2_quantile(p, nu);
      EXPECT_NEAR(chi2_cdf(x, nu), p, 1e-9 * std::max(1.0, p / (1 - p)) + 1e-12)
          << "nu=" << nu << " p=" << p;
    }
  }
  // Wilson–Hilferty regime: the median of χ²(ν) is ≈ ν(1 − 2/(9ν))³.
  const double nu = 5e7;
  EXPECT_NEAR(chi2_quantile(0.5, nu) / (nu * std::pow(1 - 2 / (9 * nu), 3)), 1.0, 1e-12);
}

TEST(ChiSquared, RejectsBadArguments) {
  EXPECT_THROW(chi2_quantile(0.0, 3), std::domain_error);
  EXPECT_THROW(chi2_quantile(1.0, 3), std::domain_error);
  EXPECT_THROW(chi2_quantile(0.5, 0), std::domain_error);
  EXPECT_THROW(normal_quantile(1.5), std::domain_error);
}

TEST(NormalQuantile, KnownValues) {
  EXPECT_NEAR(normal_quantile(0.975), 1.959963984540054, 1e-12);
  EXPECT_NEAR(normal_quantile(0.5), 0.0, 1e-15);
  EXPECT_NEAR(normal_quantile(0.8413447460685429), 1.0, 1e-12);
  EXPECT_NEAR(normal_quantile(1e-10), -6.361340902404056, 1e-9);
}

TEST(GammaP, KnownValues) {
  EXPECT_NEAR(gamma_p(1.0, 1.0), 1.0 - std::exp(-1.0), 1e-15);
  EXPECT_NEAR(gamma_p(0.5, 2.0), std::erf(std::sqrt(2.0)), 1e-14);
  EXPECT_NEAR(gamma_p(3.0, 2.0), 1.0 - std::exp(-2.0) * (1 + 2 + 2), 1e-14);
}

TEST(ChiSquared, ClosedFormsAndTheUpperTail) {
  EXPECT_NEAR(chi2_quantile(0.95, 1), 3.841458820694124, 1e-9);
  EXPECT_NEAR(chi2_quantile(0.95, 2), -2.0 * std::log(0.05), 1e-12);
  EXPECT_NEAR(chi2_quantile(0.975, 10), 20.483177350807395, 1e-8);
  EXPECT_NEAR(chi2_sf(3.841458820694124, 1), 0.05, 1e-12);
  // Two degrees of freedom: P(χ² > x) = e^{−x/2}.
  for (double x : {0.1, 2.0, 13.0}) EXPECT_NEAR(chi2_sf(x, 2), std::exp(-0.5 * x), 1e-15);
  for (double x : {0.5, 8.0}) EXPECT_NEAR(chi2_cdf(x, 7.3) + chi2_sf(x, 7.3), 1.0, 1e-15);
  EXPECT_EQ(chi2_sf(-1.0, 3), 1.0);
}

TEST(FDistribution, TailsAndQuantiles) {
  // d1 = 2: P(F > f) = (1 + 2f/d2)^(−d2/2).
  for (double f : {0.2, 1.0, 4.5})
    for (double d2 : {3.0, 17.0}) EXPECT_NEAR(f_sf(f, 2, d2), std::pow(1 + 2 * f / d2, -d2 / 2), 1e-14);
  // F(1, d) = t(d)²: the upper 5 % point is the two-sided t quantile squared.
  EXPECT_NEAR(f_upper_quantile(0.05, 1, 10), std::pow(student_t_quantile(0.975, 10), 2), 1e-9);
  EXPECT_NEAR(f_upper_quantile(0.05, 3, 10), 3.7082648190468435, 1e-8);
  EXPECT_NEAR(f_sf(f_upper_quantile(0.01, 7, 56), 7, 56), 0.01, 1e-12);
  EXPECT_EQ(f_sf(0.0, 3, 4), 1.0);
  EXPECT_EQ(f_sf(NAN, 3, 4), 1.0);
}

TEST(Wilson, ZeroOfNAndSymmetry) {
  const double z = kZ95;
  const Interval none = wilson_interval(0, 10, z);
  EXPECT_NEAR(none.lo, 0.0, 1e-15);
  EXPECT_NEAR(none.hi, z * z / (10 + z * z), 1e-15);
  const Interval a = wilson_interval(3, 20, z), b = wilson_interval(17, 20, z);
  EXPECT_NEAR(a.lo, 1.0 - b.hi, 1e-15);
  EXPECT_NEAR(a.hi, 1.0 - b.lo, 1e-15);
  EXPECT_TRUE(std::isnan(wilson_interval(0, 0, z).lo));
}
