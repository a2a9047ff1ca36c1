// Physical optics in 2.5D (sim/wave/surface/physical_optics_25d.h): the BSDF's energy against the
// 2D row's reflected power, the tilt band, and the uniform sampler's weights.
#include "sim/wave/surface/physical_optics_25d.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <vector>

#include <gtest/gtest.h>
#include <omp.h>

#include "common/constants.h"
#include "common/error.h"
#include "tests/analysis/chi_square.h"
#include "tests/sim/wave/physical_optics_25d_test_util.h"
#include "virtual_gonio/direction_sets.h"
#include "virtual_gonio/goniometer.h"

namespace plumage::sim::wave {
namespace {

using po25d_test::direction;
using po25d_test::small_row;

constexpr double kLambda = 550.0;

// ∫ f |ω_o,z| dω_o over the sphere equals cos ε_i ∫σ_t dθ_o / (|ω_i,z| W), σ_t the 2D row's
// unpolarised reflected width at k cos ε_i (physical_optics_2d's scattering_width with
// cos_elevation). Quadrature: θ_o on N = 4 k R + 256 points of the circle (σ_t is a
// trigonometric polynomial of lower degree: exact), ε_o by the midpoint rule on 2000 points
// of a 1 rad band around the cone ε_o = −ε_i that contains the tilt band (checked: f = 0 at
// its ends); D_θ jumps at the band's edges, costing ~Δε/(band width) ≈ 0.2 %. Tolerance 1 %.
// Measured: −2.7e-4 (θ = 20°, ε = 15°) and −1.5e-5 (θ = −10°, ε = 30°).
TEST(PhysicalOptics25d, EnergyEqualsTheTwoDimensionalReflectedPower) {
    const PhysicalOptics25d model(small_row());
    for (const auto& [theta_deg, elevation_deg] :
         std::vector<std::pair<double, double>>{{20.0, 15.0}, {-10.0, 30.0}}) {
        const double ei = elevation_deg * kDeg;
        const Vec3d wi = direction(theta_deg * kDeg, ei);
        const double k = 2.0 * kPi / (1e-3 * kLambda);
        const int n_theta = static_cast<int>(std::ceil(4.0 * k * 8.0)) + 256;
        std::vector<double> theta(n_theta);
        for (int m = 0; m < n_theta; ++m) theta[m] = -kPi + 2.0 * kPi * (m + 1) / n_theta;
        // The 2D side from the public 2D API.
        Row2d row = small_row().row;
        PhysicalOpticsOptions reflected;
        reflected.part = FarFieldPart::reflected;
        double sigma_integral = 0.0;
        for (Polarisation2d pol : {Polarisation2d::te, Polarisation2d::tm}) {
            const std::vector<double> sigma = scattering_width(
                row, {kLambda, theta_deg * kDeg, pol, std::cos(ei)}, theta, reflected);
            for (double v : sigma) sigma_integral += 0.5 * v * 2.0 * kPi / n_theta;
        }
        const double expected =
            std::cos(ei) * sigma_integral / (std::abs(wi.z()) * model.patch_width_um());
        // The 2.5D side.
        constexpr int kElevations = 2000;
        const double band = 1.0, e0 = -ei - 0.5 * band, de = band / kElevations;
        double integral = 0.0, edge = 0.0;
        for (int m = 0; m < n_theta; ++m) {
            edge = std::max({edge, model.eval(wi, direction(theta[m], e0), kLambda),
                             model.eval(wi, direction(theta[m], e0 + band), kLambda)});
            for (int j = 0; j < kElevations; ++j) {
                const double e = e0 + (j + 0.5) * de;
                const Vec3d wo = direction(theta[m], e);
                integral += model.eval(wi, wo, kLambda) * std::abs(wo.z()) * std::cos(e) * de *
                            2.0 * kPi / n_theta;
            }
        }
        std::printf(
            "2.5D energy θ=%g° ε=%g°: ∫f|cos| dω = %.6f, 2D: %.6f, rel %.2e, "
            "(2D internal %.6f)\n",
            theta_deg, elevation_deg, integral, expected, integral / expected - 1.0,
            model.reflected_fraction_2d(wi, kLambda, n_theta));
        EXPECT_EQ(edge, 0.0);
        EXPECT_GT(expected, 0.0);
        EXPECT_NEAR(integral / expected, 1.0, 0.01);
    }
}

// The lobe sits on the cone ε_o = −ε_i widened by the tilt: nonzero on the cone in the
// specular transverse direction, zero once the half vector's longitudinal angle exceeds θ_d.
TEST(PhysicalOptics25d, LobeFollowsTheTiltBand) {
    const PhysicalOptics25d model(small_row());
    const double ei = 20.0 * kDeg;
    const Vec3d wi = direction(0.3, ei);
    // Transverse mirror of a cell at tilt μ = −0.35 about its top (normal azimuth 0.35).
    const double theta_o = 2.0 * 0.35 - 0.3;
    EXPECT_GT(model.eval(wi, direction(theta_o, -ei), kLambda), 0.0);
    // θ_h ≈ (ε_o + ε_i)/2 for small tilts: 2θ_d + margin away, nothing.
    EXPECT_EQ(model.eval(wi, direction(theta_o, -ei + 2.0 * 0.0785 + 0.05), kLambda), 0.0);
    EXPECT_EQ(model.eval(wi, direction(theta_o, -ei - 2.0 * 0.0785 - 0.05), kLambda), 0.0);
    EXPECT_THROW(PhysicalOptics25d([] {
                     auto p = small_row();
                     p.theta_d = 0.0;
                     return p;
                 }()),
                 InputError);
}

// sample(): uniform directions with weight f |ω_o,z| 4π, so the mean weight is the reflected
// fraction; 200 000 quanta, 4 standard errors (the lobe covers a small solid angle: the
// estimate is noisy, which is why eval() is the model's intended use). Measured: 0.0870 ±
// 0.0019 against 0.0855.
TEST(PhysicalOptics25d, SamplerWeightsAverageToTheReflectedFraction) {
    const PhysicalOptics25d model(small_row());
    const Vec3d wi = direction(20.0 * kDeg, 15.0 * kDeg);
    Rng rng(derive_seed(kDefaultSeed, "tests/physical_optics_25d/sampler"), 0);
    constexpr int kQuanta = 200000;
    double sum = 0.0, sum2 = 0.0;
    for (int i = 0; i < kQuanta; ++i) {
        const auto event = model.sample(wi, kLambda, Vec2::Zero(), rng);
        const double w = event ? event->weight : 0.0;
        sum += w;
        sum2 += w * w;
    }
    const double mean = sum / kQuanta;
    const double stderr_ = std::sqrt((sum2 / kQuanta - mean * mean) / kQuanta);
    const double expected = model.reflected_fraction_2d(wi, kLambda, 1200);
    std::printf("2.5D sampler: mean weight %.5f ± %.5f, 2D fraction %.5f\n", mean, stderr_,
                expected);
    EXPECT_NEAR(mean, expected, 4.0 * stderr_);
}

// Issue 36, acceptance 3: the importance sampler is unbiased, at three incidences (in the
// cross-section's plane, out of it, oblique) and three wavelengths:
//  - every weight is f |ω_o,z| / pdf at its ω_o (tests/analysis/chi_square.h's recipe), and the
//    mean weight is the energy identity's cos ε_i ∫σ_t dθ_o / (|ω_i,z| W) within 4 standard
//    errors (that recipe's own quadrature of eval() over the sphere is not used: its 64 polar
//    cells miss the 9°-wide tilt band by up to 3 % at the oblique incidence);
//  - the sampled directions follow pdf(): Pearson's χ² over 20 × 40 cells, Šidák over the
//    family, at the two incidences where the recipe's Gauss quadrature of pdf() (16 × 16 cells
//    of 5 × 5 nodes per bin) resolves the band; at (−50°, 5°) it loses 0.06 % of the mass near
//    the pole (two polar cells 3.4σ and 4.5σ under their expectation at 550 nm), which the
//    energy identity there (to 0.03 %) shows is the quadrature's, not the sampler's.
TEST(PhysicalOptics25d, SamplerDrawsItsPdfAndItsWeightsAreEval) {
    const PhysicalOptics25d model(small_row());
    const std::vector<Vec3d> incident{direction(0.0, 0.0), direction(20.0 * kDeg, 15.0 * kDeg),
                                      direction(-50.0 * kDeg, 5.0 * kDeg)};
    const std::vector<double> lambdas{450.0, 550.0, 650.0};
    int stream = 0;
    for (const double lambda : lambdas)
        for (std::size_t i = 0; i < incident.size(); ++i) {
            const Vec3d& wi = incident[i];
            if (i < 2) {
                plumage::testing::ChiSquareOptions chi;
                chi.samples = 100'000;
                chi.tests_in_family = 2 * static_cast<int>(lambdas.size());
                chi.stream = static_cast<std::uint64_t>(stream);
                chi.name = "physical_optics_25d";
                chi.quadrature_cells = 16;
                const auto result = plumage::testing::chi_square_test(model, wi, lambda, chi);
                EXPECT_TRUE(result.passed)
                    << lambda << " nm, wi " << wi.transpose() << ": " << result.summary();
            }
            plumage::testing::ConsistencyOptions consistency;
            consistency.samples = 50'000;
            consistency.stream = static_cast<std::uint64_t>(100 + stream++);
            const auto weights =
                plumage::testing::eval_pdf_consistency(model, wi, lambda, consistency);
            EXPECT_EQ(weights.weight_mismatches, 0) << weights.summary();
            const double energy = model.reflected_fraction_2d(wi, lambda, 4800);
            EXPECT_NEAR(weights.mc_mean, energy, 4.0 * weights.mc_standard_error)
                << lambda << " nm, wi " << wi.transpose() << ": " << weights.summary()
                << ", energy identity " << energy;
        }
}

}  // namespace
}  // namespace plumage::sim::wave

