// Physical optics in 2D (sim/wave/surface/physical_optics_2d.h): the flat strip's specular power
// and closed form, reciprocity, convergence to geometric optics on the barbule arc, refused input,
// and thread-count independence of a jittered row.
#include "sim/wave/surface/physical_optics_2d.h"

#include <omp.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <numeric>
#include <vector>

#include <gtest/gtest.h>

#include "common/constants.h"
#include "common/error.h"
#include "sim/optics/multilayer.h"
#include "sim/wave/surface/geometric_optics_2d.h"

namespace plumage::sim::wave {
namespace {

using Vec = Eigen::Vector2d;

SurfaceStack2d keratin_on_melanin(double d_um) {
    return {{{optics::keratin(), d_um}}, optics::melanin()};
}

optics::Polarisation to_optics(Polarisation2d pol) {
    return pol == Polarisation2d::te ? optics::Polarisation::s : optics::Polarisation::p;
}

// Reflectance of a curve's stack (air above) at cos θ.
double stack_reflectance(const SurfaceStack2d& stack, double lambda_nm, double cos_theta,
                         Polarisation2d pol) {
    std::vector<optics::StackLayer> layers;
    for (const FilmLayer2d& f : stack.films)
        layers.push_back({f.material->index(lambda_nm), f.thickness_um});
    const optics::StackIndices indices{1.0, layers, stack.substrate->index(lambda_nm)};
    return optics::transfer_matrix_intensities(indices, lambda_nm, cos_theta, to_optics(pol))
        .reflectance;
}

std::complex<double> stack_r(const SurfaceStack2d& stack, double lambda_nm, double cos_theta,
                             Polarisation2d pol) {
    std::vector<optics::StackLayer> layers;
    for (const FilmLayer2d& f : stack.films)
        layers.push_back({f.material->index(lambda_nm), f.thickness_um});
    const optics::StackIndices indices{1.0, layers, stack.substrate->index(lambda_nm)};
    return optics::transfer_matrix_amplitudes(indices, lambda_nm, cos_theta, to_optics(pol)).r;
}

// N angles uniform on the circle, θ_m = −π + 2π (m + 1)/N ∈ (−π, π].
std::vector<double> circle(int n) {
    std::vector<double> t(n);
    for (int m = 0; m < n; ++m) t[m] = -kPi + 2.0 * kPi * (m + 1) / n;
    return t;
}

// ∫σ dθ over the circle by the trapezoid rule: σ(θ) is a trigonometric polynomial of degree
// <= 2 k R_max (R_max: the largest |r'| on the surface; the integrand of U carries
// e^{−ik ω_s·r'}), so N > 2 k R_max points integrate it exactly up to the sinc weights' tails.
double circle_integral(const std::vector<double>& sigma) {
    return std::accumulate(sigma.begin(), sigma.end(), 0.0) * 2.0 * kPi /
           static_cast<double>(sigma.size());
}

int points_for(double lambda_nm, double r_max_um) {
    const double k = 2.0 * kPi / (1e-3 * lambda_nm);
    return static_cast<int>(std::ceil(4.0 * k * r_max_um)) + 256;
}

// 1. A strip of W = 200 λ: its reflected power equals R(θ_i) W cos θ_i. The reflected part's
// lobe is a sinc² of width λ/(W cos θ_i); the obliquity (cos θ_s + cos θ_i)/2 cos θ_i varies by
// O(λ/W) across it, and the sinc² tails that fall outside the real angles carry
// ~ (2/π²) λ/W ≈ 0.1 %; 1 % leaves room for both. With r at the bisector (FresnelAngle::
// bisector) too: across the lobe ω_i·h stays within O(λ/W) of cos θ_i, so the power is the same
// to that order (r at h·n, as the option once had it, gives R(0°) W cos θ_i: 40 % low in TE at
// 50°). Not TM at 50°: 7° from keratin's Brewster angle R_p changes by its own size within a few
// degrees, and the lobe's spread of ω_i·h moves the bisector's power by +4.7 % (measured), a
// property of that choice, not an error of the sum.
TEST(PhysicalOptics2d, WideStripReflectsTheTransferMatrixSpecularPower) {
    const double lambda = 550.0, width = 200.0 * 0.55;
    const SurfaceStack2d stack = keratin_on_melanin(0.3);
    const std::vector<double> theta = circle(points_for(lambda, 0.5 * width));
    for (const FresnelAngle fresnel : {FresnelAngle::incidence, FresnelAngle::bisector}) {
        for (double theta_i_deg : {0.0, 30.0, 50.0}) {
            for (Polarisation2d pol : {Polarisation2d::te, Polarisation2d::tm}) {
                if (fresnel == FresnelAngle::bisector && theta_i_deg == 50.0 &&
                    pol == Polarisation2d::tm)
                    continue;
                const double ti = theta_i_deg * kDeg;
                PhysicalOpticsOptions options;
                options.part = FarFieldPart::reflected;
                options.fresnel = fresnel;
                const std::vector<double> sigma =
                    scattering_width(flat_strip(width, stack), {lambda, ti, pol}, theta, options);
                const double power = circle_integral(sigma);
                const double expected =
                    stack_reflectance(stack, lambda, std::cos(ti), pol) * width * std::cos(ti);
                std::printf("strip W=200λ θi=%g %s %s: PO %.6g µm, R W cosθ %.6g µm, rel %.2e\n",
                            theta_i_deg, pol == Polarisation2d::te ? "TE" : "TM",
                            fresnel == FresnelAngle::bisector ? "bisector" : "incidence", power,
                            expected, power / expected - 1.0);
                EXPECT_NEAR(power / expected, 1.0, 0.01);
            }
        }
    }
}

// 2. The flat strip's far field is k/(8π) |A|² W² sinc²(k (sin θ_i + sin θ_s) W/2) with the
// obliquity A = (1 + r) cos θ_s − (1 − r) cos θ_i (total field) and r at θ_i. The quadrature
// integrates the phase exactly along straight pieces (sinc per piece, Taylor error < 1e-12),
// so only rounding separates the two: 1e-6 relative, away from the sinc's and A's zeros.
TEST(PhysicalOptics2d, StripFarFieldIsTheClosedFormSinc) {
    const double lambda = 550.0, width = 7.3;
    const double k = 2.0 * kPi / 0.55;
    const SurfaceStack2d stack = keratin_on_melanin(0.59);
    const std::vector<double> theta = circle(1441);
    for (Polarisation2d pol : {Polarisation2d::te, Polarisation2d::tm}) {
        for (double theta_i_deg : {0.0, 30.0}) {
            const double ti = theta_i_deg * kDeg;
            const std::complex<double> r = stack_r(stack, lambda, std::cos(ti), pol);
            const std::vector<double> sigma =
                scattering_width(flat_strip(width, stack), {lambda, ti, pol}, theta);
            double worst = 0.0;
            int checked = 0;
            for (std::size_t m = 0; m < theta.size(); ++m) {
                const double x = 0.5 * k * (std::sin(ti) + std::sin(theta[m])) * width;
                const std::complex<double> a =
                    (1.0 + r) * std::cos(theta[m]) - (1.0 - r) * std::cos(ti);
                if (std::abs(std::sin(x)) < 0.05 || std::abs(a) < 1e-2) continue;
                const double sinc = x == 0.0 ? 1.0 : std::sin(x) / x;
                const double expected =
                    k / (8.0 * kPi) * std::norm(a) * width * width * sinc * sinc;
                worst = std::max(worst, std::abs(sigma[m] / expected - 1.0));
                ++checked;
            }
            std::printf("strip closed form θi=%g %s: %d angles, worst rel %.2e\n", theta_i_deg,
                        pol == Polarisation2d::te ? "TE" : "TM", checked, worst);
            EXPECT_GT(checked, 1000);
            EXPECT_LT(worst, 1e-6);
        }
    }
}

// The TM sign (header: u = H_y, r = the stack's r_p unchanged). A near-perfect conductor
// (n = 1 + 10⁴ i, |r ∓ 1| < 3e-4) must give Dirichlet (E_y = 0, r_s → −1) in TE and Neumann
// (∂H_y/∂n = 0, r_p → +1) in TM, i.e. the textbook physical-optics strip (Balanis, Advanced
// Engineering Electromagnetics, §11.3): σ = (W²/λ) cos²θ_i sinc²(X) for E along the strip's
// edges and (W²/λ) cos²θ_s sinc²(X) for H along them, X = k W (sin θ_i + sin θ_s)/2 (Balanis'
// width 2π ρ|E_s|²/|E_i|² is 2π times ours). A sign error in r_p would swap the obliquities.
// 1e-3 relative: the conductor's |r ∓ 1| enters twice; away from sinc zeros.
TEST(PhysicalOptics2d, ConductingStripHasTheTextbookObliquities) {
    const double lambda = 500.0, width = 4.0, k = 2.0 * kPi / 0.5;
    const SurfaceStack2d metal{
        {},
        std::make_shared<optics::ConstantMaterial>("conductor", std::complex<double>(1.0, 1e4))};
    const double ti = 25.0 * kDeg;
    const std::vector<double> theta = circle(361);
    for (Polarisation2d pol : {Polarisation2d::te, Polarisation2d::tm}) {
        const std::vector<double> sigma =
            scattering_width(flat_strip(width, metal), {lambda, ti, pol}, theta);
        int checked = 0;
        for (std::size_t m = 0; m < theta.size(); ++m) {
            const double x = 0.5 * k * width * (std::sin(ti) + std::sin(theta[m]));
            const double c = pol == Polarisation2d::te ? std::cos(ti) : std::cos(theta[m]);
            if (std::abs(std::sin(x)) < 0.05 || std::abs(c) < 0.05) continue;
            const double sinc = x == 0.0 ? 1.0 : std::sin(x) / x;
            const double expected = width * width / 0.5 * c * c * sinc * sinc;
            EXPECT_NEAR(sigma[m] / expected, 1.0, 1e-3) << "θ_s = " << theta[m] / kDeg;
            ++checked;
        }
        EXPECT_GT(checked, 300);
    }
}

// 3. Reciprocity, reflected part, on the closed convex reference shell (c).
// (a) With r at the bisector (FresnelAngle::bisector) the integrand r(h·n)(ω_i + ω_s)·n
// e^{−ik(ω_i + ω_s)·r} and the mask (n·ω_i > 0 and n·ω_s > 0 on a convex curve) are symmetric
// in ω_i ↔ ω_s, and so is every floating-point operation on them: equal to rounding, 1e-12
// (measured: bit-equal).
// (b) Kirchhoff's default (r at θ_i, lit set of ω_i only) is reciprocal only at the stationary
// (specular) point. Its terminator (where n·ω_i → 0 the integrand jumps from r(ω_i + ω_s)·n to
// 0) radiates an end-point wave of relative amplitude O((kρ)^{-1/2}) next to the stationary one,
// and r varies across the Fresnel zone (film fringes, Brewster for TM). Measured rms of
// |σ(i→s)/σ(s→i) − 1| over five pairs, TE / TM: 0.36 / 0.46 for the reference shell
// (5, 2, 0.3) µm, kρ ≈ 10–140; 0.045 / 0.10 for the same shape 16× larger. Asserted for TE (the
// smooth r): rms < 0.1 at 16× and < a third of the 1× value.
TEST(PhysicalOptics2d, ReciprocityOfTheReflectedField) {
    const double lambda = 550.0;
    const std::vector<std::pair<double, double>> pairs = {
        {0.0, 40.0}, {30.0, -60.0}, {-20.0, 70.0}, {10.0, -15.0}, {45.0, 5.0}};
    auto sigma = [&](const CrossSection2d& shell, double from_deg, double to_deg,
                     Polarisation2d pol, FresnelAngle fresnel) {
        PhysicalOpticsOptions options;
        options.part = FarFieldPart::reflected;
        options.fresnel = fresnel;
        return scattering_width(shell, {lambda, from_deg * kDeg, pol}, std::vector{to_deg * kDeg},
                                options)[0];
    };
    const CrossSection2d reference = coated_ellipse(5.0, 2.0, 0.3);
    for (Polarisation2d pol : {Polarisation2d::te, Polarisation2d::tm})
        for (const auto& [a, b] : pairs)
            EXPECT_NEAR(sigma(reference, a, b, pol, FresnelAngle::bisector) /
                            sigma(reference, b, a, pol, FresnelAngle::bisector),
                        1.0, 1e-12);
    auto rms_error = [&](const CrossSection2d& shell, Polarisation2d pol) {
        double sum = 0.0;
        for (const auto& [a, b] : pairs) {
            const double e = sigma(shell, a, b, pol, FresnelAngle::incidence) /
                                 sigma(shell, b, a, pol, FresnelAngle::incidence) -
                             1.0;
            sum += e * e;
        }
        return std::sqrt(sum / static_cast<double>(pairs.size()));
    };
    const CrossSection2d large = coated_ellipse(80.0, 32.0, 0.3);
    const double te_small = rms_error(reference, Polarisation2d::te);
    const double te_large = rms_error(large, Polarisation2d::te);
    std::printf("Kirchhoff reciprocity rms: TE %.3f (1×) %.3f (16×), TM %.3f (1×) %.3f (16×)\n",
                te_small, te_large, rms_error(reference, Polarisation2d::tm),
                rms_error(large, Polarisation2d::tm));
    EXPECT_LT(te_large, 0.1);
    EXPECT_LT(te_large, te_small / 3.0);
}

// Outgoing visibility (PhysicalOpticsOptions::outgoing_visibility). (a) With the bisector r the
// reflected integrand and its mask, lit from ω_i and seen from ω_s, are symmetric in ω_i ↔ ω_s
// for any cross-section: the row of three reference shells, which shadow each other at 30°
// and beyond, is reciprocal to rounding (1e-12; measured bit-equal). (b) Without visibility
// the row reflects 3.2–3.4× one shell over all angles (FullWaveReferenceCases), more than
// three shells can. With it, at normal incidence, the row/single ratio follows geometric
// optics under the same rule (each lit element's mirror ray must leave unblocked): measured
// PO 2.476 vs GO 2.598 (TE), 2.864 vs 2.944 (TM), i.e. 4.7 % and 2.7 % low, the single shell
// alone PO/GO = 1.001 / 1.000. The residual is the sharp Kirchhoff cut of the blocked flanks,
// whose rays graze the neighbours (their lit part's edge waves partly pass); bound 8 %.
TEST(PhysicalOptics2d, OutgoingVisibilityMakesRowsReciprocalAndFollowsGeometricOptics) {
    const double lambda = 550.0;
    Row2d row;
    row.cell = coated_ellipse(5.0, 2.0, 0.3);
    row.count = 3;
    row.spacing_um = 11.0;
    PhysicalOpticsOptions symmetric;
    symmetric.part = FarFieldPart::reflected;
    symmetric.fresnel = FresnelAngle::bisector;
    symmetric.outgoing_visibility = true;
    for (Polarisation2d pol : {Polarisation2d::te, Polarisation2d::tm}) {
        for (const auto& [a, b] : std::vector<std::pair<double, double>>{
                 {30.0, -75.0}, {80.0, -20.0}, {-60.0, 85.0}, {5.0, 40.0}}) {
            const double ab =
                scattering_width(row, {lambda, a * kDeg, pol}, std::vector{b * kDeg}, symmetric)[0];
            const double ba =
                scattering_width(row, {lambda, b * kDeg, pol}, std::vector{a * kDeg}, symmetric)[0];
            EXPECT_NEAR(ab / ba, 1.0, 1e-12) << a << " ↔ " << b;
        }
    }
    PhysicalOpticsOptions visible;
    visible.part = FarFieldPart::reflected;
    visible.outgoing_visibility = true;
    const std::vector<double> theta = circle(points_for(lambda, 17.0));
    // Geometric optics with the same rule (geometric_optics_2d.h): a lit element's power
    // R cos θ ds counts when the ray towards its mirror direction crosses no chord.
    auto go_visible = [&](const SampledCrossSection2d& placed, Polarisation2d pol) {
        const FarFieldKernel2d kernel =
            prepare_far_field(row.cell, placed, {lambda, 0.0, pol}, FarFieldPart::reflected);
        return total_power(geometric_rays(kernel, placed, true));
    };
    const SampledCrossSection2d cell = sample_cross_section(row.cell, 0.055);
    Row2d one = row;
    one.count = 1;
    for (Polarisation2d pol : {Polarisation2d::te, Polarisation2d::tm}) {
        const double single =
            circle_integral(scattering_width(row.cell, {lambda, 0.0, pol}, theta, visible));
        const double three =
            circle_integral(scattering_width(row, {lambda, 0.0, pol}, theta, visible));
        const double go_single = go_visible(place_row(one, cell, 0), pol);
        const double go_three = go_visible(place_row(row, cell, 0), pol);
        std::printf(
            "visibility %s: row/single PO %.4f, GO %.4f; row PO/GO %.4f, single PO/GO "
            "%.4f\n",
            pol == Polarisation2d::te ? "TE" : "TM", three / single, go_three / go_single,
            three / go_three, single / go_single);
        EXPECT_NEAR((three / single) / (go_three / go_single), 1.0, 0.08);
    }
}

// 4. Physical optics → geometric optics as the barbule arc (b) grows: PO's reflected power over
// all angles against Σ_lit R(θ_local) cos θ_local ds from the same samples and stack, and the
// angular distributions binned into 10° windows (each lit element's power into its mirror
// direction). 550 nm, normal incidence, rock-dove arc shape (b = 0.25, φ ∈ [−0.37, 2.64]),
// film 0.59 µm over a 0.3 µm gap over melanin. Each size is the mean over A·{0.97, 0.99, 1.01,
// 1.03}: the open arc's edge and the terminator radiate edge waves whose cross term with the
// specular lobe oscillates in kA; the mean keeps the trend.
// Measured (TE / TM): |PO/GO − 1| = 0.233 / 0.054 (A = 2), 0.036 / 0.023 (5), 0.066 / 0.048
// (10), 0.043 / 0.031 (20), 0.020 / 0.019 (50); 0.0101 / 0.0112 (100) and 0.0054 / 0.0064
// (200, not run here: 10 s). The sign flips near A ≈ 4 (PO below GO for small arcs, whose lit
// part is a few λ), so below A = 10 the error is pre-asymptotic; from 10 to 50 it falls
// monotonically with fitted exponents −0.76 (TE) and −0.58 (TM), steepening towards the
// expected −1 beyond (−0.94 / −0.77 from 50 to 200): the edge waves carry an absolute power of
// order 0.05 µm ≈ 0.1 λ, nearly constant in A, so the relative error tends to O(λ/A).
// Asserted: monotone decrease over 10, 20, 50;
// exponent in [−1.3, −0.4]; at A = 50 the total within 3 % and the binned L1 within 25 %.
TEST(PhysicalOptics2d, BarbuleArcConvergesToGeometricOptics) {
    const double lambda = 550.0, step = 0.055;
    const std::vector<double> sizes = {2.0, 5.0, 10.0, 20.0, 50.0};
    const std::vector<double> factors = {0.97, 0.99, 1.01, 1.03};
    constexpr int kBins = 36;
    auto bin_of = [](double theta) {
        const int b = static_cast<int>(std::floor((theta + kPi) / (2.0 * kPi) * kBins));
        return std::clamp(b, 0, kBins - 1);
    };
    for (Polarisation2d pol : {Polarisation2d::te, Polarisation2d::tm}) {
        const char* name = pol == Polarisation2d::te ? "TE" : "TM";
        std::vector<double> total_error, angular_error;
        for (double a_mean : sizes) {
            double total = 0.0, angular = 0.0;
            for (double f : factors) {
                const double a_um = a_mean * f;
                const geometry::EllipticalArc arc(a_um, 0.25 * a_um, -0.37, 2.64);
                const CrossSection2d section = barbule_arc(arc, 0.59, 0.3);
                const SampledCrossSection2d sampled = sample_cross_section(section, step);
                const FarFieldKernel2d kernel = prepare_far_field(
                    section, sampled, {lambda, 0.0, pol}, FarFieldPart::reflected);
                double go = 0.0;
                std::vector<double> go_bins(kBins, 0.0), po_bins(kBins, 0.0);
                for (const GeometricRay2d& ray : geometric_rays(kernel, sampled)) {
                    go += ray.power_um;
                    go_bins[bin_of(ray.theta_s_rad)] += ray.power_um;
                }
                PhysicalOpticsOptions options;
                options.part = FarFieldPart::reflected;
                options.step_um = step;
                const std::vector<double> theta = circle(points_for(lambda, a_um));
                const std::vector<double> sigma =
                    scattering_width(section, {lambda, 0.0, pol}, theta, options);
                const double po = circle_integral(sigma);
                for (std::size_t m = 0; m < theta.size(); ++m)
                    po_bins[bin_of(theta[m])] +=
                        sigma[m] * 2.0 * kPi / static_cast<double>(theta.size());
                double l1 = 0.0;
                for (int b = 0; b < kBins; ++b) l1 += std::abs(po_bins[b] - go_bins[b]);
                total += std::abs(po / go - 1.0) / static_cast<double>(factors.size());
                angular += l1 / go / static_cast<double>(factors.size());
            }
            total_error.push_back(total);
            angular_error.push_back(angular);
            std::printf("arc %s A=%g µm: mean |PO/GO − 1| = %.3e, binned L1/GO = %.3e\n", name,
                        a_mean, total, angular);
        }
        // Least-squares slope of log error against log A over the asymptotic sizes (from 10).
        double mx = 0.0, my = 0.0, sxy = 0.0, sxx = 0.0;
        const std::size_t first = 2, count = sizes.size() - first;
        for (std::size_t i = first; i < sizes.size(); ++i)
            mx += std::log(sizes[i]), my += std::log(total_error[i]);
        mx /= static_cast<double>(count);
        my /= static_cast<double>(count);
        for (std::size_t i = first; i < sizes.size(); ++i) {
            sxy += (std::log(sizes[i]) - mx) * (std::log(total_error[i]) - my);
            sxx += (std::log(sizes[i]) - mx) * (std::log(sizes[i]) - mx);
        }
        const double exponent = sxy / sxx;
        std::printf("arc %s: fitted exponent of the total-power error (A >= 10): %.3f\n", name,
                    exponent);
        for (std::size_t i = first + 1; i < sizes.size(); ++i) {
            EXPECT_LT(total_error[i], total_error[i - 1]) << name << " A = " << sizes[i];
            EXPECT_LT(angular_error[i], angular_error[i - 1]) << name << " A = " << sizes[i];
        }
        EXPECT_GT(exponent, -1.3);
        EXPECT_LT(exponent, -0.4);
        EXPECT_LT(total_error.back(), 0.03);
        EXPECT_LT(angular_error.back(), 0.25);
    }
}

// 5. Input physical optics cannot answer is refused, naming the limit and the value.
TEST(PhysicalOptics2d, RefusesCoarseStepsAndFeaturesBelowTheStep) {
    const Incidence2d incidence{550.0, 0.0, Polarisation2d::te};
    const std::vector<double> theta = {0.0};
    const SurfaceStack2d stack = keratin_on_melanin(0.3);
    auto message = [&](const CrossSection2d& section, double step) {
        PhysicalOpticsOptions options;
        options.step_um = step;
        try {
            scattering_width(section, incidence, theta, options);
        } catch (const InputError& e) {
            return std::string(e.what());
        }
        return std::string("(accepted)");
    };
    // λ/10 = 0.055 µm at 550 nm.
    const std::string coarse = message(flat_strip(5.0, stack), 0.08);
    EXPECT_NE(coarse.find("λ/10 = 0.055 µm"), std::string::npos) << coarse;
    EXPECT_NE(coarse.find("0.08"), std::string::npos) << coarse;
    EXPECT_EQ(message(flat_strip(5.0, stack), 0.055), "(accepted)");
    const std::string short_strip = message(flat_strip(0.03, stack), 0.0);
    EXPECT_NE(short_strip.find("below the sampling step 0.055 µm"), std::string::npos)
        << short_strip;
    EXPECT_NE(short_strip.find("0.03"), std::string::npos) << short_strip;
    // A 1 µm × 0.1 µm core: radius of curvature a_z²/a_x = 0.01 µm at the tips.
    const std::string sharp = message(coated_ellipse(1.0, 0.1, 0.0), 0.0);
    EXPECT_NE(sharp.find("radius of curvature"), std::string::npos) << sharp;
    EXPECT_NE(sharp.find("below the sampling step 0.055 µm"), std::string::npos) << sharp;
    EXPECT_THROW(scattering_width(flat_strip(5.0, stack), {-1.0, 0.0}, theta), InputError);
    Row2d row;
    row.cell = flat_strip(5.0, stack);
    row.count = 0;
    EXPECT_THROW(scattering_width(row, incidence, theta), InputError);
}

// 6. A jittered row ensemble is bit-identical at 1, 2 and 3 threads: each angle's sum runs in
// one thread in a fixed order, and the jitter comes from (seed, purpose, realisation) streams
// indexed by cell.
TEST(PhysicalOptics2d, JitteredRowIsBitIdenticalAcrossThreadCounts) {
    Row2d row;
    row.cell = barbule_arc(geometry::EllipticalArc(3.0, 0.75, -0.37, 2.64), 0.59, 0.3);
    row.count = 4;
    row.spacing_um = 3.75;
    row.tilt_rad = -0.35;
    row.jitter_position_um = 0.2;
    row.jitter_rotation_rad = 0.05;
    row.realisations = 3;
    const std::vector<double> theta = circle(181);
    const int saved = omp_get_max_threads();
    std::vector<std::vector<double>> results;
    for (int threads : {1, 2, 3}) {
        omp_set_num_threads(threads);
        results.push_back(scattering_width(row, {550.0, 20.0 * kDeg, Polarisation2d::tm}, theta));
    }
    omp_set_num_threads(saved);
    for (std::size_t t = 1; t < results.size(); ++t)
        EXPECT_EQ(
            std::memcmp(results[0].data(), results[t].data(), results[0].size() * sizeof(double)),
            0);
    // The jitter does something: an unjittered row differs.
    row.jitter_position_um = row.jitter_rotation_rad = 0.0;
    const std::vector<double> plain =
        scattering_width(row, {550.0, 20.0 * kDeg, Polarisation2d::tm}, theta);
    EXPECT_NE(std::memcmp(results[0].data(), plain.data(), plain.size() * sizeof(double)), 0);
}

// The full-wave reference cases (shape c; tests/reference, built by the Meep work): single
// (a_x, a_z, d) = (5, 2, 0.3) µm, small (1, 0.4, 0.3) µm, and three singles at x = −11, 0, 11
// µm; 450/550/650 nm; θ_i = 0° and 30°; TE and TM. Checks what must hold whatever PO's error:
// σ finite and >= 0; the reflected power below the lit elements' Σ cos θ ds (R <= 1); the
// single's reflected power near GO's Σ R cos θ ds (within 15 %: measured 2–11 %, kρ >= 10 on
// the lit side, the small one's kρ ≈ 5 is not held to it); and at normal incidence, where
// the three shells do not shadow each other (gaps 0.4 µm), the row's reflected power within
// 60° of the zenith is 3× the single's within 3 %: there the array factor
// |Σ_m e^{−ik (sin θ_i + sin θ_s) 11 m}|² oscillates fast in θ_s and its cross terms average
// out (measured 0.3–1.3 %). Over all angles the row gives 3.2–3.4× at normal incidence: near
// θ_s = ±90° sin θ_s is stationary, the cells add coherently, and the shells' flanks reflect
// exactly there, along the row, where a real neighbour would block the light; PO without
// outgoing visibility (header) counts it. The printed table is the PO column of the
// reference comparison.
TEST(PhysicalOptics2d, FullWaveReferenceCases) {
    const CrossSection2d single = coated_ellipse(5.0, 2.0, 0.3);
    const CrossSection2d small = coated_ellipse(1.0, 0.4, 0.3);
    Row2d row;
    row.cell = single;
    row.count = 3;
    row.spacing_um = 11.0;
    PhysicalOpticsOptions reflected;
    reflected.part = FarFieldPart::reflected;
    for (double lambda : {450.0, 550.0, 650.0}) {
        for (double theta_i_deg : {0.0, 30.0}) {
            for (Polarisation2d pol : {Polarisation2d::te, Polarisation2d::tm}) {
                const double ti = theta_i_deg * kDeg;
                const Vec wi(std::sin(ti), std::cos(ti));
                const Incidence2d incidence{lambda, ti, pol};
                auto go = [&](const CrossSection2d& shape, double* lit_width) {
                    const SampledCrossSection2d sampled =
                        sample_cross_section(shape, 1e-3 * lambda / 10.0);
                    const std::vector<unsigned char> lit = illuminated(sampled, wi);
                    *lit_width = 0.0;
                    for (std::size_t j = 0; j < sampled.samples.size(); ++j)
                        if (lit[j])
                            *lit_width +=
                                sampled.samples[j].normal.dot(wi) * sampled.samples[j].ds_um;
                    const FarFieldKernel2d kernel =
                        prepare_far_field(shape, sampled, incidence, FarFieldPart::reflected);
                    return total_power(geometric_rays(kernel, sampled));
                };
                double single_width = 0.0, small_width = 0.0;
                const double single_go = go(single, &single_width);
                const double small_go = go(small, &small_width);
                const std::vector<double> theta = circle(points_for(lambda, 17.0));
                const std::vector<double> s1 =
                    scattering_width(single, incidence, theta, reflected);
                const std::vector<double> s2 = scattering_width(small, incidence, theta, reflected);
                const std::vector<double> s3 = scattering_width(row, incidence, theta, reflected);
                for (const auto* s : {&s1, &s2, &s3})
                    for (double v : *s) ASSERT_TRUE(std::isfinite(v) && v >= 0.0);
                const double p1 = circle_integral(s1), p2 = circle_integral(s2),
                             p3 = circle_integral(s3);
                std::printf(
                    "reference λ=%g θi=%g %s: single PO %.4f GO %.4f µm | small PO %.4f "
                    "GO %.4f µm | row PO %.4f µm = %.4f × single\n",
                    lambda, theta_i_deg, pol == Polarisation2d::te ? "TE" : "TM", p1, single_go, p2,
                    small_go, p3, p3 / p1);
                EXPECT_LT(p1, single_width);
                EXPECT_LT(p2, small_width);
                EXPECT_LT(p3, 3.0 * single_width);
                EXPECT_NEAR(p1 / single_go, 1.0, 0.15);
                if (theta_i_deg == 0.0) {
                    double w1 = 0.0, w3 = 0.0;
                    for (std::size_t m = 0; m < theta.size(); ++m) {
                        if (std::abs(theta[m]) > 60.0 * kDeg) continue;
                        w1 += s1[m];
                        w3 += s3[m];
                    }
                    std::printf("  row/single within 60° of the zenith: %.4f\n", w3 / w1);
                    EXPECT_NEAR(w3 / w1, 3.0, 0.09);
                }
            }
        }
    }
}

}  // namespace
}  // namespace plumage::sim::wave
