// The Padrón-Griffe 2024 surface feather BSDF (analysis/models/padrongriffe2024.h): its elliptical
// cross-section trace against closed forms, then the tests every sampled Scatterer gets
// (chi-square, eval/pdf consistency, energy, reciprocity — which it does not have, shown lobe by
// lobe), the masking weights, and parameter checks.
#include "analysis/models/padrongriffe2024.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
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

using Bsdf = PadronGriffe2024Bsdf;

Vec3d dir(double theta, double phi) {
    return {std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)};
}

bool contains(const std::string& text, const std::string& part) {
    return text.find(part) != std::string::npos;
}

// Light from the pole, across the barbs, along the barbs, grazing, and from below the vane.
const std::vector<Vec3d> kIncident = {
    dir(0.0, 0.0), dir(40.0 * kDeg, 75.0 * kDeg), dir(55.0 * kDeg, 190.0 * kDeg),
    dir(78.0 * kDeg, 280.0 * kDeg), dir(130.0 * kDeg, 100.0 * kDeg)};
const std::array<double, 5> kWavelengths = {550.0, 450.0, 650.0, 500.0, 600.0};

bool is_t_lobe(const ScatterEvent& e) { return e.lobe == Bsdf::kT; }

TEST(PadronGriffe2024Bsdf, EllipticalTraceReducesToTheCircularClosedForm) {
    // Eccentricity 0, no medulla: the 2D ray trace (intersections, normals, 2D Snell with η',
    // 3D Fresnel) must give the baseline's closed-form Φ_p(h), A_p(h), bin by bin.
    for (double theta_i : {0.0, 0.4, -1.1}) {
        FibreAzimuthalScattering circle, ellipse;
        circular_fibre_azimuthal(1.55, 0.03, 30.0, std::sin(theta_i), 0.1, 256, circle);
        EllipticalCrossSection round;
        round.up_semi_axis_um = round.side_semi_axis_um = 15.0;
        round.rotation_rad = 0.7;  // irrelevant for a circle
        elliptical_fibre_azimuthal(round, 1.55, 0.03, 1.0, std::sin(theta_i), 0.0, 0.1, 256,
                                   ellipse);
        EXPECT_EQ(ellipse.medulla, 0.0);
        for (int p = 0; p < 3; ++p) {
            double peak = 0.0, worst = 0.0;
            for (int b = 0; b < AzimuthalTable::kBins; ++b) {
                peak = std::max(peak, circle.lobes[p].bin_mass(b));
                worst = std::max(
                    worst, std::abs(circle.lobes[p].bin_mass(b) - ellipse.lobes[p].bin_mass(b)));
            }
            EXPECT_LT(worst, 1e-10 * peak) << "lobe " << p << " θi " << theta_i;
            EXPECT_NEAR(circle.lobes[p].mass(), ellipse.lobes[p].mass(), 1e-12);
        }
        // Rotating the incident azimuth rotates a circle's tables and keeps their masses.
        elliptical_fibre_azimuthal(round, 1.55, 0.03, 1.0, std::sin(theta_i), 1.3, 0.1, 256,
                                   ellipse);
        for (int p = 0; p < 3; ++p)
            EXPECT_NEAR(circle.lobes[p].mass(), ellipse.lobes[p].mass(), 1e-12);
    }
}

