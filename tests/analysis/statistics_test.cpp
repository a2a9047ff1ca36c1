// The distribution functions of analysis/metrics/statistics.h (Boost.Math underneath) against
// values from an independent source written down here: closed forms of the χ² tail for 1, 2 and 4
// degrees of freedom, published standard-normal critical values, and Šidák's formula as written.
// Also what the wrappers add to Boost: underflow to 0 instead of an exception, NaN for data that
// has no p-value, and InputError naming the argument for a bad significance level.
#include "analysis/metrics/statistics.h"

#include <cmath>
#include <limits>
#include <numbers>

#include <gtest/gtest.h>

#include "common/error.h"
#include "tests/test_util.h"

namespace plumage::analysis {
namespace {

// Boost computes in long double and rounds: a few ulp at most, checked with margin.
constexpr double kRelative = 1e-14;

double relative_error(double value, double expected) {
    return std::abs(value - expected) / std::abs(expected);
}

TEST(Statistics, ChiSquareTailMatchesClosedForms) {
    for (double x : {1e-6, 0.01, 0.5, 1.0, 3.84, 10.0, 50.0, 200.0, 1400.0}) {
        // dof 2: Q = e^(−x/2); dof 4: Q = e^(−x/2) (1 + x/2); dof 1: Q = erfc(√(x/2)).
        const double two = std::exp(-0.5 * x);
        EXPECT_LE(relative_error(chi_square_p_value(x, 2), two), kRelative) << x;
        EXPECT_LE(relative_error(chi_square_p_value(x, 4), two * (1.0 + 0.5 * x)), kRelative) << x;
        const double one = std::erfc(std::sqrt(0.5 * x));
        if (one > 0.0) {
            EXPECT_LE(relative_error(chi_square_p_value(x, 1), one), 1e-13) << x;
        }
        EXPECT_LE(relative_error(regularized_gamma_q(1.0, 0.5 * x), two), kRelative) << x;
    }
    EXPECT_EQ(chi_square_p_value(0.0, 7), 1.0);
}

TEST(Statistics, FarTailsUnderflowToZeroAndDataWithoutAValueGivesNaN) {
    // e^(−1000) is below the smallest double: 0, which p_value_text prints as "p < 1e-15".
    EXPECT_EQ(chi_square_p_value(2000.0, 2), 0.0);
    EXPECT_EQ(chi_square_p_value(1e7, 50), 0.0);
    EXPECT_EQ(chi_square_p_value(std::numeric_limits<double>::infinity(), 3), 0.0);
    EXPECT_EQ(chi_square_p_value(12.0, 0), 1.0);  // nothing compared: nothing rejected
    EXPECT_TRUE(std::isnan(chi_square_p_value(std::nan(""), 3)));
    EXPECT_TRUE(std::isnan(chi_square_p_value(-1.0, 3)));
    EXPECT_TRUE(std::isnan(regularized_gamma_q(0.0, 1.0)));
    EXPECT_TRUE(std::isnan(regularized_gamma_q(1.0, -1.0)));
}

TEST(Statistics, NormalQuantilesMatchPublishedCriticalValues) {
    // z_(1 − p/2) for p = 0.05, 0.01, 0.001 (standard tables, 16 digits).
    EXPECT_LE(relative_error(two_sided_normal_quantile(0.05), 1.959963984540054), 1e-15);
    EXPECT_LE(relative_error(two_sided_normal_quantile(0.01), 2.575829303548901), 1e-15);
    EXPECT_LE(relative_error(two_sided_normal_quantile(0.001), 3.290526731491894), 1e-15);
    EXPECT_EQ(two_sided_normal_quantile(1.0), 0.0);
    EXPECT_LE(relative_error(normal_quantile(0.975), 1.959963984540054), 1e-15);
    EXPECT_LE(relative_error(normal_quantile(0.025), -1.959963984540054), 1e-15);
    // And back through erfc, far into the tail: a relative error ε in z is one of about z² ε in
    // erfc(z/√2) there, so a few ulp of z allow 4 ulp × (1 + z²) of p.
    for (double p : {1e-300, 1e-100, 1e-20, 1e-8, 0.3, 0.9}) {
        const double z = two_sided_normal_quantile(p);
        const double ulps = 4.0 * std::numeric_limits<double>::epsilon() * (1.0 + z * z);
        EXPECT_LE(relative_error(std::erfc(z / std::numbers::sqrt2), p), ulps) << p;
    }
    EXPECT_EQ(normal_quantile(0.0), -std::numeric_limits<double>::infinity());
    EXPECT_EQ(normal_quantile(1.0), std::numeric_limits<double>::infinity());
}

TEST(Statistics, SidakMatchesItsFormulaWithoutCancellation) {
    // 1 − (1 − α)^(1/m) as written (cancellation costs ~3 digits here, hence 1e-13).
    EXPECT_LE(relative_error(sidak_significance(0.05, 20), 1.0 - std::pow(0.95, 1.0 / 20.0)),
              1e-13);
    EXPECT_EQ(sidak_significance(0.01, 1), 0.01);
    EXPECT_EQ(sidak_significance(0.01, 0), 0.01);  // no tests counted as one
    // α = 1e-12, m = 4: α/m + (m − 1) α²/(2m²) + O(α³), where the formula as written has no
    // digits left.
    EXPECT_LE(relative_error(sidak_significance(1e-12, 4), 0.25e-12 + 3.0 / 32.0 * 1e-24), 1e-15);
}

TEST(Statistics, BadSignificanceLevelsAreInputErrorsNamingTheArgument) {
    using testing::input_error_message;
    EXPECT_EQ(input_error_message([] { sidak_significance(0.0, 3); }),
              "sidak_significance: family = 0: expected a family-wise significance in (0, 1)");
    EXPECT_EQ(input_error_message([] { sidak_significance(1.5, 3); }),
              "sidak_significance: family = 1.5: expected a family-wise significance in (0, 1)");
    EXPECT_EQ(input_error_message([] { two_sided_normal_quantile(0.0); }),
              "two_sided_normal_quantile: p = 0: expected a two-sided tail probability in (0, 1]");
    EXPECT_EQ(input_error_message([] { two_sided_normal_quantile(std::nan("")); }),
              "two_sided_normal_quantile: p = nan: expected a two-sided tail probability in "
              "(0, 1]");
}

}  // namespace
}  // namespace plumage::analysis
