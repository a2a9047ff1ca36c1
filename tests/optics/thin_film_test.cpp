// The Airy film against the transfer-matrix solver (a different code path: 2×2 matrix
// products) and against its own limits.
#include "sim/optics/thin_film.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
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

// Independent reference for a lossless film with propagating waves: the textbook
// R = |r12 + r23 e^{iδ}|² / |1 + r12 r23 e^{iδ}|², T = 1 − R, from the amplitudes, in
// long double (64-bit mantissa) from the same double-rounded phase, so that its own
// round-off near grazing (ε / cos θ) stays well below the 1e-13 asked of the fast path.
struct Reference {
    bool applies;
    long double reflectance, transmittance;
};
Reference lossless_reference(double above, double film, double below, double d_um, double lambda_nm,
                             double cos_i, Polarisation pol) {
    using L = long double;
    // q² = (n² − n0²) + q0² rounded in double, as every double-precision path rounds it:
    // within ~1e-9 of a critical angle that rounding decides between a propagating and an
    // evanescent wave, a difference in the input, not in the formula under test.
    const double q1_double = above * cos_i;
    const double q2sq = (film * film - above * above) + q1_double * q1_double;
    const double q3sq = (below * below - above * above) + q1_double * q1_double;
    if (!(q1_double > 0.0) || !(q2sq > 0.0) || !(q3sq > 0.0)) return {false, 0, 0};
    const L n1 = above, n2 = film, n3 = below, q1 = q1_double;
    const L q2 = std::sqrt(L(q2sq)), q3 = std::sqrt(L(q3sq));
    L x1 = q1, x2 = q2, x3 = q3;
    if (pol == Polarisation::p) x1 /= n1 * n1, x2 /= n2 * n2, x3 /= n3 * n3;
    const L r12 = (x1 - x2) / (x1 + x2), r23 = (x2 - x3) / (x2 + x3);
    // The phase δ/2 = k0 d q2 as the code rounds it in double: at 5 µm it reaches ~300 rad,
    // and near grazing R's slope in δ (the film's finesse) turns that rounding, shared by
    // every double-precision path, into differences above 1e-13 that no formula removes.
    const double k0_d = 2.0 * std::numbers::pi * d_um * 1000.0 / lambda_nm;
    const double q2_double =
        std::sqrt((film * film - above * above) + (above * cos_i) * (above * cos_i));
    const L sin_sq = std::sin(L(k0_d * q2_double)) * std::sin(L(k0_d * q2_double));
    // |a + b e^{iδ}|² = (a + b)² − 4ab sin²(δ/2): unlike a² + b² + 2ab cos δ it keeps its
    // digits when δ is small and a ≈ −b (just inside a critical angle of the film).
    const L ab = r12 * r23;
    const L r =
        ((r12 + r23) * (r12 + r23) - 4 * ab * sin_sq) / ((1 + ab) * (1 + ab) - 4 * ab * sin_sq);
    return {true, r, 1 - r};
}

