// Distribution functions the statistical checks share (the tests' chi-square recipe, the
// studies' family-wise bounds): thin wrappers over Boost.Math (libboost-dev), which computes them
// to within a few ulp, in one place so every caller gets the same conventions and the same
// errors. tests/analysis/statistics_test.cpp checks them against closed forms written down
// there; tests/analysis/filip2024_test.cpp against textbook chi-square critical values.
//
// What Boost computes (Boost 1.74 headers; double arguments are promoted to long double inside
// on x86-64). Measured against 50-digit Boost.Multiprecision when this replaced our own series,
// continued fraction, bisection and Acklam + Halley code: ≤ 2e-15 relative for the χ² tail over
// dof 1–1e5 and statistic/dof 0.01–30 (ours: up to 3e-13 at dof 1000, 8e-11 at dof 1e5), and
// ≤ 2e-16 for the normal quantiles (ours: up to 7e-7 for p = 1 − 1e-12); the tests check 1e-14.
//  - regularized_gamma_q: boost::math::gamma_q (DiDonato & Morris' method, Temme's expansion for
//    large a; the tail is computed directly, never as 1 − P, so it keeps its relative accuracy
//    down to the smallest normal double).
//  - chi_square_p_value: cdf(complement(chi_squared(dof), statistic)), i.e. gamma_q(dof/2, x/2).
//  - two_sided_normal_quantile: √2 · erfc_inv(p), Boost's inverse complementary error function;
//    normal_quantile: quantile(normal(), p), the same function.
//  - sidak_significance: −expm1(log1p(−family)/tests) from <cmath>; Boost has no Šidák function,
//    and this form is exact to rounding without the cancellation of 1 − (1 − α)^(1/m).
//
// Errors. Values far in a tail that underflow a double come back as 0 (Boost's underflow policy
// set to "ignore"): callers print them as "p < 1e-15" (studies/measurement_cost.cpp p_value_text).
// Out-of-domain arguments are checked here before Boost sees them: the data-driven ones (a χ²
// statistic that came out NaN or negative) give NaN as before, the configuration ones
// (a significance level outside its interval) throw InputError naming the argument and value.
// Anything Boost still refuses (domain, pole or evaluation errors; overflow returns ±∞) is a bug
// here and throws InvariantError with Boost's message and the arguments.
#pragma once

#include <cstdint>

namespace plumage::analysis {

// Q(a, x) = Γ(a, x) / Γ(a), the upper regularized incomplete gamma function, for finite a > 0
// and x ≥ 0 (0 for x = +∞); NaN for any other a or x.
double regularized_gamma_q(double a, double x);

// P(χ²_dof ≥ statistic); 1 for dof ≤ 0, NaN for a negative or NaN statistic, 0 for +∞.
double chi_square_p_value(double statistic, int dof);

// Per-test significance that keeps the family-wise one at `family` ∈ (0, 1) over `tests`
// independent tests (Šidák): 1 − (1 − family)^(1/tests), tests < 1 counted as 1. InputError for
// family outside (0, 1).
double sidak_significance(double family, int tests);

// z ≥ 0 whose two-sided standard-normal tail probability is p ∈ (0, 1]: erfc(z/√2) = p.
// InputError for p outside (0, 1].
double two_sided_normal_quantile(double p);

// The standard normal quantile Φ⁻¹(p) = −√2 · erfc_inv(2p) for p ∈ (0, 1); −∞ for p ≤ 0 (and
// NaN), +∞ for p ≥ 1, so samplers may pass the ends of their interval.
double normal_quantile(double p);

// The reciprocity test of one couple: cell a = f̄(u, v) and cell b = f̄(v, u) of a both_cones
// photon record (virtual_gonio/goniometer.h), each the mean over `quanta` quanta of
// x = w · 1[ω_o ∈ cone] / (π sin²α cos θ_view), w the path's weight, with its standard error.
// Returns z = (a − b) / √(var_a + var_b) with the variances estimated under the hypothesis
// f̄(u, v) = f̄(v, u) = μ (a score test), or NaN when neither cell has a hit.
//
// Why not each cell's own standard error (the Wald z): a cell's hits are few at grazing
// views and each weighs 1/cos θ_view, so the two cells of a couple have hit sizes up to
// cos 15°/cos 75° = 3.7 apart; with few hits a cell's sample variance grows with its own
// fluctuation (a cell that drew few hits reads low AND precise), which biases the Wald z
// towards the heavier cell and inflates χ² (measured on the four quick species patches at
// 3000 quanta, two seeds each: χ²/dof 1.07–1.15 by Wald, 0.98–1.04 by this test; couples in which a
// cell has fewer than 5 effective hits carry the excess, while two seeds of the same cell, whose
// hit sizes are equal, agree at χ²/dof 0.98–1.02 either way).
//
// Under the hypothesis: a cell with view cosine c receives hits at a rate ∝ μ c (its
// projected detector solid angle), and reversed paths carry the same weights (power
// transmittances are reciprocal), so the hit-weight moment κ = E[w²]/E[w] is common and
// E[x_c²] = μ κ / (P c), P = π sin²α. From the record, S1 = mean x = value and
// S2 = mean x² = σ²(N − 1) + value² (the goniometer's variance estimator, inverted); pooled:
// κ/P = (c_a² S2_a + c_b² S2_b) / (c_a S1_a + c_b S1_b), μ̂ = (c_a a + c_b b) / (c_a + c_b) (the
// common mean that maximises the Poisson likelihood of both cells' hits), and
// var_c = (μ̂ κ/(P c) − μ̂²) / (N − 1). With equal cosines and equal weights this is the
// classical score test of two Poisson counts, (n_a − n_b) / √(n_a + n_b).
struct ReciprocityCell {
    double value = 0.0;           // 1/sr
    double standard_error = 0.0;  // 1/sr
    double cos_view = 1.0;        // cos θ of the cell's view direction, > 0
};
double reciprocity_z(const ReciprocityCell& a, const ReciprocityCell& b, std::uint64_t quanta);

}  // namespace plumage::analysis
