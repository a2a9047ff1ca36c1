// The strong-contrast medium against what it must reduce to: the real-space expansion of A₂
// for a Debye medium (its real part, through the dispersion relation, and its imaginary part),
// Maxwell Garnett in the static limit, first Born at weak contrast on a generated channel
// volume, and the refusals.
#include "sim/wave/volume/strong_contrast.h"

#include <cmath>
#include <complex>
#include <cstdio>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "common/constants.h"
#include "common/error.h"
#include "geometry/spongy_volume.h"
#include "sim/optics/material.h"
#include "sim/wave/volume/born_medium.h"
#include "sim/wave/volume/index_field.h"
#include "tests/test_util.h"

namespace plumage::sim::wave {
namespace {

using Complex = std::complex<double>;

// Debye random medium: χ_V(r) = c e^{−r/a}, c = φ(1 − φ), S̄(q) = 8π c a³ / (1 + q²a²)².
constexpr double kA = 0.1, kC = 0.25;
double debye_spectrum(double q) {
    const double u = 1.0 + q * q * kA * kA;
    return 8.0 * kPi * kC * kA * kA * kA / (u * u);
}

// Real-space expansion of A₂ = 3 ∫ χ_V ê·H·ê e^{−iQk̂·r} d³r to order Q² (header): Re A₂ →
// (11/5) Q² ∫₀^∞ r χ_V dr = (11/5) Q² c a²; Im A₂ → Q³ S̄(0)/(2π) = 4 c a³ Q³. Neither uses
// the dispersion relation: the real part is an independent check of it and of w.
TEST(StrongContrast, DebyeMediumMatchesTheRealSpaceExpansionAtLongWavelength) {
    const StrongContrastKernel kernel = StrongContrastKernel::sampled(debye_spectrum, 2000.0, 0.05);
    for (const double qa : {0.01, 0.003}) {
        const double q = qa / kA;
        const Complex a2 = kernel.a2(q);
        const double re_expected = 11.0 / 5.0 * q * q * kC * kA * kA;
        const double im_expected = 4.0 * kC * kA * kA * kA * q * q * q;
        // Next orders are O((Qa)²) relative for both parts.
        EXPECT_NEAR(a2.real() / re_expected, 1.0, 2e-3) << "Qa = " << qa;
        EXPECT_NEAR(a2.imag() / im_expected, 1.0, 5.0 * qa * qa) << "Qa = " << qa;
    }
    // h_∞ = (3/8π) ∫₀^∞ q S̄ dq = (3/8π) · 4π c a (Debye), Porod's tail included; the
    // linear S̄ between 0.05/µm nodes errs by ~(0.05 a)² where S̄ curves.
    EXPECT_NEAR(kernel.im_a2_over_q_limit() / (1.5 * kC * kA), 1.0, 1e-5);
}

// The dispersion relation is linear in S̄ and the Porod tail continues the data: the same
// Debye medium cut at a 10× shorter q gives the same A₂ within the tail's error there
// ((qa)⁻² relative in S̄ at q_cut = 200/µm).
TEST(StrongContrast, PorodTailContinuesTheMeasuredSpectrum) {
    const StrongContrastKernel full = StrongContrastKernel::sampled(debye_spectrum, 2000.0, 0.05);
    const StrongContrastKernel cut = StrongContrastKernel::sampled(debye_spectrum, 200.0, 0.05);
    for (const double q : {2.0, 10.0, 30.0}) {
        const Complex a = full.a2(q), b = cut.a2(q);
        EXPECT_NEAR(b.real() / a.real(), 1.0, 2e-3) << "Q = " << q;
        EXPECT_NEAR(b.imag() / a.imag(), 1.0, 2e-3) << "Q = " << q;
    }
}

// A₂ → 0 as Q → 0, so ε_e → Maxwell Garnett of the host (the Hashin–Shtrikman bound), and
// the attenuation is non-negative at every Q (S̄ ≥ 0, w > 0).
TEST(StrongContrast, StaticLimitIsMaxwellGarnett) {
    const StrongContrastKernel kernel = StrongContrastKernel::sampled(debye_spectrum, 2000.0, 0.05);
    const Complex eps_p = 1.0, eps_q = 1.55 * 1.55;
    const double phi = 0.5;
    const Complex mg = eps_q * (1.0 + 3.0 * phi * (eps_p - eps_q) / (eps_p + 2.0 * eps_q) /
                                          (1.0 - phi * (eps_p - eps_q) / (eps_p + 2.0 * eps_q)));
    EXPECT_NEAR(std::abs(strong_contrast_permittivity(eps_p, eps_q, phi, 0.0) - mg), 0.0, 1e-15);
    const Complex near_static = strong_contrast_permittivity(eps_p, eps_q, phi, kernel.a2(1e-3));
    EXPECT_NEAR(std::abs(near_static - mg) / std::abs(mg), 0.0, 1e-7);
    for (const double q : {0.1, 1.0, 5.0, 10.0, 20.0, 50.0, 100.0}) {
        EXPECT_GE(kernel.a2(q).imag(), 0.0) << "Q = " << q;
        EXPECT_GE(strong_contrast_permittivity(eps_p, eps_q, phi, kernel.a2(q)).imag(), 0.0);
    }
}

const char* host_name(StrongContrastHost host) {
    return host == StrongContrastHost::keratin ? "keratin"
           : host == StrongContrastHost::air   ? "air"
                                               : "bruggeman";
}

PowerSpectrum channel_spectrum() {
    geometry::ChannelVolumeParams p;
    p.length_scale_um = 0.2;
    p.keratin_fraction = 0.5;
    p.box_um = 1.28;
    p.voxel_um = 0.02;
    const geometry::SpongyVolume v = geometry::make_channel_volume(p);
    const IndicatorField field = sample_indicator(*v.level_set);
    return PowerSpectrum::measure_3d(field.as_doubles(), 64, 0.02);
}

// Weak contrast: the two-point resummation is first Born (header), with either phase as host
// or self-consistent. With a phase as host the remainder is first order in Δn (the hosts'
// wavenumbers and Maxwell Garnett against Bruggeman, the resummation's denominator), so the
// ratio's distance from 1 shrinks ~10× per decade of Δn.
TEST(StrongContrast, WeakContrastIsFirstBorn) {
    const PowerSpectrum spectrum = channel_spectrum();
    const optics::ConstantMaterial air("air", Complex(1.0, 0.0));
    for (const StrongContrastHost host :
         {StrongContrastHost::keratin, StrongContrastHost::air, StrongContrastHost::bruggeman}) {
        std::vector<double> offsets;
        for (const double dn : {1e-2, 1e-3}) {
            const optics::ConstantMaterial keratin("weak keratin", Complex(1.0 + dn, 0.0));
            for (const double lambda : {400.0, 550.0, 700.0}) {
                const ScatteringTable sc =
                    strong_contrast_medium(spectrum, keratin, air, lambda, host);
                const ScatteringTable born = born_medium(spectrum, keratin, air, lambda);
                const double offset = std::abs(sc.mu_s_per_um / born.mu_s_per_um - 1.0);
                EXPECT_LT(offset, 1.5 * dn) << "dn " << dn << " at " << lambda << " nm";
                // The self-consistent form has Born's own background (Bruggeman): its remainder
                // is second order, above the two angular integrations' ~1e-6 agreement.
                if (host == StrongContrastHost::bruggeman) {
                    EXPECT_LT(offset, dn * dn + 3e-6) << "dn " << dn << " at " << lambda << " nm";
                }
                EXPECT_NEAR(sc.g, born.g, 5.0 * dn) << "dn " << dn << " at " << lambda << " nm";
                offsets.push_back(offset);
                std::printf("host %s, dn %.0e, %.0f nm: mu_s strong contrast / Born - 1 = %+.2e\n",
                            host_name(host), dn, lambda, sc.mu_s_per_um / born.mu_s_per_um - 1.0);
            }
        }
        for (std::size_t i = 0; i < 3; ++i) EXPECT_LT(offsets[i + 3], 0.2 * offsets[i]);
    }
}

// Keratin at n = 1.55: lossless phases give no absorption, μ_s > 0, a normalised phase
// function, and the attenuation of the coherent wave is what the table's μ_s says.
TEST(StrongContrast, KeratinChannelMediumIsLosslessAndNormalised) {
    const PowerSpectrum spectrum = channel_spectrum();
    const optics::ConstantMaterial keratin("keratin", Complex(1.55, 0.0));
    const optics::ConstantMaterial air("air", Complex(1.0, 0.0));
    for (const StrongContrastHost host :
         {StrongContrastHost::keratin, StrongContrastHost::air, StrongContrastHost::bruggeman}) {
        for (const double lambda : {400.0, 550.0, 700.0}) {
            const ScatteringTable t = strong_contrast_medium(spectrum, keratin, air, lambda, host);
            const ScatteringTable born = born_medium(spectrum, keratin, air, lambda);
            std::printf(
                "host %s, %.0f nm: n_eff %.4f (Bruggeman %.4f), mu_s %.3f /um (Born %.3f)\n",
                host_name(host), lambda, t.n_eff.real(), born.n_eff.real(), t.mu_s_per_um,
                born.mu_s_per_um);
            EXPECT_EQ(t.mu_a_per_um, 0.0);
            EXPECT_GT(t.mu_s_per_um, 0.0);
            EXPECT_GT(t.n_eff.real(), 1.0);
            EXPECT_LT(t.n_eff.real(), 1.55);
            double norm = 0.0;  // trapezoid in θ over the table
            for (std::size_t i = 1; i < t.cos_theta.size(); ++i) {
                const double th0 = std::acos(t.cos_theta[i - 1]), th1 = std::acos(t.cos_theta[i]);
                norm += 0.5 * (th1 - th0) *
                        (t.phase_per_sr[i] * std::sin(th1) + t.phase_per_sr[i - 1] * std::sin(th0));
            }
            EXPECT_NEAR(2.0 * kPi * norm, 1.0, 2e-3) << lambda << " nm";
        }
    }
}

TEST(StrongContrast, RefusesOutsideItsValidity) {
    using plumage::testing::input_error_message;
    EXPECT_NE(input_error_message([] {
                  StrongContrastKernel::sampled(debye_spectrum, 0.0, 0.1);
              }).find("q_cut = 0"),
              std::string::npos);
    EXPECT_NE(input_error_message([] {
                  StrongContrastKernel::sampled(debye_spectrum, 10.0, 20.0);
              }).find("q_step = 20"),
              std::string::npos);
    EXPECT_NE(input_error_message([] {
                  StrongContrastKernel::sampled([](double q) { return q > 5.0 ? -1.0 : 1.0; }, 10.0,
                                                1.0);
              }).find("expected a finite value >= 0"),
              std::string::npos);
    // The medium refuses what first Born refuses, in its words.
    const int n = 16;
    std::vector<double> half(n * n * n);
    for (std::size_t p = 0; p < half.size(); ++p) half[p] = p % 2 == 0 ? 1.0 : 0.0;
    const PowerSpectrum coarse = PowerSpectrum::measure_3d(half, n, 0.08);
    const std::string message = input_error_message([&] {
        strong_contrast_medium(coarse, *optics::keratin(), *optics::air(), 400.0,
                               StrongContrastHost::keratin);
    });
    EXPECT_NE(message.find("lambda / (4 n_max)"), std::string::npos) << message;
}

}  // namespace
}  // namespace plumage::sim::wave