TEST(PadronGriffe2024Bsdf, EllipticalReflectionAndMedullaMatchIndependentIntegrals) {
    const double eta = 1.55;
    // R mass of an ellipse = ∫ F(cos θi n·l) (n·l) ds / (2W) over the lit boundary, with the arc
    // length ds = ρ(φ) dφ in the normal-angle parameterisation (ρ = A²B²/(A² sin²φ + B²
    // cos²φ)^{3/2}).
    for (double rotation : {0.0, 0.6}) {
        for (double psi_i : {0.0, 1.0, 2.4}) {
            for (double theta_i : {0.0, 0.7}) {
                EllipticalCrossSection e;
                e.up_semi_axis_um = 15.0;
                e.side_semi_axis_um = 6.0;
                e.rotation_rad = rotation;
                FibreAzimuthalScattering out;
                elliptical_fibre_azimuthal(e, eta, 0.0, 1.0, std::sin(theta_i), psi_i, 0.1, 4096,
                                           out);
                const double a = e.up_semi_axis_um, b = e.side_semi_axis_um;
                // In the ellipse's own axes (major along `up` rotated by `rotation`), the light
                // direction l has in-frame angle psi_i − rotation from the major axis.
                const double lpsi = psi_i - rotation;
                const double lx = std::sin(lpsi), lz = std::cos(lpsi);  // (minor, major) components
                const int n = 200'000;
                double integral = 0.0;
                for (int k = 0; k < n; ++k) {
                    const double phi = -kPi + (k + 0.5) * 2.0 * kPi /
                                                  n;  // normal (sin φ, cos φ) in (minor, major)
                    const double cos_nl = std::sin(phi) * lx + std::cos(phi) * lz;
                    if (cos_nl <= 0.0) continue;
                    // Arc along the minor axis x with semi-axis b, major z with a.
                    const double rho = a * a * b * b /
                                       std::pow(b * b * std::sin(phi) * std::sin(phi) +
                                                    a * a * std::cos(phi) * std::cos(phi),
                                                1.5);
                    const double f = optics::fresnel_intensities_unpolarised(
                                         1.0, eta, std::cos(theta_i) * cos_nl)
                                         .reflectance;
                    integral += f * cos_nl * rho * 2.0 * kPi / n;
                }
                const double width = 2.0 * std::hypot(a * lx, b * lz);  // support across l, doubled
                EXPECT_NEAR(out.lobes[kFibreR].mass(), integral / width, 2e-5)
                    << rotation << " " << psi_i << " " << theta_i;
                // Lossless interior: every quantum is reflected, leaves after 0–2 internal
                // reflections, or is still inside (lost beyond TRT): the total stays <= 1.
                EXPECT_LE(out.lobes[0].mass() + out.lobes[1].mass() + out.lobes[2].mass(), 1.0);
            }
        }
    }
    // A concentric medulla of radius r in a circle of radius R: the refracted chord at offset h
    // passes the centre at distance R h / η', so it meets the medulla iff |h| < η' r / R. With no
    // absorption and albedo 1, the medulla takes ½ ∫ (1 − F) dh over that range.
    for (double theta_i : {0.0, 0.5}) {
        EllipticalCrossSection c;
        c.up_semi_axis_um = c.side_semi_axis_um = 15.0;
        c.medulla_scale = 0.5;
        FibreAzimuthalScattering out;
        elliptical_fibre_azimuthal(c, eta, 0.0, 1.0, std::sin(theta_i), 0.3, 0.1, 8192, out);
        const double s = std::sin(theta_i), ct = std::cos(theta_i);
        const double eta_p = std::sqrt(eta * eta - s * s) / ct;
        const double reach = std::min(1.0, eta_p * 0.5);
        const int n = 400'000;
        double expected = 0.0;
        for (int k = 0; k < n; ++k) {
            const double h = -reach + (k + 0.5) * 2.0 * reach / n;
            const double f =
                optics::fresnel_intensities_unpolarised(1.0, eta, ct * std::sqrt(1.0 - h * h))
                    .reflectance;
            expected += 0.5 * (1.0 - f) * 2.0 * reach / n;
        }
        EXPECT_NEAR(out.medulla, expected, 5e-4) << theta_i;
        std::printf("[ info ] concentric medulla θi %.1f: traced %.5f, closed form %.5f\n", theta_i,
                    out.medulla, expected);
    }
}

