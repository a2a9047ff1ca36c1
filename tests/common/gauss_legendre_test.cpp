// The one Gauss–Legendre rule: exact for polynomials of degree 2n − 1, and the written-out 8- and
// 16-node tables are the same rule.
#include "common/gauss_legendre.h"

#include <cmath>

#include <gtest/gtest.h>

#include "common/error.h"

namespace plumage {
namespace {

// ∫₋₁¹ x^k dx: 2/(k + 1) for even k, 0 for odd.
double monomial_integral(int k) { return k % 2 == 0 ? 2.0 / (k + 1) : 0.0; }

TEST(GaussLegendre, IntegratesPolynomialsOfDegreeTwoNMinusOneExactly) {
    for (int n : {1, 2, 3, 5, 8, 16, 33, 64, 512}) {
        const GaussLegendreRule rule = gauss_legendre(n);
        ASSERT_EQ(rule.nodes.size(), static_cast<std::size_t>(n));
        for (int k = 0; k <= std::min(2 * n - 1, 40); ++k) {
            double sum = 0.0;
            for (int i = 0; i < n; ++i) sum += rule.weights[i] * std::pow(rule.nodes[i], k);
            // The weights' stated accuracy (header): 1e-13 relative.
            EXPECT_NEAR(sum, monomial_integral(k), 1e-13) << "n = " << n << ", k = " << k;
        }
        for (int i = 1; i < n; ++i) EXPECT_LT(rule.nodes[i], rule.nodes[i - 1]) << "decreasing";
    }
}

TEST(GaussLegendre, TheTablesAreTheSameRule) {
    const GaussLegendreRule eight = gauss_legendre(8), sixteen = gauss_legendre(16);
    // The tables are increasing, the rule decreasing; the tables are correctly rounded to 16
    // digits, the computed rule within its stated accuracy (nodes 1e-15, weights 1e-13 relative).
    for (std::size_t i = 0; i < 8; ++i) {
        EXPECT_NEAR(kGl8Nodes[i], eight.nodes[7 - i], 1e-15);
        EXPECT_NEAR(kGl8Weights[i], eight.weights[7 - i], 1e-13 * kGl8Weights[i]);
    }
    for (std::size_t i = 0; i < 16; ++i) {
        EXPECT_NEAR(kGl16Nodes[i], sixteen.nodes[15 - i], 1e-15);
        EXPECT_NEAR(kGl16Weights[i], sixteen.weights[15 - i], 1e-13 * kGl16Weights[i]);
    }
}

TEST(GaussLegendre, RefusesANodeCountOutsideItsRange) {
    EXPECT_THROW(gauss_legendre(0), InputError);
    EXPECT_THROW(gauss_legendre(4097), InputError);
}

}  // namespace
}  // namespace plumage
