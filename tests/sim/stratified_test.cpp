// Stratified groups (sim/scatterer/stratified.h): the nets that make a group's mean vary less,
// the exact uniformity that keeps it unbiased, and the gain on a pixel's edge.
#include "sim/scatterer/stratified.h"

#include <cmath>
#include <cstdint>
#include <vector>

#include <gtest/gtest.h>

#include "common/constants.h"

namespace plumage {
namespace {

// The smallest t for which the first 2^m points of dimensions (a, b) form a (t, m, 2)-net: every
// elementary box of area 2^(t − m) (sides 2^-i × 2^-(m − t − i)) holds exactly 2^t points.
int net_quality(const ScrambledSobolGroup& group, int m, int a, int b) {
    const std::uint32_t n = 1u << m;
    for (int t = 0; t <= m; ++t) {
        bool net = true;
        for (int i = 0; i <= m - t && net; ++i) {
            const int j = m - t - i;
            std::vector<int> count(std::size_t{1} << (m - t), 0);
            for (std::uint32_t p = 0; p < n; ++p) {
                const std::uint32_t x = i == 0 ? 0u : group.digits(p, a) >> (32 - i);
                const std::uint32_t y = j == 0 ? 0u : group.digits(p, b) >> (32 - j);
                ++count[(static_cast<std::size_t>(x) << j) | y];
            }
            for (int c : count) net = net && c == (1 << t);
        }
        if (net) return t;
    }
    return m;
}

TEST(ScrambledSobol, EveryDimensionIsStratifiedAndTheFirstPairIsAPerfectNet) {
    for (std::uint64_t g = 0; g < 20; ++g) {
        Rng rng(derive_seed(7, "test/stratified", g), 0);
        const ScrambledSobolGroup group(rng);
        for (int m = 1; m <= 10; ++m) {
            for (int d = 0; d < ScrambledSobolGroup::kDimensions; ++d) {
                std::vector<int> count(std::size_t{1} << m, 0);
                for (std::uint32_t p = 0; p < (1u << m); ++p)
                    ++count[group.digits(p, d) >> (32 - m)];
                for (int c : count) ASSERT_EQ(c, 1) << "dimension " << d << ", 2^" << m;
            }
            EXPECT_EQ(net_quality(group, m, 0, 1), 0) << "2^" << m;
            // Joe and Kuo's third and fourth dimensions form a (1, m, 2)-net from m = 2 on.
            // Joe and Kuo's third and fourth dimensions: a (t, m, 2)-net with t <= 2 (t = 1
            // from 2^5 points on), the boxes of 2^(t - m) holding 2^t points each.
            EXPECT_LE(net_quality(group, m, 2, 3), m >= 5 ? 1 : 2) << "2^" << m;
        }
    }
}

// Any one point of a group, over many groups, is uniform: a χ² over 64 bins, and the mean.
TEST(ScrambledSobol, EachPointIsUniformOverGroups) {
    const int groups = 64000, bins = 64;
    for (std::uint32_t index : {0u, 1u, 37u}) {
        for (int d = 0; d < ScrambledSobolGroup::kDimensions; ++d) {
            std::vector<int> count(bins, 0);
            double sum = 0.0;
            for (int g = 0; g < groups; ++g) {
                Rng rng(derive_seed(11, "test/stratified-uniform", static_cast<std::uint64_t>(d)),
                        static_cast<std::uint64_t>(g));
                const double u = ScrambledSobolGroup(rng).uniform(index, d);
                ASSERT_GE(u, 0.0);
                ASSERT_LT(u, 1.0);
                ++count[static_cast<std::size_t>(u * bins)];
                sum += u;
            }
            double chi2 = 0.0;
            const double expected = static_cast<double>(groups) / bins;
            for (int c : count) chi2 += (c - expected) * (c - expected) / expected;
            // 63 degrees of freedom: P(χ² > 120) ≈ 2e-5.
            EXPECT_LT(chi2, 120.0) << "point " << index << ", dimension " << d;
            // The mean of 64 000 uniforms: σ = 1/√(12 · 64 000) = 0.00114; 5σ.
            EXPECT_NEAR(sum / groups, 0.5, 0.0057) << "point " << index << ", dimension " << d;
        }
    }
}

// A pixel's highlight: the indicator of a disc of radius 0.6 in [0, 1]² (area 0.36 π / 4 exactly
// within the square). The mean of a group of 64 stratified points is unbiased, and its variance
// is well under that of 64 independent points, p(1 − p)/64.
TEST(ScrambledSobol, GroupMeanIsUnbiasedAndBeatsIndependentPointsOnAnEdge) {
    const double radius = 0.6, area = kPi * radius * radius / 4.0;
    const int groups = 20000;
    const std::uint32_t size = 64;
    double sum = 0.0, sum_sq = 0.0;
    for (int g = 0; g < groups; ++g) {
        Rng rng(derive_seed(3, "test/stratified-disc"), static_cast<std::uint64_t>(g));
        const ScrambledSobolGroup group(rng);
        int inside = 0;
        for (std::uint32_t p = 0; p < size; ++p) {
            const double x = group.uniform(p, 0), y = group.uniform(p, 1);
            inside += x * x + y * y < radius * radius ? 1 : 0;
        }
        const double mean = static_cast<double>(inside) / size;
        sum += mean;
        sum_sq += mean * mean;
    }
    const double mean = sum / groups;
    const double variance = (sum_sq / groups - mean * mean) * groups / (groups - 1.0);
    EXPECT_NEAR(mean, area, 5.0 * std::sqrt(variance / groups));
    const double independent = area * (1.0 - area) / size;
    // An edge's variance falls as 2^(-3m/2) (m = 6 here): about 8× below independent points.
    EXPECT_LT(variance, independent / 4.0)
        << "stratified " << variance << ", independent " << independent;
}

}  // namespace
}  // namespace plumage