TEST(PadronGriffe2024Bsdf, SamplingPassesChiSquare) {
    using namespace plumage::testing;
    const Bsdf model({});
    for (std::size_t d = 0; d < kIncident.size(); ++d) {
        ChiSquareOptions options;
        options.tests_in_family = static_cast<int>(kIncident.size());
        options.stream = 700 + d;
        options.name = "padrongriffe2024";
        options.outside_density = is_t_lobe;
        const auto result = chi_square_test(model, kIncident[d], kWavelengths[d], options);
        EXPECT_TRUE(result.passed) << "direction " << d << ": " << result.summary();
        EXPECT_NEAR(result.density_mass, model.albedo(kIncident[d], kWavelengths[d]), 2e-3);
        RecordProperty("chi_square_p_wi" + std::to_string(d), std::to_string(result.p_value));
        std::printf("[ info ] chi-square Padrón-Griffe wi %zu: %s\n", d, result.summary().c_str());
    }
}

TEST(PadronGriffe2024Bsdf, SampleWeightsAgreeWithEvalAndPdf) {
    using namespace plumage::testing;
    const Bsdf model({});
    for (std::size_t d = 0; d < kIncident.size(); ++d) {
        ConsistencyOptions options;
        options.stream = 800 + d;
        options.samples = 100'000;
        options.polar_cells = 48;
        options.outside_density = is_t_lobe;
        const auto result = eval_pdf_consistency(model, kIncident[d], kWavelengths[d], options);
        EXPECT_TRUE(result.agrees) << "direction " << d << ": " << result.summary();
        std::printf("[ info ] consistency Padrón-Griffe wi %zu: %s\n", d, result.summary().c_str());
        // The T lobe's share of the quanta is the gap fraction G_gap(ωi).
        Rng rng(kDefaultSeed, 900 + d);
        constexpr int kQuanta = 100'000;
        int through = 0;
        for (int k = 0; k < kQuanta; ++k) {
            const auto e = model.sample(kIncident[d], kWavelengths[d], Vec2(0, 0), rng);
            if (e && e->lobe == Bsdf::kT) {
                ++through;
                EXPECT_EQ(e->wo, -kIncident[d]);
            }
        }
        const double gap = model.fractions(kIncident[d]).gap;
        EXPECT_NEAR(static_cast<double>(through) / kQuanta, gap,
                    5.0 * std::sqrt(gap * (1 - gap) / kQuanta) + 1e-12);
    }
}

TEST(PadronGriffe2024Bsdf, EnergyAtMostOneAndEqualToTheWeightedFibreAlbedos) {
    PadronGriffe2024Params sparse;  // with gaps, so that the T lobe carries energy too
    sparse.geometry.barb_spacing = 12.0;
    for (const PadronGriffe2024Params& params : {PadronGriffe2024Params{}, sparse}) {
        const Bsdf model(params);
        std::vector<Vec3d> incident = hemisphere_grid(15.0 * kDeg, 75.0 * kDeg, 60.0 * kDeg);
        for (int k = 0; k < 6; ++k)
            incident.push_back(dir(kPi - 50.0 * kDeg, k * 60.0 * kDeg));  // from below
        const std::array<double, 2> lambdas = {450.0, 650.0};
        const EnergyCheck check = check_energy(model, incident, lambdas, 32);
        EXPECT_FALSE(check.violates()) << check.max_albedo;
        EXPECT_LE(check.max_albedo, 1.0);
        double worst = 0.0, max_total = 0.0;
        for (const Vec3d& wi : incident) {
            const double expected = model.albedo(wi, 550.0);
            const AlbedoEstimate q = directional_albedo(model, wi, 550.0, 32);
            EXPECT_NEAR(q.value, expected, q.error_estimate + 3e-3) << wi.transpose();
            worst = std::max(worst, std::abs(q.value - expected));
            max_total = std::max(max_total, expected + model.fractions(wi).gap);  // with the T lobe
        }
        EXPECT_LE(max_total, 1.0 + 1e-12);
        const std::string label = params.geometry.barb_spacing > 0.0 ? "sparse" : "default";
        RecordProperty("max_albedo_" + label, std::to_string(check.max_albedo));
        std::printf(
            "[ info ] energy Padrón-Griffe %s: max albedo %.4f (±%.1e) at wi (%.2f %.2f %.2f) %.0f "
            "nm; "
            "quadrature vs Σ G Ā %.1e; max albedo + T lobe %.4f\n",
            label.c_str(), check.max_albedo, check.error_estimate, check.worst_wi.x(),
            check.worst_wi.y(), check.worst_wi.z(), check.worst_lambda_nm, worst, max_total);
    }
}

