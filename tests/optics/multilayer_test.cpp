// The multilayer solver: energy with absorption (fields against reflectance),
// reciprocity, incoherent layers (phase average, no aliasing), stiff cases.
#include "sim/optics/multilayer.h"
#include "common/constants.h"

#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "sim/optics/material.h"
#include "sim/optics/thin_film.h"
#include "tests/test_util.h"

namespace plumage::optics {
namespace {

constexpr Polarisation kBoth[] = {Polarisation::s, Polarisation::p};

TEST(Multilayer, ReflectancePlusTransmittancePlusLayerAbsorptionIsOne) {
    // Absorption per layer comes from the Poynting flux of Rouard-recursion fields, an
    // independent path from the transfer-matrix R and T.
    const std::vector<StackLayer> layers = {
        {Complex(1.55), 0.595},        // keratin cortex
        {Complex(1.0), 0.12},          // air gap
        {Complex(1.74, 0.088), 0.25},  // melanin
        {Complex(1.55, 0.001), 1.0},   // weakly absorbing keratin
        {Complex(0.2, 3.0), 0.02},     // metal-like
    };
    for (Complex substrate : {Complex(1.55), Complex(1.74, 0.088), Complex(1.0)}) {
        for (double deg : {0.0, 20.0, 45.0, 60.0, 80.0, 89.99}) {
            for (double lambda : {400.0, 550.0, 700.0}) {
                for (Polarisation pol : kBoth) {
                    const StackIndices stack{1.0, layers, substrate};
                    const auto i =
                        transfer_matrix_intensities(stack, lambda, std::cos(deg * kDeg), pol);
                    const auto a =
                        coherent_layer_absorption(stack, lambda, std::cos(deg * kDeg), pol);
                    double absorbed = 0.0;
                    for (std::size_t j = 0; j < a.size(); ++j) {
                        EXPECT_GE(a[j], -1e-14) << "layer " << j;
                        absorbed += a[j];
                    }
                    EXPECT_NEAR(a[1], 0.0, 1e-13) << "the lossless air gap absorbs nothing";
                    EXPECT_NEAR(i.reflectance + i.transmittance + absorbed, 1.0, 1e-12)
                        << deg << " deg, " << lambda << " nm";
                    EXPECT_GT(absorbed, 0.0);
                }
            }
        }
    }
}

TEST(Multilayer, TransmittanceIsReciprocalWhenTheMediaAreSwapped) {
    // Between lossless outer media T(forward, θ0) = T(backward, θs) even though the
    // layers absorb; reflectance is not reciprocal then.
    const std::vector<StackLayer> layers = {{Complex(1.55), 0.53},
                                            {Complex(1.74, 0.088), 0.2},
                                            {Complex(1.0), 0.3},
                                            {Complex(1.6, 0.02), 0.7}};
    const std::vector<StackLayer> reversed(layers.rbegin(), layers.rend());
    const double n0 = 1.0, ns = 1.5;
    for (double deg : {0.0, 25.0, 50.0, 75.0, 89.0}) {
        const double sin0 = std::sin(deg * kDeg);
        const double cos_s = std::sqrt(1.0 - std::pow(n0 * sin0 / ns, 2));
        for (double lambda : {420.0, 560.0, 690.0}) {
            for (Polarisation pol : kBoth) {
                const auto forward = transfer_matrix_intensities({n0, layers, Complex(ns)}, lambda,
                                                                 std::cos(deg * kDeg), pol);
                const auto backward =
                    transfer_matrix_intensities({ns, reversed, Complex(n0)}, lambda, cos_s, pol);
                EXPECT_NEAR(forward.transmittance, backward.transmittance, 1e-13) << deg;
                EXPECT_GT(std::abs(forward.reflectance - backward.reflectance), 1e-4);
            }
        }
    }
}

TEST(Multilayer, IncoherentLayerIsThePhaseAverageOfTheCoherentOne) {
    // Averaging the coherent result over one period of the thick layer's phase is the
    // incoherent result exactly (the trapezoid rule on a periodic analytic function
    // converges geometrically; 256 samples are far beyond double precision here).
    const double lambda = 550.0, cos_i = std::cos(35.0 * kDeg);
    const double n_thick = 1.5, d0 = 20.0;
    const double beta = std::sin(35.0 * kDeg);
    const double q = std::sqrt(n_thick * n_thick - beta * beta);
    const double period_um = lambda / (2.0 * q) / 1000.0;
    for (Polarisation pol : kBoth) {
        auto stack = [&](double d, Coherence c) {
            return std::vector<StackLayer>{
                {Complex(1.55), 0.3}, {Complex(n_thick), d, c}, {Complex(1.0), 0.15}};
        };
        const auto incoherent_layers = stack(d0, Coherence::incoherent);
        const auto incoherent = transfer_matrix_intensities(
            {1.0, incoherent_layers, Complex(1.74, 0.088)}, lambda, cos_i, pol);
        constexpr int kSamples = 256;
        double r_mean = 0.0, t_mean = 0.0;
        for (int k = 0; k < kSamples; ++k) {
            const auto layers = stack(d0 + period_um * k / kSamples, Coherence::coherent);
            const auto c = transfer_matrix_intensities({1.0, layers, Complex(1.74, 0.088)}, lambda,
                                                       cos_i, pol);
            r_mean += c.reflectance / kSamples;
            t_mean += c.transmittance / kSamples;
        }
        EXPECT_NEAR(incoherent.reflectance, r_mean, 1e-12);
        EXPECT_NEAR(incoherent.transmittance, t_mean, 1e-12);
    }
}

TEST(Multilayer, IncoherentThickLayerDoesNotAliasUnderSpectralSampling) {
    // A 50 µm keratin slab: coherent fringes are ~1.6 nm apart, so a 1 nm grid aliases
    // them; the incoherent result is smooth.
    double coherent_jump = 0.0, incoherent_jump = 0.0, previous_c = -1.0, previous_i = -1.0;
    for (double lambda = 500.0; lambda <= 600.0; lambda += 1.0) {
        const Complex n = keratin()->index(lambda);
        const StackLayer coherent{n, 50.0, Coherence::coherent};
        const StackLayer incoherent{n, 50.0, Coherence::incoherent};
        const double rc = transfer_matrix_intensities({1.0, std::span(&coherent, 1), Complex(1.0)},
                                                      lambda, 1.0, Polarisation::s)
                              .reflectance;
        const double ri =
            transfer_matrix_intensities({1.0, std::span(&incoherent, 1), Complex(1.0)}, lambda, 1.0,
                                        Polarisation::s)
                .reflectance;
        if (previous_c >= 0.0) {
            coherent_jump = std::max(coherent_jump, std::abs(rc - previous_c));
            incoherent_jump = std::max(incoherent_jump, std::abs(ri - previous_i));
        }
        previous_c = rc;
        previous_i = ri;
        // Two incoherent interfaces: R = 2 R1 / (1 + R1).
        const double r1 = std::pow((n.real() - 1.0) / (n.real() + 1.0), 2);
        EXPECT_NEAR(ri, 2.0 * r1 / (1.0 + r1), 1e-14);
    }
    EXPECT_GT(coherent_jump, 0.05);
    EXPECT_LT(incoherent_jump, 1e-4);
}

TEST(Multilayer, FiniteAndBoundedOnADenseStiffGrid) {
    // 89.99° and exactly 90°, total internal reflection (keratin ambient over air),
    // k up to 10, thickness 0 to 100 µm (incoherent from 10 µm up).
    int evaluations = 0;
    for (double ambient : {1.0, 1.55}) {
        for (double k : {0.0, 1e-3, 0.1, 1.0, 10.0}) {
            for (double d_um : {0.0, 1e-4, 0.1, 0.595, 3.0, 10.0, 50.0, 100.0}) {
                for (double deg : {0.0, 30.0, 40.0, 41.0, 60.0, 89.0, 89.99, 90.0}) {
                    for (double lambda : {360.0, 550.0, 830.0}) {
                        for (Polarisation pol : kBoth) {
                            const Coherence coherence =
                                d_um >= 10.0 ? Coherence::incoherent : Coherence::coherent;
                            const std::vector<StackLayer> layers = {
                                {Complex(1.55, k), d_um, coherence}, {Complex(1.0), 0.2}};
                            const double cos_i = deg == 90.0 ? 0.0 : std::cos(deg * kDeg);
                            const auto i = transfer_matrix_intensities(
                                {ambient, layers, Complex(1.0)}, lambda, cos_i, pol);
                            ASSERT_TRUE(std::isfinite(i.reflectance) &&
                                        std::isfinite(i.transmittance))
                                << ambient << " k=" << k << " d=" << d_um << " deg=" << deg;
                            ASSERT_GE(i.reflectance, -1e-15);
                            ASSERT_GE(i.transmittance, -1e-15);
                            ASSERT_LE(i.reflectance + i.transmittance, 1.0 + 1e-12);
                            if (k == 0.0 && coherence == Coherence::coherent) {
                                ASSERT_NEAR(i.reflectance + i.transmittance, 1.0,
                                            plumage::testing::grazing_tolerance(1e-12, cos_i));
                            }
                            ++evaluations;
                        }
                    }
                }
            }
        }
    }
    EXPECT_EQ(evaluations, 2 * 5 * 8 * 8 * 3 * 2);
}

TEST(Multilayer, TotalInternalReflectionAndFrustration) {
    // Keratin | air gap | keratin beyond the critical angle: transmission tunnels
    // through a thin gap and vanishes exponentially for a thick one.
    const double cos_i = std::cos(60.0 * kDeg);
    double previous = 1.0;
    for (double gap_um : {0.0, 0.05, 0.2, 0.5, 2.0}) {
        const StackLayer gap{Complex(1.0), gap_um};
        const auto i = transfer_matrix_intensities({1.55, std::span(&gap, 1), Complex(1.55)}, 550.0,
                                                   cos_i, Polarisation::s);
        EXPECT_NEAR(i.reflectance + i.transmittance, 1.0, 1e-13);
        EXPECT_LE(i.transmittance, previous);
        previous = i.transmittance;
    }
    EXPECT_LT(previous, 1e-6);
}

TEST(Multilayer, OpaqueAbsorberReflectsLikeItsSurface) {
    // 100 µm of k = 10 in coherent mode: no overflow, and the stack reflects like the
    // bare absorbing interface.
    const StackLayer thick{Complex(1.5, 10.0), 100.0};
    for (Polarisation pol : kBoth) {
        const auto i = transfer_matrix_intensities({1.0, std::span(&thick, 1), Complex(1.0)}, 400.0,
                                                   std::cos(0.5), pol);
        const auto bare = fresnel_intensities(1.0, Complex(1.5, 10.0), std::cos(0.5), pol);
        EXPECT_NEAR(i.reflectance, bare.reflectance, 1e-14);
        EXPECT_EQ(i.transmittance, 0.0);
    }
}

TEST(Multilayer, RejectsBadInput) {
    using plumage::testing::input_error_message;
    const StackLayer negative{Complex(1.5), -1.0};
    EXPECT_NE(input_error_message([&] {
                  transfer_matrix_intensities({1.0, std::span(&negative, 1), Complex(1.0)}, 500.0,
                                              1.0, Polarisation::s);
              }).find("thickness = -1 um"),
              std::string::npos);
    const StackLayer incoherent{Complex(1.5), 20.0, Coherence::incoherent};
    EXPECT_NE(input_error_message([&] {
                  transfer_matrix_amplitudes({1.0, std::span(&incoherent, 1), Complex(1.0)}, 500.0,
                                             1.0, Polarisation::s);
              }).find("incoherent"),
              std::string::npos);
    EXPECT_NE(input_error_message([&] {
                  transfer_matrix_intensities({0.0, {}, Complex(1.0)}, 500.0, 1.0, Polarisation::s);
              }).find("ambient"),
              std::string::npos);
    // An empty stack is a bare interface, not an error.
    EXPECT_EQ(input_error_message([&] {
                  transfer_matrix_intensities({1.0, {}, Complex(1.5)}, 500.0, 1.0, Polarisation::s);
              }),
              "no InputError");
}

}  // namespace
}  // namespace plumage::optics
