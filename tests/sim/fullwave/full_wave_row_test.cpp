// Periodic rows in full wave (full_wave_row, sim/fullwave/full_wave_2d.h) against what is known
// without it: a planar film seen as a row of any period against the transfer matrix at oblique
// incidence (TE and TM: the Bloch phase, the oblique source and the order split), energy
// conservation R + T = 1 for a lossless grating of many orders, the grating equation for the
// orders' directions, and reciprocity (an order's efficiency is the same with the light
// reversed) for an absorbing, asymmetric grating. Tolerances are the runs' own resolution
// error: a run at r and at 1.5 r, the fine run's error bounded by 2 |fine − coarse|.
#include <cmath>
#include <complex>
#include <memory>
#include <numbers>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "common/error.h"
#include "sim/fullwave/full_wave_2d.h"
#include "sim/optics/multilayer.h"
#include "tests/test_util.h"

namespace plumage::sim::fullwave {
namespace {

constexpr double kPi = std::numbers::pi;

FullWaveRowResult row(const CrossSection2d& s, double period_um, Polarisation2d pol, double theta_i,
                      std::span<const double> lambdas, double res) {
    FullWave2dOptions o;
    o.resolution_px_per_um = res;
    return full_wave_row(s, period_um, pol, theta_i, lambdas, o);
}

// A keratin film 0.59 µm thick in air, as a row four grid cells wide (order 0 alone propagates),
// lit at 50° (450 nm; 650 nm passes as well): R and T against the transfer matrix within the stated
// error and the interfaces' wobble (full_wave_2d_test.cpp: 2e-4 at these grids).
TEST(FullWaveRow, FilmAtObliqueIncidenceMatchesTransferMatrix) {
    CrossSection2d film;
    film.bodies.push_back({layer(-0.59, 0.0), optics::keratin()});
    const std::array<double, 1> lambdas{450.0};  // the larger grid error of the two ends
    const double theta_deg = 50.0, theta = theta_deg * kPi / 180.0;
    for (const Polarisation2d pol : {Polarisation2d::te, Polarisation2d::tm}) {
        SCOPED_TRACE(fmt::format("{}°, {}", theta_deg, wave::polarisation_name(pol)));
        const FullWaveRowResult coarse = row(film, 4.0 / 180.0, pol, theta, lambdas, 180.0);
        const FullWaveRowResult fine = row(film, 4.0 / 270.0, pol, theta, lambdas, 270.0);
        for (std::size_t k = 0; k < lambdas.size(); ++k) {
            const RowSpectrum& f = fine.wavelengths[k];
            ASSERT_EQ(f.reflected.size(), 1u);
            ASSERT_EQ(f.transmitted.size(), 1u);
            EXPECT_NEAR(f.reflected[0].theta_s_rad, -theta, 1e-12);  // specular
            EXPECT_NEAR(f.transmitted[0].theta_s_rad, theta - kPi, 1e-12);
            const std::array<optics::StackLayer, 1> layers{
                optics::StackLayer{optics::keratin()->index(lambdas[k]), 0.59}};
            const optics::StackIntensities tmm = optics::transfer_matrix_intensities(
                {1.0, layers, 1.0}, lambdas[k], std::cos(theta),
                pol == Polarisation2d::te ? optics::Polarisation::s : optics::Polarisation::p);
            const double r_error =
                2.0 * std::abs(f.reflectance - coarse.wavelengths[k].reflectance) + 2e-4;
            const double t_error =
                2.0 * std::abs(f.transmittance - coarse.wavelengths[k].transmittance) + 2e-4;
            fmt::print(
                "{}° {} {} nm: R {:.5f} (transfer matrix {:.5f}, ±{:.1e}), T {:.5f} "
                "({:.5f}, ±{:.1e}); {:.1f} s\n",
                theta_deg, wave::polarisation_name(pol), lambdas[k], f.reflectance, tmm.reflectance,
                r_error, f.transmittance, tmm.transmittance, t_error, fine.seconds);
            EXPECT_NEAR(f.reflectance, tmm.reflectance, r_error);
            EXPECT_NEAR(f.transmittance, tmm.transmittance, t_error);
        }
    }
}

// One period of a grating: an ellipse 0.6 × 0.3 µm turned by 0.4 rad (no mirror symmetry),
// period 1 µm, of a constant index.
CrossSection2d grating(std::complex<double> n) {
    CrossSection2d s;
    s.bodies.push_back({ellipse({0.0, 0.0}, 0.3, 0.15, 0.4),
                        std::make_shared<optics::ConstantMaterial>("grating", n)});
    return s;
}

// A lossless grating at 20°, 500 nm: four reflected and four transmitted orders, whose powers
// add to the incident power within the runs' stated error (nothing else carries power away),
// in directions the grating equation gives, sin θ_m = −sin θ_i + m λ/Λ.
TEST(FullWaveRow, LosslessGratingConservesPowerOverItsOrders) {
    const std::array<double, 1> lambdas{500.0};
    const double theta = 20.0 * kPi / 180.0;
    for (const Polarisation2d pol : {Polarisation2d::te, Polarisation2d::tm}) {
        SCOPED_TRACE(std::string(wave::polarisation_name(pol)));
        const RowSpectrum coarse =
            row(grating({1.56, 0.0}), 1.0, pol, theta, lambdas, 40.0).wavelengths.front();
        const RowSpectrum fine =
            row(grating({1.56, 0.0}), 1.0, pol, theta, lambdas, 60.0).wavelengths.front();
        ASSERT_EQ(fine.reflected.size(), 4u);
        ASSERT_EQ(fine.transmitted.size(), 4u);
        for (const DiffractionOrder& o : fine.reflected)
            EXPECT_NEAR(std::sin(o.theta_s_rad), -std::sin(theta) + o.m * 0.5, 1e-12);
        const double total = fine.reflectance + fine.transmittance;
        const double error = 2.0 * std::abs(total - coarse.reflectance - coarse.transmittance);
        fmt::print("{}: R {:.5f} over {} orders, T {:.5f}; R + T = {:.6f} (stated error {:.1e})\n",
                   wave::polarisation_name(pol), fine.reflectance, fine.reflected.size(),
                   fine.transmittance, total, error);
        EXPECT_NEAR(total, 1.0, error + 1e-4);
        EXPECT_GT(fine.reflected.size(), 1u);
    }
}

// Reciprocity (a law of any linear, reciprocal medium, absorbing or not): order m's efficiency
// from θ_i equals order m's from the direction θ_m it went to, the light sent back. An
// absorbing, tilted grating (no symmetry makes the two runs alike): 20° → order 1 at 9.07°,
// and back. The grid is reciprocal too (Yee's scheme, a symmetric smoothed ε, the PML), so on
// one grid the two agree far closer than the grid's own error (measured: 3e-5 of the
// efficiency): held to 1e-3 of it, which a wrong Bloch phase, source or order split breaks.
TEST(FullWaveRow, OrderEfficienciesAreReciprocal) {
    const std::array<double, 1> lambdas{500.0};
    const double theta = 20.0 * kPi / 180.0;
    const double theta_1 = std::asin(-std::sin(theta) + 0.5);
    for (const Polarisation2d pol : {Polarisation2d::te, Polarisation2d::tm}) {
        SCOPED_TRACE(std::string(wave::polarisation_name(pol)));
        const auto order_1 = [&](double from) {
            const RowSpectrum r =
                row(grating({1.7, 0.2}), 1.0, pol, from, lambdas, 60.0).wavelengths.front();
            for (const DiffractionOrder& o : r.reflected)
                if (o.m == 1) return o;
            ADD_FAILURE() << "no order 1";
            return DiffractionOrder{};
        };
        const DiffractionOrder there = order_1(theta), back = order_1(theta_1);
        EXPECT_NEAR(there.theta_s_rad, theta_1, 1e-12);
        EXPECT_NEAR(back.theta_s_rad, theta, 1e-12);
        fmt::print("{}: order 1 {:.7f} there, {:.7f} back\n", wave::polarisation_name(pol),
                   there.efficiency, back.efficiency);
        EXPECT_NEAR(there.efficiency, back.efficiency, 1e-3 * there.efficiency);
        EXPECT_GT(there.efficiency, 1e-3);  // not trivially zero
    }
}

}  // namespace
}  // namespace plumage::sim::fullwave