TEST(PadronGriffe2024Bsdf, IsNotReciprocalBecauseTheMaskingWeighsTheIncidentSide) {
    const Bsdf model({});
    std::array<double, Bsdf::kLobeCount> forward{}, backward{};
    double largest = 0.0;
    Rng rng(kDefaultSeed, 950);
    for (int k = 0; k < 200; ++k) {
        const Vec3d wi = dir(std::acos(rng.uniform()), 2.0 * kPi * rng.uniform());
        const Vec3d wo = dir(std::acos(rng.uniform()), 2.0 * kPi * rng.uniform());
        const double a = model.eval(wi, wo, 550.0, forward);
        const double b = model.eval(wo, wi, 550.0, backward);
        if (a + b > 1e-3) largest = std::max(largest, std::abs(a - b) / (0.5 * (a + b)));
        // The medulla lobe is isotropic, so its asymmetry is exactly the incident-side weight:
        // f_med(ωi, ωo) |ωo·z| = G_barb(ωi) Ā_med(ωi) / 4π.
        if (model.fractions(wi).barb < 1e-9 || model.fractions(wo).barb < 1e-9) continue;
        const double ratio = forward[Bsdf::kBarbMedulla] * std::abs(wo.z()) /
                             (backward[Bsdf::kBarbMedulla] * std::abs(wi.z()));
        const double weights =
            model.fractions(wi).barb * model.fibre_albedos(Bsdf::kBarb, wi, 550.0)[3] /
            (model.fractions(wo).barb * model.fibre_albedos(Bsdf::kBarb, wo, 550.0)[3]);
        EXPECT_NEAR(ratio, weights, 1e-9 * weights);
    }
    RecordProperty("max_relative_asymmetry", std::to_string(largest));
    std::printf("[ info ] Padrón-Griffe: largest |f(wi,wo) − f(wo,wi)| / mean = %.3f\n", largest);
    EXPECT_GT(largest, 0.1);
    // Normal light against a grazing view across the barbs: barbules hide the barb from the side,
    // so the barb's medulla glow differs by G_barb(0°) / G_barb(80°).
    const Vec3d normal = dir(0.0, 0.0), side = dir(80.0 * kDeg, 90.0 * kDeg);
    const double g0 = model.fractions(normal).barb, g80 = model.fractions(side).barb;
    std::printf("[ info ] G_barb: %.4f at normal incidence, %.4f at 80 deg across the barbs\n", g0,
                g80);
    EXPECT_GT(std::abs(g0 - g80), 0.05);
}

