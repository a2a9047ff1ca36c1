// Distribution functions the statistical checks share (the tests' chi-square recipe, the
// studies' family-wise bounds): one implementation, tested once (tests/analysis/filip2024_test.cpp
// checks Q against closed forms and chi-square quantiles).
#pragma once

namespace plumage::analysis {

// Q(a, x) = Γ(a, x) / Γ(a), the upper regularized incomplete gamma function, a > 0, x ≥ 0
// (NaN otherwise): the power series of P = 1 − Q for x < a + 1, Legendre's continued fraction
// for Q otherwise (modified Lentz), each converging fast in its region. Clamped to [0, 1].
double regularized_gamma_q(double a, double x);

// P(χ²_dof ≥ statistic); 1 for dof ≤ 0.
double chi_square_p_value(double statistic, int dof);

// Per-test significance that keeps the family-wise one at `family` over `tests` independent
// tests (Šidák): 1 − (1 − family)^(1/tests), computed without cancellation.
double sidak_significance(double family, int tests);

// |z| whose two-sided standard-normal tail probability is p: erfc(z/√2) = p (bisection).
double two_sided_normal_quantile(double p);

}  // namespace plumage::analysis
