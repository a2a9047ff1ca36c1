// Error against run time: the power-law fit against exact power laws, and the χ² of an
// estimate against its reference under the hypothesis it tests (normal errors of size σ).
#include "analysis/metrics/convergence.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <vector>

#include "sim/scatterer/random.h"

namespace plumage::analysis {
namespace {

TEST(FitPowerLaw, RecoversAnExactPowerLaw) {
    const std::vector<double> t = {1.0, 2.0, 4.0, 8.0, 16.0};
    std::vector<double> e;
    for (double x : t) e.push_back(0.3 * std::pow(x, -0.5));
    const PowerLawFit fit = fit_power_law(t, e);
    EXPECT_EQ(fit.points, 5);
    EXPECT_NEAR(fit.exponent, -0.5, 1e-12);
    EXPECT_NEAR(fit.prefactor, 0.3, 1e-12);
    EXPECT_NEAR(fit.exponent_standard_error, 0.0, 1e-12);
}

TEST(FitPowerLaw, LeavesOutNonPositivePointsAndSaysWhenItCannotFit) {
    const std::vector<double> t = {0.0, 1.0, 10.0, 100.0};
    const std::vector<double> e = {1.0, 2.0, 20.0, -1.0};  // slope 1 through the valid two
    const PowerLawFit fit = fit_power_law(t, e);
    EXPECT_EQ(fit.points, 2);
    EXPECT_NEAR(fit.exponent, 1.0, 1e-12);
    const std::vector<double> one_t = {1.0}, one_e = {1.0};
    EXPECT_TRUE(std::isnan(fit_power_law(one_t, one_e).exponent));
}

// Values drawn as ref + N(0, σ): the χ² p-value is uniform, so over many independent trials
// the fraction below 0.05 is 0.05 within its binomial error; and the true RMS matches the
// estimated one on average.
TEST(ErrorAgainstReference, ChiSquareIsCalibratedForNormalErrorsOfTheStatedSize) {
    constexpr int kTrials = 2000, kCells = 40;
    int rejected = 0;
    double ratio_sum = 0.0;
    for (int trial = 0; trial < kTrials; ++trial) {
        std::vector<double> value, sigma, ref, ref_err;
        for (int k = 0; k < kCells; ++k) {
            Rng rng(20261125, static_cast<std::uint64_t>(trial) * kCells + k);
            const double r = 1.0 + k, s = 0.05 * r, eps = 0.01 * r;
            // Box–Muller, with the reference's own error in the variance as the test assumes.
            const double u1 = 1.0 - rng.uniform(), u2 = rng.uniform();
            const double z = std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * std::numbers::pi * u2);
            value.push_back(r + std::hypot(s, eps) * z);
            sigma.push_back(s);
            ref.push_back(r);
            ref_err.push_back(eps);
        }
        const ErrorAgainstReference e = error_against_reference(value, sigma, ref, ref_err);
        ASSERT_EQ(e.cells, kCells);
        EXPECT_NEAR(e.estimated, 0.05, 1e-12);
        EXPECT_NEAR(e.reference_floor, 0.01, 1e-12);
        if (e.p_value < 0.05) ++rejected;
        ratio_sum += e.true_error * e.true_error / (0.05 * 0.05 + 0.01 * 0.01);
    }
    const double rate = static_cast<double>(rejected) / kTrials;
    const double binomial_sigma = std::sqrt(0.05 * 0.95 / kTrials);
    EXPECT_NEAR(rate, 0.05, 4.0 * binomial_sigma);
    // mean of χ²_n / n is 1 with standard error sqrt(2/n)/sqrt(trials)
    EXPECT_NEAR(ratio_sum / kTrials, 1.0, 4.0 * std::sqrt(2.0 / kCells / kTrials));
}

TEST(ErrorAgainstReference, LeavesOutCellsWithoutSignalOrError) {
    const std::vector<double> value = {1.1, 5.0, 2.0}, sigma = {0.1, 1.0, 0.0},
                              ref = {1.0, 0.0, 2.0}, ref_err = {0.0, 0.0, 0.0};
    const ErrorAgainstReference e = error_against_reference(value, sigma, ref, ref_err);
    EXPECT_EQ(e.cells, 1);
    EXPECT_NEAR(e.true_error, 0.1, 1e-12);
    EXPECT_NEAR(e.chi_square, 1.0, 1e-12);
}

}  // namespace
}  // namespace plumage::analysis