TEST(PadronGriffe2024Bsdf, ComponentsAreWeightedByTheMaskingFractions) {
    // Two vanes that differ only in barb spacing have the same fibres and different fractions:
    // every barb lobe scales with G_barb(ωi), the T lobe's mass is G_gap.
    PadronGriffe2024Params dense, sparse;
    sparse.geometry.barb_spacing = 15.0;
    const Bsdf a(dense), b(sparse);
    std::array<double, Bsdf::kLobeCount> la{}, lb{};
    for (const Vec3d& wi :
         {dir(0.0, 0.0), dir(50.0 * kDeg, 80.0 * kDeg), dir(70.0 * kDeg, 250.0 * kDeg)}) {
        const double scale = b.fractions(wi).barb / a.fractions(wi).barb;
        for (const Vec3d& wo : {dir(20.0 * kDeg, 10.0 * kDeg), dir(60.0 * kDeg, 200.0 * kDeg),
                                dir(150.0 * kDeg, 1.0)}) {
            a.eval(wi, wo, 550.0, la);
            b.eval(wi, wo, 550.0, lb);
            for (int p = Bsdf::kBarbR; p <= Bsdf::kBarbMedulla; ++p) {
                EXPECT_NEAR(lb[p], scale * la[p], 1e-12 * (la[p] + lb[p]) + 1e-300) << p;
            }
            EXPECT_EQ(la[Bsdf::kT], 0.0);  // a Dirac: not in eval()
        }
        EXPECT_NEAR(a.albedo(wi, 550.0) + a.fractions(wi).gap,
                    a.albedo(wi, 550.0) + 1.0 - a.fractions(wi).barb - a.fractions(wi).barbule(),
                    1e-12);
    }
    // Wavelength enters through keratin's dispersion: the barb's R albedo rises towards blue.
    const Vec3d wi = dir(30.0 * kDeg, 90.0 * kDeg);
    EXPECT_GT(a.fibre_albedos(Bsdf::kBarb, wi, 420.0)[0],
              a.fibre_albedos(Bsdf::kBarb, wi, 700.0)[0]);
}

TEST(PadronGriffe2024Bsdf, FiniteAndNonNegativeForAwkwardDirections) {
    const auto model = Bsdf({});
    plumage::testing::expect_finite_everywhere(model);
}

TEST(PadronGriffe2024Bsdf, RejectsBadParameters) {
    using plumage::testing::input_error_message;
    auto message = [](auto modify) {
        return input_error_message([&] {
            PadronGriffe2024Params p;
            modify(p);
            Bsdf m(p);
        });
    };
    std::string m = message([](PadronGriffe2024Params& p) { p.medulla_albedo = 1.5; });
    EXPECT_TRUE(
        contains(m, "Padrón-Griffe 2024 BSDF: medulla_albedo = 1.5: expected a value in [0, 1]"))
        << m;
    m = message([](PadronGriffe2024Params& p) { p.barb_beta_r_rad = 0.0; });
    EXPECT_TRUE(contains(m, "barb_beta_r_rad = 0: expected a value in [0.01, 0.5] (rad)")) << m;
    m = message([](PadronGriffe2024Params& p) { p.barbule_alpha_r_rad = -1.0; });
    EXPECT_TRUE(contains(m, "barbule_alpha_r_rad = -1: expected a value in [-0.35, 0.35] (rad)"))
        << m;
    m = message([](PadronGriffe2024Params& p) { p.barbule_absorption_per_um = 20.0; });
    EXPECT_TRUE(contains(m, "barbule_absorption_per_um = 20: expected a value in [0, 10] (1/um)"))
        << m;
    m = message([](PadronGriffe2024Params& p) { p.fibre_offsets = 8; });
    EXPECT_TRUE(contains(m, "fibre_offsets = 8: expected an integer in [16, 65536]")) << m;
    m = message([](PadronGriffe2024Params& p) { p.geometry.barb.medulla_offset_z_um = 10.0; });
    EXPECT_TRUE(contains(m, "medulla_offset = 10: expected a medulla strictly inside the cortex"))
        << m;
    m = message([](PadronGriffe2024Params& p) { p.geometry.barb.medulla_scale = 0.99; });
    EXPECT_TRUE(contains(m, "medulla_scale = 0.99: expected a value in [0, 0.95]")) << m;
    m = message([](PadronGriffe2024Params& p) { p.geometry.barbule_inclination_rad = 1.6; });
    EXPECT_TRUE(
        contains(m, "masking: barbule_inclination_rad = 1.6: expected an angle in (-pi/2, pi/2)"))
        << m;
    EXPECT_EQ(message([](PadronGriffe2024Params&) {}), "no InputError");
    const Bsdf model({});
    m = input_error_message([&] { model.eval(Vec3d::UnitZ(), Vec3d::UnitZ(), std::nan("")); });
    EXPECT_TRUE(contains(m, "wavelength = nan nm: expected a finite value > 0")) << m;
}

}  // namespace
}  // namespace plumage::analysis