namespace plumage::sim::wave {
namespace {

// The instruments measure it like any other Scatterer: the goniometer's cubature estimator on
// the in-plane set in the cross-section's own plane (barb axis, φ = 0), the same bits on 1 and
// 2 threads (the per-thread cache of eval() must not leak between cells or threads), and a
// non-zero specular band.
TEST(PhysicalOptics25d, GoniometerMeasuresItTheSameOnOneAndTwoThreads) {
    const PhysicalOptics25d model(small_row());
    gonio::GoniometerConfig c;
    c.pairs = gonio::filip2024_in_plane_pairs(0.0);
    c.wavelengths_nm = {450.0, 650.0};
    c.detector_half_angle_rad = 5.0 * kDeg;
    c.estimator = gonio::Estimator::eval;
    c.eval_rings = 2;
    const int saved = omp_get_max_threads();
    omp_set_num_threads(1);
    const gonio::BrdfRecord one = gonio::measure_brdf(model, c);
    omp_set_num_threads(2);
    const gonio::BrdfRecord two = gonio::measure_brdf(model, c);
    omp_set_num_threads(saved);
    ASSERT_EQ(one.value.size(), two.value.size());
    EXPECT_EQ(0,
              std::memcmp(one.value.data(), two.value.data(), one.value.size() * sizeof(double)));
    double largest = 0.0;
    for (double v : one.value) {
        EXPECT_TRUE(std::isfinite(v) && v >= 0.0);
        largest = std::max(largest, v);
    }
    EXPECT_GT(largest, 0.0);
}

}  // namespace
}  // namespace plumage::sim::wave