// The lossless real-arithmetic path of airy_film_intensities against the complex path
// (detail::airy_film_intensities_complex), the transfer-matrix solver and a long-double
// closed form, over the film
// thicknesses, visible wavelengths, angles and keratin-like indices the models use. The
// absorbing (melanin-like) medium below and the TIR cases take the complex path on both
// sides; they are in the grid to check the dispatch.
TEST(ThinFilm, LosslessFastPathEqualsComplexPath) {
    constexpr double kTolerance = 1e-13;
    struct Media {
        double above;
        Complex below;
    };
    // Above 1.56 (light inside keratin) puts the critical angles of film and below in range.
    const std::vector<Media> media = {{1.0, Complex(1.0)},
                                      {1.0, Complex(1.56)},
                                      {1.0, Complex(1.65, 0.5)},
                                      {1.56, Complex(1.0)},
                                      {1.56, Complex(1.56)}};
    std::vector<double> degrees;
    for (double deg = 0.0; deg <= 85.0; deg += 5.0) degrees.push_back(deg);
    for (double deg : {87.0, 89.0, 89.5, 89.9}) degrees.push_back(deg);
    double worst_complex = 0.0, worst_tmm = 0.0, worst_reference = 0.0;
    double air_complex = 0.0, air_tmm = 0.0, air_reference = 0.0;  // light from air
    int evaluations = 0;
    for (const Media& m : media) {
        for (double n_film = 1.3; n_film <= 1.8 + 1e-9; n_film += 0.1) {
            const Complex film(n_film);
            std::vector<double> cosines;
            for (double deg : degrees) cosines.push_back(std::cos(deg * std::numbers::pi / 180.0));
            // Near-TIR: just before and after the critical angles in the film and below.
            for (Complex n : {film, m.below}) {
                const double sin_critical = n.real() / m.above;
                if (n.imag() != 0.0 || sin_critical >= 1.0) continue;
                for (double offset : {-1e-3, -1e-6, -1e-9, 0.0, 1e-9, 1e-6, 1e-3}) {
                    const double s = std::clamp(sin_critical + offset, 0.0, 1.0);
                    cosines.push_back(std::sqrt(1.0 - s * s));
                }
            }
            for (double d_um : {0.0, 0.05, 0.3, 0.595, 1.234, 2.5, 5.0}) {
                for (double lambda = 380.0; lambda <= 780.0; lambda += 20.0) {
                    for (double cos_i : cosines) {
                        const FilmMedia fm{m.above, film, m.below};
                        const auto cos_in = [&](Complex n) {
                            return std::abs(normal_wavevector(n, m.above, cos_i) / n);
                        };
                        const double smallest_cos =
                            std::min({cos_i, cos_in(film), cos_in(m.below)});
                        const StackLayer layer{film, d_um};
                        const StackIndices stack{m.above, std::span(&layer, 1), m.below};
                        for (Polarisation pol : kBoth) {
                            const FilmIntensities fast =
                                airy_film_intensities(fm, d_um, lambda, cos_i, pol);
                            const FilmIntensities slow =
                                detail::airy_film_intensities_complex(fm, d_um, lambda, cos_i, pol);
                            const StackIntensities tmm =
                                transfer_matrix_intensities(stack, lambda, cos_i, pol);
                            const Reference ref = lossless_reference(
                                m.above, n_film, m.below.real(), d_um, lambda, cos_i, pol);
                            const auto difference = [&](double r, double t) {
                                return std::max(std::abs(fast.reflectance - r),
                                                std::abs(fast.transmittance - t));
                            };
                            const double to_complex =
                                difference(slow.reflectance, slow.transmittance);
                            const double to_tmm = difference(tmm.reflectance, tmm.transmittance);
                            const double to_reference =
                                m.below.imag() == 0.0 && ref.applies
                                    ? difference(static_cast<double>(ref.reflectance),
                                                 static_cast<double>(ref.transmittance))
                                    : 0.0;
                            worst_complex = std::max(worst_complex, to_complex);
                            worst_tmm = std::max(worst_tmm, to_tmm);
                            worst_reference = std::max(worst_reference, to_reference);
                            if (m.above == 1.0) {
                                air_complex = std::max(air_complex, to_complex);
                                air_tmm = std::max(air_tmm, to_tmm);
                                air_reference = std::max(air_reference, to_reference);
                            }
                            // The complex path and the transfer matrix carry their own
                            // round-off of order ε / cos θ near grazing (test_util.h), and
                            // of order ε / cos θ_j near a critical angle in layer j.
                            const double tolerance =
                                plumage::testing::grazing_tolerance(kTolerance, smallest_cos);
                            const auto where = [&] {
                                return ::testing::Message()
                                       << "above " << m.above << ", film " << n_film << ", below "
                                       << m.below << ", d = " << d_um << " um, lambda = " << lambda
                                       << ", cos = " << cos_i << ", pol " << static_cast<int>(pol);
                            };
                            // The long-double reference's own round-off, ε_L / cos θ_j, is ~1e-11
                            // at 1e-9 from a critical angle (q_2 ~ 1e-8); 6e-16 from air.
                            const double reference_tolerance =
                                kTolerance + 10.0 *
                                                 static_cast<double>(
                                                     std::numeric_limits<long double>::epsilon()) /
                                                 smallest_cos;
                            ASSERT_LE(to_reference, reference_tolerance) << where();
                            ASSERT_LE(to_complex, tolerance) << where();
                            ASSERT_LE(to_tmm, tolerance) << where();
                            ++evaluations;
                        }
                        const FilmIntensities u =
                            airy_film_intensities_unpolarised(fm, d_um, lambda, cos_i);
                        const FilmIntensities s =
                            airy_film_intensities(fm, d_um, lambda, cos_i, Polarisation::s);
                        const FilmIntensities p =
                            airy_film_intensities(fm, d_um, lambda, cos_i, Polarisation::p);
                        ASSERT_EQ(u.reflectance, 0.5 * (s.reflectance + p.reflectance));
                        ASSERT_EQ(u.transmittance, 0.5 * (s.transmittance + p.transmittance));
                    }
                }
            }
        }
    }
    RecordProperty("worst_difference_to_complex_path", std::to_string(worst_complex));
    RecordProperty("worst_difference_to_transfer_matrix", std::to_string(worst_tmm));
    RecordProperty("worst_difference_to_long_double", std::to_string(worst_reference));
    std::printf(
        "worst |fast - long double|, |fast - complex|, |fast - transfer matrix|: %.3g, %.3g, "
        "%.3g from air; %.3g, %.3g, %.3g in all (%d evaluations)\n",
        air_reference, air_complex, air_tmm, worst_reference, worst_complex, worst_tmm,
        evaluations);
    EXPECT_GT(evaluations, 100000);
}

TEST(ThinFilm, LosslessFastPathStaysFiniteAtExtremes) {
    // Nearly grazing, index-matched and very large indices: the quartic real forms are scaled
    // (or left to the complex path) so that nothing overflows or underflows to 0/0.
    for (double cos_i : {1e-300, 1e-60, 1e-40, 1e-8}) {
        for (const FilmMedia& m : {FilmMedia{1.0, Complex(1.0), Complex(1.0)},
                                   FilmMedia{1.0, Complex(1.55), Complex(1.0)},
                                   FilmMedia{1.0, Complex(1e30), Complex(1e-30)},
                                   FilmMedia{1e-30, Complex(1e30), Complex(1.0)}}) {
            for (Polarisation pol : kBoth) {
                const FilmIntensities fast = airy_film_intensities(m, 0.595, 550.0, cos_i, pol);
                const FilmIntensities slow =
                    detail::airy_film_intensities_complex(m, 0.595, 550.0, cos_i, pol);
                ASSERT_TRUE(std::isfinite(fast.reflectance) && std::isfinite(fast.transmittance))
                    << cos_i << " " << m.film;
                EXPECT_NEAR(fast.reflectance, slow.reflectance, 1e-12) << cos_i << " " << m.film;
                EXPECT_NEAR(fast.transmittance, slow.transmittance, 1e-12)
                    << cos_i << " " << m.film;
            }
        }
    }
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
