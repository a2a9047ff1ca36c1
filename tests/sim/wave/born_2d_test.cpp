// Flatland first Born (sim/wave/volume/born_2d.h) and rectangular 2D power spectra: Parseval on
// rectangles, the voxelised disc's form factor, the Rayleigh cylinder of van de Hulst, the
// 2D effective permittivities, and the input checks.
#include "sim/wave/volume/born_2d.h"

#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "tests/sim/wave/random_field.h"

#include "common/constants.h"
#include "common/error.h"
#include "sim/optics/material.h"
#include "sim/wave/volume/power_spectrum.h"
#include "tests/test_util.h"

namespace plumage::sim::wave {
namespace {

using fields::random_indicator;
using fields::real_space_variance;

// One disc of radius a (pixel centres within a), centred in an nx × ny field of pixel h.
std::vector<double> disc_field(int nx, int ny, double h, double a, std::size_t* pixels) {
    std::vector<double> v(static_cast<std::size_t>(nx) * ny, 0.0);
    *pixels = 0;
    for (int row = 0; row < ny; ++row) {
        for (int col = 0; col < nx; ++col) {
            const double x = (col + 0.5 - 0.5 * nx) * h, y = (row + 0.5 - 0.5 * ny) * h;
            if (x * x + y * y <= a * a) {
                v[static_cast<std::size_t>(row) * nx + col] = 1.0;
                ++*pixels;
            }
        }
    }
    return v;
}

// [2 J1(x)/x]², the disc's normalised form factor.
double disc_form_factor(double x) {
    if (x < 1e-8) return 1.0;
    const double f = 2.0 * std::cyl_bessel_j(1.0, x) / x;
    return f * f;
}

TEST(WaveBorn2d, RectangularSpectrumKeepsParseval) {
    for (auto [nx, ny] : {std::pair{40, 30}, std::pair{33, 20}, std::pair{16, 47}}) {
        const auto v = random_indicator(static_cast<std::size_t>(nx) * ny, 0.45, 7);
        const PowerSpectrum s = PowerSpectrum::measure_2d(v, nx, ny, 0.01);
        EXPECT_EQ(s.voxels_x(), nx);
        EXPECT_EQ(s.voxels_y(), ny);
        EXPECT_NEAR(s.cell_measure(), nx * ny * 1e-4, 1e-15);
        EXPECT_NEAR(s.variance() / real_space_variance(v), 1.0, 1e-12) << nx << " x " << ny;
        // Every shell up to the longest side's N/2 holds modes, and they account for all the
        // power inside |q| <= π/h (the corners beyond are left out, as for squares).
        const RadialSpectrum r = s.radial();
        EXPECT_EQ(r.q_per_um.size(), static_cast<std::size_t>(std::max(nx, ny) / 2));
        EXPECT_NEAR(r.shell_width_per_um, kTwoPi / (std::max(nx, ny) * 0.01), 1e-12);
        for (std::size_t m : r.modes) EXPECT_GT(m, 0u);
    }
}

TEST(WaveBorn2d, SquareFieldGivesTheSameSpectrumThroughBothOverloads) {
    const auto v = random_indicator(32 * 32, 0.5, 8);
    const PowerSpectrum a = PowerSpectrum::measure_2d(v, 32, 0.02);
    const PowerSpectrum b = PowerSpectrum::measure_2d(v, 32, 32, 0.02);
    EXPECT_EQ(a.half_complex(), b.half_complex());
    EXPECT_EQ(a.variance(), b.variance());
    const RadialSpectrum ra = a.radial(), rb = b.radial();
    EXPECT_EQ(ra.power, rb.power);
    EXPECT_EQ(ra.q_per_um, rb.q_per_um);
}

TEST(WaveBorn2d, RectangularSpectrumOfADiscIsItsFormFactor) {
    // a = 0.2 µm (20 pixels) in a 6.4 × 4.8 µm cell: S(q) = (A_disc)² F(qa)² / A for q ≠ 0
    // (one disc: the mean's subtraction removes only q = 0).
    const int nx = 640, ny = 480;
    const double h = 0.01, a = 0.2;
    std::size_t pixels = 0;
    const auto v = disc_field(nx, ny, h, a, &pixels);
    const PowerSpectrum s = PowerSpectrum::measure_2d(v, nx, ny, h);
    const RadialSpectrum r = s.radial();
    const double area_disc = static_cast<double>(pixels) * h * h;
    const double a_eq = std::sqrt(area_disc / kPi);  // the voxelised disc's equivalent radius
    const double cell = nx * ny * h * h;
    int checked = 0;
    for (std::size_t i = 0; i < r.q_per_um.size(); ++i) {
        const double x = r.q_per_um[i] * a_eq;
        if (x > 2.5) break;  // before the first zero (3.83), where relative errors stay small
        const double expected = area_disc * area_disc * disc_form_factor(x) / cell;
        EXPECT_NEAR(r.power[i] / expected, 1.0, 0.02) << "q = " << r.q_per_um[i];
        ++checked;
    }
    EXPECT_GT(checked, 10);
}

TEST(WaveBorn2d, DiluteThinCylindersReproduceTheRayleighCylinder) {
    // ρ cylinders of radius a per µm², uncorrelated: S̄ = ρ (πa²)² F(qa)². Low contrast, ka → 0:
    // C_TE = π² k³ a⁴ Δε²/4 (van de Hulst §15.3, E along the axis), C_TM = C_TE / 2.
    const double a = 5e-4, rho = 3.0, d_eps = 0.01, lambda_nm = 500.0, n_eff = 1.0;
    auto spectrum = [&](double q) {
        return rho * std::pow(kPi * a * a, 2) * disc_form_factor(q * a);
    };
    const double k = kTwoPi / (lambda_nm * 1e-3) * n_eff;
    const double c_te = kPi * kPi * std::pow(k, 3) * std::pow(a, 4) * d_eps * d_eps / 4.0;
    const FlatlandTable te =
        born_scattering_2d(spectrum, d_eps, n_eff, lambda_nm, Polarisation2d::te);
    const FlatlandTable tm =
        born_scattering_2d(spectrum, d_eps, n_eff, lambda_nm, Polarisation2d::tm);
    // (ka)² ≈ 4e-5: the form factor's departure from 1 is below 1e-4 relative.
    EXPECT_NEAR(te.mu_s_per_um / (rho * c_te), 1.0, 1e-4);
    EXPECT_NEAR(tm.mu_s_per_um / (rho * c_te / 2.0), 1.0, 1e-4);
    // TE is isotropic in the plane, TM goes as cos²θ; both have g = 0 here.
    EXPECT_NEAR(te.g, 0.0, 1e-4);
    EXPECT_NEAR(tm.g, 0.0, 1e-4);
    EXPECT_NEAR(te.phase_per_rad.front(), 1.0 / kTwoPi, 1e-4 / kTwoPi);
    EXPECT_NEAR(tm.phase_per_rad.front(), 1.0 / kPi, 1e-4 / kPi);
    EXPECT_NEAR(tm.phase_per_rad[tm.phase_per_rad.size() / 2], 0.0, 1e-12);  // θ = π/2
}

TEST(WaveBorn2d, PipelineOnOneDiscMatchesItsCrossSection) {
    // power spectrum → born_flatland for a single voxelised disc (a = 0.05 µm) in a 2.56 ×
    // 1.92 µm cell: μ_s A is the disc's RGD scattering width ∫ dσ/dθ dθ with its form factor.
    const int nx = 256, ny = 192;
    const double h = 0.01, a = 0.05, lambda_nm = 500.0;
    std::size_t pixels = 0;
    const auto v = disc_field(nx, ny, h, a, &pixels);
    const PowerSpectrum s = PowerSpectrum::measure_2d(v, nx, ny, h);
    const optics::ConstantMaterial keratin("keratin", 1.55), air("air", 1.0);
    const double cell = nx * ny * h * h;
    const double area_disc = static_cast<double>(pixels) * h * h;
    const double a_eq = std::sqrt(area_disc / kPi);
    for (Polarisation2d pol : {Polarisation2d::te, Polarisation2d::tm}) {
        const FlatlandTable t = born_flatland(s, keratin, air, lambda_nm, pol);
        const double f = s.filling_fraction();
        const double n_eff = std::sqrt(effective_permittivity_2d(1.55 * 1.55, 1.0, f, pol).real());
        EXPECT_DOUBLE_EQ(t.n_eff, n_eff);
        const double k0 = kTwoPi / (lambda_nm * 1e-3), k = k0 * n_eff, d_eps = 1.55 * 1.55 - 1;
        double integral = 0.0;  // 2 ∫_0^π F² P dθ, midpoint rule
        const int m = 20000;
        for (int i = 0; i < m; ++i) {
            const double th = kPi * (i + 0.5) / m;
            const double dipole = pol == Polarisation2d::te ? 1.0 : std::pow(std::cos(th), 2);
            integral += disc_form_factor(2.0 * k * std::sin(0.5 * th) * a_eq) * dipole;
        }
        integral *= 2.0 * kPi / m;
        const double expected = std::pow(k0, 4) * d_eps * d_eps * area_disc * area_disc /
                                (8.0 * kPi * k) * integral / cell;
        // The voxelised disc's form factor departs from the round one's by ~1 % at qa ≈ 1.3.
        EXPECT_NEAR(t.mu_s_per_um / expected, 1.0, 0.02) << polarisation_name(pol);
    }
}

TEST(WaveBorn2d, EffectivePermittivityPerPolarisation) {
    const std::complex<double> e1 = 2.4025, e2 = 1.0;
    EXPECT_NEAR(effective_permittivity_2d(e1, e2, 0.3, Polarisation2d::te).real(),
                0.3 * 2.4025 + 0.7, 1e-15);
    // Dykhne: at f = ½ the 2D Bruggeman (TM) is √(ε1 ε2).
    EXPECT_NEAR(effective_permittivity_2d(e1, e2, 0.5, Polarisation2d::tm).real(),
                std::sqrt(2.4025), 1e-14);
    // Dilute inclusions: dε/df at f = 0 is 2 ε2 (ε1 − ε2)/(ε1 + ε2) (circular inclusions).
    const double df = 1e-7;
    const double slope =
        (effective_permittivity_2d(e1, e2, df, Polarisation2d::tm).real() - 1.0) / df;
    EXPECT_NEAR(slope, 2.0 * 1.4025 / 3.4025, 1e-5);
    // Ends, symmetry under exchanging the phases, and the TM < TE ordering (Wiener bounds).
    EXPECT_EQ(effective_permittivity_2d(e1, e2, 0.0, Polarisation2d::tm), e2);
    EXPECT_EQ(effective_permittivity_2d(e1, e2, 1.0, Polarisation2d::tm), e1);
    EXPECT_NEAR(effective_permittivity_2d(e1, e2, 0.3, Polarisation2d::tm).real(),
                effective_permittivity_2d(e2, e1, 0.7, Polarisation2d::tm).real(), 1e-14);
    for (double f : {0.1, 0.5, 0.9}) {
        EXPECT_LT(effective_permittivity_2d(e1, e2, f, Polarisation2d::tm).real(),
                  effective_permittivity_2d(e1, e2, f, Polarisation2d::te).real());
    }
}

TEST(WaveBorn2d, RefusesBadInput) {
    using testing::input_error_message;
    EXPECT_EQ(
        input_error_message([] { effective_permittivity_2d(2.0, 1.0, 1.5, Polarisation2d::tm); }),
        "2D effective permittivity: f = 1.5: expected an area fraction in [0, 1]");
    EXPECT_NE(input_error_message([] {
                  effective_permittivity_2d(-2.0, 1.0, 0.5, Polarisation2d::te);
              }).find("eps1 = (-2, 0)"),
              std::string::npos);
    auto flat = [](double) { return 1e-3; };
    EXPECT_EQ(
        input_error_message([&] { born_scattering_2d(flat, 1.4, 1.2, -5.0, Polarisation2d::te); }),
        "2D Born medium: lambda = -5 nm: expected a finite wavelength > 0");
    EXPECT_NE(input_error_message([&] {
                  born_scattering_2d(flat, 1.4, 0.0, 500.0, Polarisation2d::te);
              }).find("n_eff = 0"),
              std::string::npos);
    EXPECT_NE(input_error_message([&] {
                  born_scattering_2d(flat, 1.4, 1.2, 500.0, Polarisation2d::te, 1);
              }).find("table_points = 1"),
              std::string::npos);
    const optics::ConstantMaterial keratin("keratin", 1.55), air("air", 1.0);
    const auto v3 = random_indicator(8 * 8 * 8, 0.5, 3);
    const PowerSpectrum s3 = PowerSpectrum::measure_3d(v3, 8, 0.01);
    EXPECT_NE(input_error_message([&] {
                  born_flatland(s3, keratin, air, 500.0, Polarisation2d::te);
              }).find("3D power spectrum"),
              std::string::npos);
    const PowerSpectrum coarse =
        PowerSpectrum::measure_2d(random_indicator(16 * 12, 0.5, 4), 16, 12, 0.2);
    EXPECT_NE(input_error_message(
                  [&] { born_flatland(coarse, keratin, air, 500.0, Polarisation2d::te); }),
              "no InputError");
    EXPECT_NE(input_error_message([] {
                  PowerSpectrum::measure_2d(std::vector<double>(40 * 3), 40, 3, 0.01);
              }).find("ny = 3 pixels: expected 4 <= ny <= 1024"),
              std::string::npos);
    EXPECT_NE(input_error_message([] {
                  PowerSpectrum::measure_2d(std::vector<double>(40 * 30 - 1), 40, 30, 0.01);
              }).find("1199 values: expected nx * ny = 1200"),
              std::string::npos);
}

}  // namespace
}  // namespace plumage::sim::wave
