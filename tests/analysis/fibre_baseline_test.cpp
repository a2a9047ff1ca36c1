// The Marschner-style fibre baseline (analysis/models/fibre_baseline.h) and its shared lobe
// machinery: normal quantile, truncated longitudinal Gaussian, azimuthal tables against Marschner's
// closed form, then the tests every sampled Scatterer gets (chi-square, eval/pdf consistency,
// energy, reciprocity — which this model does not have, shown and explained).
#include "analysis/models/fibre_baseline.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "analysis/metrics/energy.h"
#include "common/constants.h"
#include "common/error.h"
#include "sim/optics/fresnel.h"
#include "tests/analysis/chi_square.h"
#include "tests/test_util.h"

namespace plumage::analysis {
namespace {

Vec3d dir(double theta, double phi) {
    return {std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)};
}

bool contains(const std::string& text, const std::string& part) {
    return text.find(part) != std::string::npos;
}

// Light from the pole, oblique, steep, grazing, and from below the patch.
const std::vector<Vec3d> kIncident = {
    dir(0.0, 0.0), dir(35.0 * kDeg, 40.0 * kDeg), dir(60.0 * kDeg, 200.0 * kDeg),
    dir(80.0 * kDeg, 300.0 * kDeg), dir(125.0 * kDeg, 70.0 * kDeg)};

TEST(FibreBaseline, NormalQuantileInvertsTheCdf) {
    for (double p : {1e-300, 1e-100, 1e-20, 1e-8, 0.001, 0.02425, 0.1, 0.3, 0.5, 0.7, 0.97575,
                     0.999, 1 - 1e-9}) {
        const double x = normal_quantile(p);
        const double back = 0.5 * std::erfc(-x / std::numbers::sqrt2);
        EXPECT_NEAR(back, p, 1e-13 * p + 1e-16) << p;
    }
    EXPECT_EQ(normal_quantile(0.5), 0.0);
}

TEST(FibreBaseline, LongitudinalLobeIsNormalisedAndSampledExactly) {
    using plumage::testing::chi_square_p_value;
    struct Case {
        double theta_i, alpha, beta;
    };
    // Centred, shifted, cut by the pole, and far beyond it (the exponential-tail sampler).
    const std::vector<Case> cases = {{0.0, -0.0873, 0.131}, {1.2, 0.3, 0.05},
                                     {-1.5, -0.2, 0.2},     {1.5, -0.35, 0.01},
                                     {-1.5707, 0.35, 0.01}, {0.4, 0.0, 0.5}};
    constexpr int kBins = 40;
    constexpr int kSamples = 200'000;
    std::uint64_t stream = 10;
    for (const Case& c : cases) {
        const LongitudinalLobe lobe(c.theta_i, c.alpha, c.beta);
        // ∫ density over [−π/2, π/2] by composite Simpson on a grid fine against σ.
        const int n = 200'000;
        const double h = kPi / n;
        double integral = lobe.density(-0.5 * kPi) + lobe.density(0.5 * kPi);
        for (int k = 1; k < n; ++k)
            integral += (k % 2 ? 4.0 : 2.0) * lobe.density(-0.5 * kPi + k * h);
        integral *= h / 3.0;
        EXPECT_NEAR(integral, 1.0, 1e-6) << c.theta_i << " " << c.alpha << " " << c.beta;
        // Sampling against the density: Pearson over bins of θo, expected by Simpson per bin.
        Rng rng(kDefaultSeed, stream++);
        std::array<double, kBins> observed{};
        for (int k = 0; k < kSamples; ++k) {
            const double t = lobe.sample(rng);
            ASSERT_GE(t, -0.5 * kPi);
            ASSERT_LE(t, 0.5 * kPi);
            observed[std::clamp(static_cast<int>((t + 0.5 * kPi) / kPi * kBins), 0, kBins - 1)] +=
                1.0;
        }
        double statistic = 0.0;
        int dof = -1;
        double pooled_o = 0.0, pooled_e = 0.0;
        for (int b = 0; b < kBins; ++b) {
            const double lo = -0.5 * kPi + b * kPi / kBins;
            const int m = 2000;
            const double hb = kPi / kBins / m;
            double e = lobe.density(lo) + lobe.density(lo + kPi / kBins);
            for (int k = 1; k < m; ++k) e += (k % 2 ? 4.0 : 2.0) * lobe.density(lo + k * hb);
            e *= hb / 3.0 * kSamples;
            if (e < 5.0) {
                pooled_o += observed[b];
                pooled_e += e;
                continue;
            }
            statistic += (observed[b] - e) * (observed[b] - e) / e;
            ++dof;
        }
        if (pooled_e >= 5.0) {
            statistic += (pooled_o - pooled_e) * (pooled_o - pooled_e) / pooled_e;
            ++dof;
        }
        const double p = dof > 0 ? chi_square_p_value(statistic, dof) : 1.0;
        EXPECT_GT(p, plumage::testing::sidak_significance(0.01, static_cast<int>(cases.size())))
            << c.theta_i << " " << c.alpha << " " << c.beta << ": chi2 " << statistic << " dof "
            << dof;
    }
}

// Marschner's closed form for R: one root h = −sin(φ/2), |dh/dφ| = cos(φ/2)/2, so
// N_R(φ) = ½ F(cos θi cos(φ/2)) cos(φ/2)/2; smoothed by the same Gaussian, averaged over each bin.
TEST(FibreBaseline, AzimuthalTablesMatchMarschnersClosedForm) {
    const double eta = 1.55, roughness = 0.15;
    for (double theta_i : {0.0, 0.5, 1.2}) {
        FibreAzimuthalScattering table;
        circular_fibre_azimuthal(eta, 0.02, 30.0, std::sin(theta_i), roughness, 512, table);
        auto closed_r = [&](double phi) {
            const double c = std::cos(0.5 * phi);
            if (c <= 0.0) return 0.0;
            const double f =
                optics::fresnel_intensities_unpolarised(1.0, eta, std::cos(theta_i) * c)
                    .reflectance;
            return 0.25 * f * c;
        };
        // Continuous convolution on a fine grid (wrapped), then bin averages.
        const int fine = 7200;
        const double d = 2.0 * kPi / fine;
        std::vector<double> raw(fine), smooth(fine, 0.0);
        for (int k = 0; k < fine; ++k) raw[k] = closed_r(-kPi + (k + 0.5) * d);
        const int reach = static_cast<int>(6.0 * roughness / d);
        for (int k = 0; k < fine; ++k) {
            for (int j = -reach; j <= reach; ++j) {
                const double g = std::exp(-0.5 * std::pow(j * d / roughness, 2)) /
                                 (std::sqrt(2.0 * kPi) * roughness);
                smooth[((k + j) % fine + fine) % fine] += raw[k] * g * d;
            }
        }
        double peak = 0.0, worst = 0.0, mass = 0.0;
        const int per_bin = fine / AzimuthalTable::kBins;
        for (int b = 0; b < AzimuthalTable::kBins; ++b) {
            double avg = 0.0;
            for (int k = 0; k < per_bin; ++k) avg += smooth[b * per_bin + k] / per_bin;
            const double psi = -kPi + (b + 0.5) * AzimuthalTable::bin_width();
            peak = std::max(peak, avg);
            worst = std::max(worst, std::abs(table.lobes[kFibreR].density(psi) - avg));
            mass += avg * AzimuthalTable::bin_width();
        }
        EXPECT_LT(worst, 5e-3 * peak) << "θi " << theta_i << ": closed form vs offset quadrature";
        EXPECT_NEAR(table.lobes[kFibreR].mass(), mass, 1e-4);
        std::printf(
            "[ info ] R lobe θi %.1f: max |table − closed form| %.2e of peak %.4f, mass %.6f\n",
            theta_i, worst, peak, table.lobes[kFibreR].mass());

        // Lobe masses against ½ ∫ A_p(h) dh by the trapezoid rule directly in h (another route).
        const double s = std::sin(theta_i), ct = std::cos(theta_i);
        const double eta_p = std::sqrt(eta * eta - s * s) / ct,
                     ctt = std::sqrt(1.0 - s * s / (eta * eta));
        std::array<double, 3> masses{};
        const int n = 400'000;
        for (int k = 0; k <= n; ++k) {
            const double h = -1.0 + 2.0 * k / n;
            const double w = (k == 0 || k == n ? 0.5 : 1.0) * (2.0 / n) * 0.5;
            const double cg = std::sqrt(std::max(0.0, 1.0 - h * h));
            const double f = optics::fresnel_intensities_unpolarised(1.0, eta, ct * cg).reflectance;
            const double t =
                std::exp(-0.02 * 30.0 * std::sqrt(1.0 - h * h / (eta_p * eta_p)) / ctt);
            masses[0] += w * f;
            masses[1] += w * (1 - f) * (1 - f) * t;
            masses[2] += w * (1 - f) * (1 - f) * f * t * t;
        }
        for (int p = 0; p < 3; ++p)
            EXPECT_NEAR(table.lobes[p].mass(), masses[p], 2e-5) << "lobe " << p;
        // The circle is symmetric: N(φ) = N(−φ).
        for (int p = 0; p < 3; ++p) {
            for (int b = 0; b < AzimuthalTable::kBins; ++b) {
                EXPECT_NEAR(table.lobes[p].bin_mass(b),
                            table.lobes[p].bin_mass(AzimuthalTable::kBins - 1 - b), 1e-15);
            }
        }
    }
}

TEST(FibreBaseline, SamplingPassesChiSquare) {
    using namespace plumage::testing;
    const FibreBaselineBsdf model({});
    for (std::size_t d = 0; d < kIncident.size(); ++d) {
        ChiSquareOptions options;
        options.tests_in_family = static_cast<int>(kIncident.size());
        options.stream = 400 + d;
        options.name = "fibre_baseline";
        const auto result = chi_square_test(model, kIncident[d], 550.0, options);
        EXPECT_TRUE(result.passed) << "direction " << d << ": " << result.summary();
        const auto a = model.lobe_albedos(kIncident[d]);
        EXPECT_NEAR(result.density_mass, a[0] + a[1] + a[2], 2e-3);
        RecordProperty("chi_square_p_wi" + std::to_string(d), std::to_string(result.p_value));
        std::printf("[ info ] chi-square fibre baseline wi %zu: %s\n", d, result.summary().c_str());
    }
}

TEST(FibreBaseline, SampleWeightsAgreeWithEvalAndPdf) {
    using namespace plumage::testing;
    const FibreBaselineBsdf model({});
    for (std::size_t d = 0; d < kIncident.size(); ++d) {
        ConsistencyOptions options;
        options.stream = 500 + d;
        options.samples = 100'000;
        options.polar_cells = 48;
        const auto result = eval_pdf_consistency(model, kIncident[d], 550.0, options);
        EXPECT_TRUE(result.agrees) << "direction " << d << ": " << result.summary();
        std::printf("[ info ] consistency fibre baseline wi %zu: %s\n", d,
                    result.summary().c_str());
    }
}

TEST(FibreBaseline, AlbedoIsTheSumOfLobeAlbedosAndAtMostOne) {
    // Lossless interior: what is missing from 1 is only the paths beyond TRT.
    for (double absorption : {0.0, 0.01}) {
        FibreBaselineParams p;
        p.absorption_per_um = absorption;
        const FibreBaselineBsdf model(p);
        const auto grid = hemisphere_grid(15.0 * kDeg, 75.0 * kDeg, 60.0 * kDeg);
        const std::array<double, 1> lambdas = {550.0};
        const EnergyCheck check = check_energy(model, grid, lambdas, 32);
        EXPECT_FALSE(check.violates()) << check.max_albedo;
        EXPECT_LE(check.max_albedo, 1.0);
        double worst = 0.0;
        for (const Vec3d& wi : grid) {
            const auto a = model.lobe_albedos(wi);
            const AlbedoEstimate q = directional_albedo(model, wi, 550.0, 32);
            EXPECT_NEAR(q.value, a[0] + a[1] + a[2], q.error_estimate + 2e-3) << wi.transpose();
            worst = std::max(worst, std::abs(q.value - a[0] - a[1] - a[2]));
        }
        RecordProperty("max_albedo_absorption_" + std::to_string(absorption),
                       std::to_string(check.max_albedo));
        std::printf(
            "[ info ] energy fibre baseline σa = %.2f/um: max albedo %.4f (±%.1e), quadrature vs "
            "lobe sum "
            "%.1e\n",
            absorption, check.max_albedo, check.error_estimate, worst);
    }
}

TEST(FibreBaseline, IsNotReciprocalExceptThroughTheProjectionOnTheCone) {
    const FibreBaselineBsdf model({});
    const FibreFrame& f = FibreBaselineBsdf::frame();
    // General pairs: the normalisation per θi, η'(θi) and the outgoing solid angle break symmetry.
    double largest = 0.0;
    Rng rng(kDefaultSeed, 600);
    for (int k = 0; k < 400; ++k) {
        const Vec3d wi = dir(std::acos(rng.uniform()), 2.0 * kPi * rng.uniform());
        const Vec3d wo = dir(std::acos(rng.uniform()), 2.0 * kPi * rng.uniform());
        const double a = model.eval(wi, wo, 550.0), b = model.eval(wo, wi, 550.0);
        if (a + b > 1e-3) largest = std::max(largest, std::abs(a - b) / (0.5 * (a + b)));
    }
    RecordProperty("max_relative_asymmetry", std::to_string(largest));
    std::printf("[ info ] fibre baseline: largest |f(wi,wo) − f(wo,wi)| / mean = %.3f\n", largest);
    EXPECT_GT(largest, 0.1) << "the model should not be reciprocal";
    // On the cone θo = θi everything but the patch projection is symmetric (N is even for a
    // circle): f(ωi, ωo) |ωo·z| = f(ωo, ωi) |ωi·z|.
    for (double theta : {-0.6, 0.0, 0.3, 0.9}) {
        for (double psi_i : {0.2, 1.0, 2.5}) {
            for (double psi_o : {-2.0, 0.7, 2.9}) {
                const Vec3d wi = f.direction(theta, psi_i), wo = f.direction(theta, psi_o);
                const double a = model.eval(wi, wo, 550.0) * std::abs(wo.z());
                const double b = model.eval(wo, wi, 550.0) * std::abs(wi.z());
                EXPECT_NEAR(a, b, 1e-9 * std::max(a, b) + 1e-300)
                    << theta << " " << psi_i << " " << psi_o;
            }
        }
    }
}

TEST(FibreBaseline, FiniteAndNonNegativeForAwkwardDirections) {
    const auto model = FibreBaselineBsdf({});
    plumage::testing::expect_finite_everywhere(model);
}

TEST(FibreBaseline, RejectsBadParameters) {
    using plumage::testing::input_error_message;
    auto message = [](auto modify) {
        return input_error_message([&] {
            FibreBaselineParams p;
            modify(p);
            FibreBaselineBsdf m(p);
        });
    };
    std::string m = message([](FibreBaselineParams& p) { p.eta = 0.9; });
    EXPECT_TRUE(contains(m, "fibre baseline: eta = 0.9: expected a value in [1.01, 3]")) << m;
    m = message([](FibreBaselineParams& p) { p.beta_r_rad = 0.0; });
    EXPECT_TRUE(contains(m, "beta_r_rad = 0: expected a value in [0.01, 0.5] (rad)")) << m;
    m = message([](FibreBaselineParams& p) { p.alpha_r_rad = 1.0; });
    EXPECT_TRUE(contains(m, "alpha_r_rad = 1: expected a value in [-0.35, 0.35] (rad)")) << m;
    m = message([](FibreBaselineParams& p) { p.absorption_per_um = -1.0; });
    EXPECT_TRUE(contains(m, "absorption_per_um = -1: expected a value in [0, 10] (1/um)")) << m;
    m = message([](FibreBaselineParams& p) { p.azimuthal_roughness_rad = 0.01; });
    EXPECT_TRUE(contains(m, "azimuthal_roughness_rad = 0.01: expected a value in [0.03, 1.5]"))
        << m;
    m = message([](FibreBaselineParams& p) { p.offsets = 4; });
    EXPECT_TRUE(contains(m, "offsets = 4: expected an integer in [16, 65536]")) << m;
    m = message([](FibreBaselineParams& p) { p.diameter_um = std::nan(""); });
    EXPECT_TRUE(contains(m, "diameter_um = nan")) << m;
    EXPECT_EQ(message([](FibreBaselineParams&) {}), "no InputError");
    const FibreBaselineBsdf model({});
    m = input_error_message([&] { model.eval(Vec3d::UnitZ(), Vec3d::UnitZ(), -5.0); });
    EXPECT_TRUE(contains(m, "wavelength = -5 nm: expected a finite value > 0")) << m;
}

}  // namespace
}  // namespace plumage::analysis
