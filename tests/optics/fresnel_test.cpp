// Fresnel against closed forms: normal incidence, Brewster's angle, energy balance,
// total internal reflection, absorbing media, grazing incidence, bad input.
#include "sim/optics/fresnel.h"
#include "common/constants.h"

#include <cmath>

#include <gtest/gtest.h>

#include "common/error.h"
#include "tests/test_util.h"

namespace plumage::optics {
namespace {

constexpr Polarisation kBoth[] = {Polarisation::s, Polarisation::p};

TEST(Fresnel, NormalIncidenceMatchesClosedFormFromEitherSide) {
    for (double n : {1.0001, 1.333, 1.532, 2.4, 4.0}) {
        const double expected = std::pow((n - 1.0) / (n + 1.0), 2);
        for (Polarisation pol : kBoth) {
            const auto into = fresnel_intensities(1.0, Complex(n), 1.0, pol);
            const auto out_of = fresnel_intensities(n, Complex(1.0), 1.0, pol);
            EXPECT_NEAR(into.reflectance, expected, 1e-15) << "n = " << n;
            EXPECT_NEAR(out_of.reflectance, expected, 1e-15) << "n = " << n;
            EXPECT_NEAR(into.transmittance, 1.0 - expected, 1e-15);
            EXPECT_NEAR(out_of.transmittance, 1.0 - expected, 1e-15);
        }
    }
}

TEST(Fresnel, AbsorbingMediumAtNormalIncidence) {
    // R = |(n − 1)/(n + 1)|² for complex n.
    for (Complex n : {Complex(1.74, 0.088), Complex(0.2, 3.0), Complex(1.5, 10.0)}) {
        const double expected = std::norm((n - 1.0) / (n + 1.0));
        for (Polarisation pol : kBoth) {
            const auto i = fresnel_intensities(1.0, n, 1.0, pol);
            EXPECT_NEAR(i.reflectance, expected, 1e-14);
            // No absorption at the interface itself: what is not reflected enters.
            EXPECT_NEAR(i.reflectance + i.transmittance, 1.0, 1e-14);
        }
    }
}

TEST(Fresnel, PReflectanceVanishesAtBrewstersAngle) {
    for (auto [n1, n2] : {std::pair{1.0, 1.532}, std::pair{1.532, 1.0}, std::pair{1.0, 2.4}}) {
        const double brewster = std::atan(n2 / n1);
        const auto p = fresnel_intensities(n1, Complex(n2), std::cos(brewster), Polarisation::p);
        const auto s = fresnel_intensities(n1, Complex(n2), std::cos(brewster), Polarisation::s);
        EXPECT_LT(p.reflectance, 1e-28) << n1 << " -> " << n2;
        EXPECT_GT(s.reflectance, 0.01);
    }
}

TEST(Fresnel, LosslessEnergyBalanceOverAllAngles) {
    for (auto [n1, n2] : {std::pair{1.0, 1.532}, std::pair{1.532, 1.0}, std::pair{1.33, 1.5}}) {
        for (int i = 0; i <= 900; ++i) {
            const double theta = 0.1 * i * kPi / 180.0;
            for (Polarisation pol : kBoth) {
                const auto r = fresnel_intensities(n1, Complex(n2), std::cos(theta), pol);
                EXPECT_NEAR(r.reflectance + r.transmittance, 1.0, 1e-13) << theta;
                EXPECT_GE(r.reflectance, 0.0);
                EXPECT_GE(r.transmittance, 0.0);
            }
        }
    }
}

TEST(Fresnel, TotalInternalReflectionInsideKeratin) {
    const double n = 1.55;
    const double critical = std::asin(1.0 / n);
    for (double theta : {critical + 1e-9, critical + 0.1, 1.2, kPi / 2}) {
        for (Polarisation pol : kBoth) {
            const auto r = fresnel_intensities(n, Complex(1.0), std::cos(theta), pol);
            EXPECT_NEAR(r.reflectance, 1.0, 1e-12) << theta;
            EXPECT_EQ(r.transmittance, 0.0);
        }
    }
    // Just below the critical angle some light still leaves.
    const auto below =
        fresnel_intensities(n, Complex(1.0), std::cos(critical - 1e-3), Polarisation::s);
    EXPECT_GT(below.transmittance, 0.0);
}

TEST(Fresnel, GrazingIncidenceReflectsEverything) {
    for (Complex n2 : {Complex(1.532), Complex(1.7, 0.1), Complex(1.0, 10.0)}) {
        for (Polarisation pol : kBoth) {
            const auto a = fresnel_amplitudes(1.0, n2, 0.0, pol);
            EXPECT_NEAR(std::abs(a.r + 1.0), 0.0, 1e-15);
            EXPECT_EQ(fresnel_intensities(1.0, n2, 0.0, pol).transmittance, 0.0);
        }
    }
    // Index-matched media: no interface even at grazing (the formulas' 0/0).
    const auto matched = fresnel_intensities(1.5, Complex(1.5), 0.0, Polarisation::p);
    EXPECT_EQ(matched.reflectance, 0.0);
}

TEST(Fresnel, StokesRelationsHold) {
    // t12 t21 − r12 r21 = 1 with r21 = −r12: the identity Airy's form relies on.
    const Complex n1(1.0), n2(1.55, 0.02);
    const Complex q1 = normal_wavevector(n1, 1.0, std::cos(0.7)),
                  q2 = normal_wavevector(n2, 1.0, std::cos(0.7));
    for (Polarisation pol : kBoth) {
        const auto a12 = fresnel_amplitudes(n1, q1, n2, q2, pol);
        const auto a21 = fresnel_amplitudes(n2, q2, n1, q1, pol);
        EXPECT_NEAR(std::abs(a12.t * a21.t - a12.r * a21.r - 1.0), 0.0, 1e-15);
        EXPECT_NEAR(std::abs(a12.r + a21.r), 0.0, 1e-15);
    }
}

TEST(Fresnel, RejectsBadInputNamingTheValue) {
    using plumage::testing::input_error_message;
    EXPECT_NE(input_error_message([] {
                  fresnel_intensities(1.0, Complex(1.5), 1.5, Polarisation::s);
              }).find("1.5 is outside [0, 1]"),
              std::string::npos);
    EXPECT_NE(input_error_message([] {
                  fresnel_intensities(1.0, Complex(1.5), NAN, Polarisation::s);
              }).find("nan"),
              std::string::npos);
    EXPECT_NE(input_error_message([] {
                  fresnel_intensities(1.0, Complex(1.5, -0.1), 1.0, Polarisation::s);
              }).find("k >= 0"),
              std::string::npos);
    EXPECT_NE(input_error_message([] {
                  fresnel_intensities(1.2, Complex(1.5), 1.0, Polarisation::s);
              }).find("no InputError"),
              std::string::npos);
}

}  // namespace
}  // namespace plumage::optics
