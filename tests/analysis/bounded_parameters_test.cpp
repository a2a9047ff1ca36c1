// The logistic map of bounded fit parameters (analysis/fits/bounded_parameters.h): variable ↔
// parameter round trips, the inset at the bounds, the slope, and the at-bound test.
#include "analysis/fits/bounded_parameters.h"

#include <cmath>
#include <limits>

#include <gtest/gtest.h>

namespace plumage::analysis {
namespace {

constexpr BoundedRange kRange{-2.0, 3.0};

TEST(BoundedParameters, ParameterOfVariableRoundTrips) {
    for (double p = -1.999; p < 3.0; p += 0.0625) {
        const double u = kRange.variable(p);
        EXPECT_TRUE(std::isfinite(u)) << p;
        EXPECT_NEAR(kRange.parameter(u), p, 1e-13) << p;
    }
}

TEST(BoundedParameters, VariableOfParameterRoundTrips) {
    for (double u = -20.0; u <= 20.0; u += 0.5) {
        const double p = kRange.parameter(u);
        EXPECT_GE(p, kRange.min);
        EXPECT_LE(p, kRange.max);
        // Far out, p rounds onto its bound and the inset takes over.
        if (std::abs(u) < 15.0) {
            EXPECT_NEAR(kRange.variable(p), u, 1e-8 * (1.0 + std::abs(u)));
        }
    }
}

TEST(BoundedParameters, BoundsAndBeyondAreMovedInsideByTheInset) {
    const double width = kRange.max - kRange.min;
    for (const double p : {kRange.min, kRange.min - 1.0, -std::numeric_limits<double>::max()}) {
        const double u = kRange.variable(p);
        EXPECT_TRUE(std::isfinite(u));
        EXPECT_NEAR(kRange.parameter(u), kRange.min + kStartInset * width, 1e-15 * width);
    }
    for (const double p : {kRange.max, kRange.max + 1.0}) {
        const double u = kRange.variable(p);
        EXPECT_TRUE(std::isfinite(u));
        EXPECT_NEAR(kRange.parameter(u), kRange.max - kStartInset * width, 1e-15 * width);
    }
}

TEST(BoundedParameters, SlopeIsTheDerivativeOfParameter) {
    for (double u = -8.0; u <= 8.0; u += 0.25) {
        const double h = 1e-6;
        const double numeric = (kRange.parameter(u + h) - kRange.parameter(u - h)) / (2.0 * h);
        EXPECT_NEAR(kRange.slope(u), numeric, 1e-8) << u;
        EXPECT_GT(kRange.slope(u), 0.0);
    }
    EXPECT_DOUBLE_EQ(kRange.slope(0.0), 0.25 * (kRange.max - kRange.min));
}

TEST(BoundedParameters, NearBoundWithinTheFractionOfTheRange) {
    const double margin = kAtBoundFraction * (kRange.max - kRange.min);
    EXPECT_TRUE(kRange.near_bound(kRange.min));
    EXPECT_TRUE(kRange.near_bound(kRange.max));
    EXPECT_TRUE(kRange.near_bound(kRange.min + 0.5 * margin));
    EXPECT_TRUE(kRange.near_bound(kRange.max - 0.5 * margin));
    EXPECT_FALSE(kRange.near_bound(kRange.min + 2.0 * margin));
    EXPECT_FALSE(kRange.near_bound(kRange.max - 2.0 * margin));
    EXPECT_FALSE(kRange.near_bound(0.5 * (kRange.min + kRange.max)));
}

}  // namespace
}  // namespace plumage::analysis
