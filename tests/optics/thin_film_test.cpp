// The Airy film against the transfer-matrix solver (a different code path: 2×2 matrix
// products) and against its own limits.
#include "sim/optics/thin_film.h"

#include <cmath>
#include <numbers>
#include <vector>

#include <gtest/gtest.h>

#include "sim/optics/material.h"
#include "sim/optics/multilayer.h"
#include "tests/test_util.h"

namespace plumage::optics {
namespace {

constexpr Polarisation kBoth[] = {Polarisation::s, Polarisation::p};

std::vector<double> incidence_cosines() {
    std::vector<double> cosines;
    for (double deg : {0.0, 10.0, 30.0, 45.0, 57.0, 70.0, 85.0, 89.0, 89.99}) {
        cosines.push_back(std::cos(deg * std::numbers::pi / 180.0));
    }
    cosines.push_back(0.0);  // exactly grazing
    return cosines;
}

TEST(ThinFilm, AiryEqualsTransferMatrixForOneFilm) {
    struct Case {
        double above;
        Complex film, below;
    };
    const std::vector<Case> cases = {
        {1.0, Complex(1.55), Complex(1.0)},          // keratin film in air (Huang)
        {1.0, Complex(1.55), Complex(1.74, 0.088)},  // keratin on melanin
        {1.0, Complex(1.74, 0.088), Complex(1.55)},  // absorbing film
        {1.55, Complex(1.0), Complex(1.55)},         // air gap in keratin: frustrated TIR
        {1.0, Complex(2.0, 3.0), Complex(1.5, 10.0)},
    };
    double worst = 0.0;
    int evaluations = 0;
    for (const Case& c : cases) {
        for (double d_um : {0.0, 0.01, 0.1, 0.53, 0.595, 1.7, 10.0}) {
            for (double cos_i : incidence_cosines()) {
                for (double lambda : {380.0, 450.0, 532.0, 650.0, 830.0}) {
                    for (Polarisation pol : kBoth) {
                        const FilmAmplitudes airy = airy_film_amplitudes({c.above, c.film, c.below},
                                                                         d_um, lambda, cos_i, pol);
                        const StackLayer layer{c.film, d_um};
                        const StackAmplitudes tmm = transfer_matrix_amplitudes(
                            {c.above, std::span(&layer, 1), c.below}, lambda, cos_i, pol);
                        worst =
                            std::max({worst, std::abs(airy.r - tmm.r), std::abs(airy.t - tmm.t)});
                        ASSERT_NEAR(std::abs(airy.r - tmm.r), 0.0, 1e-12)
                            << "d = " << d_um << " um, cos = " << cos_i << ", lambda = " << lambda;
                        ASSERT_NEAR(std::abs(airy.t - tmm.t), 0.0, 1e-12)
                            << "d = " << d_um << " um, cos = " << cos_i << ", lambda = " << lambda;
                        ++evaluations;
                    }
                }
            }
        }
    }
    RecordProperty("worst_amplitude_difference", std::to_string(worst));
    EXPECT_EQ(evaluations, 5 * 7 * 10 * 5 * 2);
}

TEST(ThinFilm, ZeroThicknessIsTheBareInterface) {
    for (Complex below : {Complex(1.0), Complex(1.74, 0.088), Complex(1.3, 5.0)}) {
        for (double cos_i : incidence_cosines()) {
            for (Polarisation pol : kBoth) {
                const auto film =
                    airy_film_amplitudes({1.0, Complex(1.55), below}, 0.0, 500.0, cos_i, pol);
                const auto bare = fresnel_amplitudes(1.0, below, cos_i, pol);
                const double tolerance = plumage::testing::grazing_tolerance(1e-14, cos_i);
                EXPECT_NEAR(std::abs(film.r - bare.r), 0.0, tolerance) << cos_i;
                EXPECT_NEAR(std::abs(film.t - bare.t), 0.0, tolerance) << cos_i;
            }
        }
    }
}

TEST(ThinFilm, VanishingThicknessConvergesToTheBareInterface) {
    // r(d) − r(0) = O(d/λ): the film's effect fades linearly.
    const FilmMedia media{1.0, Complex(1.55), Complex(1.74, 0.088)};
    const auto bare = fresnel_amplitudes(1.0, media.below, 1.0, Polarisation::s);
    double previous = 1.0;
    for (double d : {1e-2, 1e-3, 1e-4, 1e-5}) {
        const double diff =
            std::abs(airy_film_amplitudes(media, d, 500.0, 1.0, Polarisation::s).r - bare.r);
        EXPECT_LT(diff, previous / 5.0) << d;
        previous = diff;
    }
    EXPECT_LT(previous, 1e-4);
}

TEST(ThinFilm, LosslessFilmConservesEnergy) {
    for (double d_um : {0.0, 0.3, 0.595, 5.0}) {
        for (double cos_i : incidence_cosines()) {
            for (Polarisation pol : kBoth) {
                const auto i = airy_film_intensities({1.0, Complex(1.55), Complex(1.3)}, d_um,
                                                     550.0, cos_i, pol);
                EXPECT_NEAR(i.reflectance + i.transmittance, 1.0, 1e-13);
                EXPECT_NEAR(i.absorptance, 0.0, 1e-13);
            }
        }
    }
}

TEST(ThinFilm, SymmetricFilmAtNormalIncidenceMatchesTextbookMaxima) {
    // Quarter-wave film in air: R = ((n² − 1)/(n² + 1))² at λ = 4 n d.
    const double n = 1.55, d_um = 0.1;
    const double lambda = 4.0 * n * d_um * 1000.0;
    const auto i =
        airy_film_intensities({1.0, Complex(n), Complex(1.0)}, d_um, lambda, 1.0, Polarisation::s);
    EXPECT_NEAR(i.reflectance, std::pow((n * n - 1.0) / (n * n + 1.0), 2), 1e-14);
    // Half-wave film: invisible.
    const auto h = airy_film_intensities({1.0, Complex(n), Complex(1.0)}, d_um,
                                         2.0 * n * d_um * 1000.0, 1.0, Polarisation::p);
    EXPECT_NEAR(h.reflectance, 0.0, 1e-28);
}

TEST(ThinFilm, RejectsBadInput) {
    using plumage::testing::input_error_message;
    const FilmMedia media{1.0, Complex(1.55), Complex(1.0)};
    EXPECT_NE(input_error_message([&] {
                  airy_film_amplitudes(media, -0.1, 500.0, 1.0, Polarisation::s);
              }).find("thickness = -0.1 um"),
              std::string::npos);
    EXPECT_NE(input_error_message([&] {
                  airy_film_amplitudes(media, 0.5, 0.0, 1.0, Polarisation::s);
              }).find("wavelength = 0 nm"),
              std::string::npos);
    EXPECT_NE(input_error_message([&] {
                  airy_film_amplitudes(media, INFINITY, 500.0, 1.0, Polarisation::s);
              }).find("inf"),
              std::string::npos);
    EXPECT_NE(input_error_message([&] {
                  airy_film_amplitudes({1.0, Complex(NAN), Complex(1.0)}, 0.5, 500.0, 1.0,
                                       Polarisation::s);
              }).find("film"),
              std::string::npos);
}

}  // namespace
}  // namespace plumage::optics
