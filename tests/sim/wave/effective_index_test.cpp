// Bruggeman effective permittivity: end points, symmetry, agreement with Maxwell-Garnett to
// second order in the contrast, lossless in → real out, passivity and continuity of the
// chosen root.
#include "sim/wave/volume/effective_index.h"

#include <cmath>
#include <complex>

#include <gtest/gtest.h>

#include "common/error.h"

namespace plumage::sim::wave {
namespace {

// Keratin (n = 1.56 at 550 nm) and air, and a weakly absorbing keratin (melanin-doped).
const Complex kKeratin = Complex(1.56, 0.0) * Complex(1.56, 0.0);
const Complex kLossyKeratin = Complex(1.56, 0.05) * Complex(1.56, 0.05);
const Complex kAir(1.0, 0.0);

TEST(Bruggeman, EndPointsAreTheComponents) {
    for (Complex e1 : {kKeratin, kLossyKeratin}) {
        EXPECT_EQ(bruggeman_permittivity(e1, kAir, 0.0), kAir);
        EXPECT_EQ(bruggeman_permittivity(e1, kAir, 1.0), e1);
        // Approaching the end points continuously: the slope there is finite (first-order
        // in f), so f = 1e-9 lands within ~1e-9 |ε1 − ε2| of the component.
        EXPECT_LT(std::abs(bruggeman_permittivity(e1, kAir, 1e-9) - kAir), 1e-8);
        EXPECT_LT(std::abs(bruggeman_permittivity(e1, kAir, 1.0 - 1e-9) - e1), 1e-8);
    }
}

TEST(Bruggeman, SymmetricUnderSwappingComponents) {
    for (double f : {0.1, 0.3, 0.5, 0.7, 0.9}) {
        for (Complex e1 : {kKeratin, kLossyKeratin}) {
            const Complex a = bruggeman_permittivity(e1, kAir, f);
            const Complex b = bruggeman_permittivity(kAir, e1, 1.0 - f);
            EXPECT_LT(std::abs(a - b), 1e-14 * std::abs(a)) << "f = " << f;
        }
    }
}

TEST(Bruggeman, SatisfiesItsEquation) {
    for (double f : {0.2, 0.5, 0.8}) {
        const Complex e = bruggeman_permittivity(kLossyKeratin, kAir, f);
        const Complex residual = f * (kLossyKeratin - e) / (kLossyKeratin + 2.0 * e) +
                                 (1.0 - f) * (kAir - e) / (kAir + 2.0 * e);
        EXPECT_LT(std::abs(residual), 1e-14);
    }
}

TEST(Bruggeman, LosslessComponentsGiveARealPermittivityBetweenThem) {
    for (double f = 0.0; f <= 1.0; f += 0.05) {
        const Complex e = bruggeman_permittivity(kKeratin, kAir, f);
        EXPECT_EQ(e.imag(), 0.0) << "f = " << f;
        EXPECT_GE(e.real(), 1.0);
        EXPECT_LE(e.real(), kKeratin.real());
        // Wiener bounds: between the series and parallel averages.
        EXPECT_LE(e.real(), f * kKeratin.real() + (1.0 - f) + 1e-15);
        EXPECT_GE(e.real(), 1.0 / (f / kKeratin.real() + (1.0 - f)) - 1e-15);
    }
}

TEST(Bruggeman, PassiveAndContinuousForAbsorbingComponent) {
    // Steps of 1e-3 in f: the root moves by about |ε1 − ε2| · 1e-3 ≈ 1.5e-3 per step; a
    // branch jump would move it by the distance between the roots (> 1).
    Complex previous = bruggeman_permittivity(kLossyKeratin, kAir, 0.0);
    for (int i = 1; i <= 1000; ++i) {
        const double f = i * 1e-3;
        const Complex e = bruggeman_permittivity(kLossyKeratin, kAir, f);
        EXPECT_GE(e.imag(), 0.0);
        EXPECT_LT(std::abs(e - previous), 5e-3) << "f = " << f;
        previous = e;
    }
}

TEST(Bruggeman, AgreesWithMaxwellGarnettToSecondOrderInContrast) {
    // Both are ε2 + f δ − f(1 − f) δ²/(3 ε2) + O(δ³): the difference over δ³ stays bounded
    // (and roughly constant) as δ → 0, while the difference over δ² vanishes.
    const Complex host(2.0, 0.0);
    for (double f : {0.2, 0.5}) {
        double previous_ratio = 0.0;
        for (double delta : {0.1, 0.05, 0.025, 0.0125}) {
            const Complex inclusion = host + delta;
            const double difference = std::abs(bruggeman_permittivity(inclusion, host, f) -
                                               maxwell_garnett_permittivity(inclusion, host, f));
            const double ratio = difference / (delta * delta * delta);
            EXPECT_LT(difference / (delta * delta), 0.05) << "f = " << f << " delta = " << delta;
            if (previous_ratio > 0.0) {
                EXPECT_NEAR(ratio / previous_ratio, 1.0, 0.15)
                    << "f = " << f << " delta = " << delta;
            }
            previous_ratio = ratio;
            // And the common second-order expansion itself.
            const Complex series = host + f * delta - f * (1.0 - f) * delta * delta / (3.0 * host);
            EXPECT_LT(std::abs(bruggeman_permittivity(inclusion, host, f) - series),
                      delta * delta * delta);
        }
    }
}

TEST(Bruggeman, RefusesNonDielectricsAndBadFractions) {
    EXPECT_THROW(bruggeman_permittivity(kKeratin, kAir, -0.1), InputError);
    EXPECT_THROW(bruggeman_permittivity(kKeratin, kAir, 1.1), InputError);
    EXPECT_THROW(bruggeman_permittivity(kKeratin, kAir, std::nan("")), InputError);
    EXPECT_THROW(bruggeman_permittivity(Complex(-2.0, 0.1), kAir, 0.5), InputError);
    EXPECT_THROW(bruggeman_permittivity(Complex(2.0, -0.1), kAir, 0.5), InputError);
}

TEST(Bruggeman, IndexIsTheRootOfThePermittivity) {
    const Complex n = bruggeman_index(Complex(1.56, 0.05), Complex(1.0, 0.0), 0.5);
    EXPECT_GT(n.real(), 1.0);
    EXPECT_LT(n.real(), 1.56);
    EXPECT_GT(n.imag(), 0.0);
    EXPECT_LT(std::abs(n * n - bruggeman_permittivity(kLossyKeratin, kAir, 0.5)), 1e-14);
}

}  // namespace
}  // namespace plumage::sim::wave
