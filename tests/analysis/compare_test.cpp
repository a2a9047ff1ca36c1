// Record comparison against closed forms: two Lambertian plates.
#include "analysis/metrics/compare.h"

#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include "analysis/models/lambertian.h"
#include "common/error.h"
#include "sim/optics/colour.h"
#include "sim/scatterer/random.h"

namespace plumage::analysis {
namespace {

gonio::BrdfRecord measure(double albedo, std::vector<double> wavelengths) {
    gonio::GoniometerConfig c;
    c.pairs = gonio::filip2024_in_plane_pairs();
    c.wavelengths_nm = std::move(wavelengths);
    c.estimator = gonio::Estimator::eval;
    return gonio::measure_brdf(LambertianScatterer(albedo), c);
}

TEST(CompareRecords, LambertianPlatesDifferByTheClosedForms) {
    const std::vector<double> grid = {400.0, 450.0, 500.0, 550.0, 600.0, 650.0, 700.0};
    const auto a = measure(0.6, grid), b = measure(0.5, grid);
    const RecordComparison c = compare_records(a, b);
    EXPECT_NEAR(c.total.rmse, 0.1 / std::numbers::pi, 1e-12);
    EXPECT_NEAR(c.total.relative_l1, 0.2, 1e-12);
    EXPECT_NEAR(c.total.cosine_weighted_rmse, 0.1 / std::numbers::pi, 1e-12);
    ASSERT_EQ(c.lobes.size(), 1u);
    EXPECT_NEAR(c.lobes[0].second.relative_l1, 0.2, 1e-12);
    // Two greys of reflectance factor 0.6 and 0.5: ΔE00 from their L* alone.
    ASSERT_TRUE(c.colour_available);
    auto lab = [](double y) {
        const double f = std::cbrt(y);
        return optics::Lab{116.0 * f - 16.0, 0.0, 0.0};
    };
    EXPECT_NEAR(c.mean_delta_e00, optics::ciede2000(lab(0.5), lab(0.6)), 1e-9);
    EXPECT_EQ(c.worst.size(), 10u);
    EXPECT_NE(comparison_markdown(c, a, "a", "b").find("| diffuse |"), std::string::npos);
    // A record against itself: all zero.
    const RecordComparison same = compare_records(a, a);
    EXPECT_EQ(same.total.rmse, 0.0);
    EXPECT_EQ(same.max_delta_e00, 0.0);
}

// The noise floors are what a perfect model scores: a record of f plus normal noise of its
// stated σ, against f itself, shows L1 and ΔE00 at their floors (within the spread of a mean
// over 55 pairs × 7 wavelengths).
TEST(CompareRecords, APerfectModelScoresItsNoiseFloor) {
    const std::vector<double> grid = {400.0, 450.0, 500.0, 550.0, 600.0, 650.0, 700.0};
    const auto exact = measure(0.5, grid);
    auto noisy = exact;
    const double sigma = 0.02 * 0.5 / std::numbers::pi;  // 2 % of the value
    for (std::size_t i = 0; i < noisy.value.size(); ++i) {
        Rng rng(7, i);
        const double u1 = 1.0 - rng.uniform(), u2 = rng.uniform();
        noisy.value[i] +=
            sigma * std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * std::numbers::pi * u2);
        noisy.standard_error[i] = sigma;
    }
    std::fill(noisy.lobe_values.begin(), noisy.lobe_values.end(), 0.0);  // lobes: not under test
    noisy.estimator_used = gonio::Estimator::photon;  // a Monte Carlo record: its σ is noise
    const RecordComparison c = compare_records(noisy, exact);
    // Mean |N(0, σ)| over n = 385 cells: relative spread sqrt(π/2 − 1)/sqrt(n) = 3.9 %.
    EXPECT_NEAR(c.total.relative_l1_noise_floor, 0.02 * std::sqrt(2.0 / std::numbers::pi), 1e-6);
    EXPECT_NEAR(c.total.relative_l1 / c.total.relative_l1_noise_floor, 1.0, 4.0 * 0.039);
    EXPECT_NEAR(c.total.rmse / c.total.rmse_noise_floor, 1.0, 4.0 / std::sqrt(2.0 * 385.0));
    // ΔE00 of a grey with 2 % noise per wavelength: the mean over 55 pairs is within about
    // 30 % of the floor (the per-pair ΔE00 spreads about half its mean).
    EXPECT_GT(c.delta_e00_noise_floor, 0.0);
    EXPECT_NEAR(c.mean_delta_e00 / c.delta_e00_noise_floor, 1.0, 0.3);
}

// A cubature's error estimate is not noise: the same record with its σ as a cubature's (the
// eval estimator) has no floor at all, so a model's numerics cannot pass for noise.
TEST(CompareRecords, ACubaturesErrorIsNotNoise) {
    const std::vector<double> grid = {450.0, 550.0, 650.0};
    const auto exact = measure(0.5, grid);
    auto stated = exact;
    std::fill(stated.standard_error.begin(), stated.standard_error.end(), 0.01);
    stated.estimator_used = gonio::Estimator::eval;
    const RecordComparison cubature = compare_records(stated, exact);
    EXPECT_EQ(cubature.total.rmse_noise_floor, 0.0);
    EXPECT_EQ(cubature.total.relative_l1_noise_floor, 0.0);
    stated.estimator_used = gonio::Estimator::photon;
    EXPECT_GT(compare_records(stated, exact).total.rmse_noise_floor, 0.0);
}

TEST(CompareRecords, RefusesRecordsFromDifferentInstruments) {
    const auto a = measure(0.6, {550.0});
    auto b = measure(0.6, {550.0, 600.0});
    EXPECT_THROW(compare_records(a, b), InputError);
}

}  // namespace
}  // namespace plumage::analysis
