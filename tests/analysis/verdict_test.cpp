// The report's verdict (analysis/metrics/verdict.h): a test record 5 % above its reference at 10σ
// per cell differs (and says by how much), one equal to it within its noise agrees, and the
// reference's own error is stated beside the verdict without entering its floor.
#include "analysis/metrics/verdict.h"

#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

namespace plumage::analysis {
namespace {

struct Pair {
    std::vector<double> test, sigma, reference;
};

// 2000 cells of a smooth reference (values 1 … 3), σ = `relative_sigma` of the value, the test
// = reference × (1 + offset) + noise drawn from a fixed stream.
Pair pair(double offset, double relative_sigma, bool noisy, std::size_t cells = 2000) {
    Pair p;
    std::mt19937_64 stream(20261128);
    std::normal_distribution<double> normal;
    for (std::size_t c = 0; c < cells; ++c) {
        const double ref = 2.0 + std::sin(0.01 * static_cast<double>(c));
        const double s = relative_sigma * ref;
        p.reference.push_back(ref);
        p.sigma.push_back(s);
        p.test.push_back(ref * (1.0 + offset) + (noisy ? s * normal(stream) : 0.0));
    }
    return p;
}

TEST(Verdict, FivePercentAtTenSigmaDiffers) {
    const Pair p = pair(0.05, 0.005, true);  // 5 % offset, σ 0.5 %: 10σ per cell
    const AgreementVerdict v = agreement(p.test, p.sigma, p.reference);
    EXPECT_EQ(v.verdict, "differs");
    EXPECT_EQ(v.cells, 2000u);
    EXPECT_LT(v.p_value, 1e-15);
    EXPECT_NEAR(v.rms_z, 10.0, 0.2);  // sqrt(100 + 1)
    EXPECT_GT(v.beyond_3_sigma, 0.99);
    EXPECT_NEAR(v.power_difference, 0.05, 5.0 * v.power_difference_sigma);
    EXPECT_NEAR(v.power_difference_sigma, 0.005 / std::sqrt(2000.0) * 1.03, 2e-5);
}

TEST(Verdict, EqualWithinNoiseAgrees) {
    const Pair p = pair(0.0, 0.05, true);
    const AgreementVerdict v = agreement(p.test, p.sigma, p.reference);
    EXPECT_EQ(v.verdict, "agrees");
    EXPECT_GE(v.p_value, 0.01);
    EXPECT_NEAR(v.rms_z, 1.0, 0.05);  // sqrt(χ²_2000 / 2000): σ 0.016
    EXPECT_LT(v.beyond_3_sigma, 0.01);
    EXPECT_LT(std::abs(v.power_difference), 4.0 * v.power_difference_sigma);
}

// Every cell shifted by 0.4 % under σ = 5 % per cell, 2000 cells: χ² grows by about
// 2000 · 0.08² ≈ 13 over its 2000 ± 63 (invisible), the power difference is 3.5 of its σ: the power
// test sees it, and the verdict's p is twice its p.
TEST(Verdict, ACoherentShiftIsSeenByThePowerTest) {
    const Pair p = pair(0.004, 0.05, true);  // 0.4 % shift, σ 5 % per cell, 2000 cells
    const AgreementVerdict v = agreement(p.test, p.sigma, p.reference);
    EXPECT_GT(v.chi_square_p, 0.01);
    EXPECT_LT(v.power_p, v.chi_square_p);
    EXPECT_EQ(v.p_value, std::min(1.0, 2.0 * v.power_p));
}

TEST(Verdict, MaskAndReferenceErrorAreHonoured) {
    Pair p = pair(0.05, 0.005, true, 100);
    std::vector<std::uint8_t> use(100, 0);  // only the first ten cells, made equal
    for (std::size_t c = 0; c < 10; ++c) use[c] = 1, p.test[c] = p.reference[c];
    std::vector<double> cubature(100);
    for (std::size_t c = 0; c < 100; ++c) cubature[c] = 0.03 * p.reference[c];  // 3 %: not noise
    const AgreementVerdict v = agreement(p.test, p.sigma, p.reference, cubature, use);
    EXPECT_EQ(v.cells, 10u);
    EXPECT_EQ(v.verdict, "agrees");  // the model's 3 % does not widen the floor ...
    EXPECT_NEAR(v.reference_error, 0.03, 1e-12);
    EXPECT_FALSE(v.reference_converged);  // ... it is stated: over 1 %
    const std::vector<std::uint8_t> none(100, 0);
    EXPECT_EQ(agreement(p.test, p.sigma, p.reference, {}, none).verdict, "no cells");
}

}  // namespace
}  // namespace plumage::analysis
