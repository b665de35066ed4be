// Special functions behind every tail probability and quantile of Stend (stend/stats/
// distributions.hpp): the regularized incomplete gamma and beta functions, by series and continued
// fractions (Numerical Recipes §6.2, §6.4; modified Lentz), double precision.
#pragma once

namespace stend::stats {

// Regularized lower incomplete gamma P(a, x) = γ(a, x)/Γ(a), a > 0, x ≥ 0 (x = ∞ gives 1).
// Throws std::domain_error outside that domain (x NaN included). Relative error ≈ 1e-15.
double gamma_p(double a, double x);

// Regularized incomplete beta I_x(a, b), a, b > 0; 0 for x ≤ 0, 1 for x ≥ 1.
double beta_i(double a, double b, double x);

}  // namespace stend::stats
