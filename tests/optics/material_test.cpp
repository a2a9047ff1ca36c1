#include "sim/optics/material.h"

#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "tests/test_util.h"

namespace plumage::optics {
namespace {

using plumage::testing::input_error_message;

TEST(Material, KeratinAndMelaninFollowThePublishedDispersion) {
    for (double l : {400.0, 500.0, 700.0}) {
        EXPECT_DOUBLE_EQ(keratin()->index(l).real(), 1.532 + 5890.0 / (l * l));
        EXPECT_EQ(keratin()->index(l).imag(), 0.0);
        EXPECT_DOUBLE_EQ(melanin()->index(l).real(), 1.648 + 23700.0 / (l * l));
        EXPECT_DOUBLE_EQ(melanin()->index(l).imag(), 0.56 * std::exp(-l / 270.0));
    }
    EXPECT_NEAR(keratin()->index(500.0).real(), 1.55556, 1e-5);
    EXPECT_EQ(air()->index(500.0), std::complex<double>(1.0, 0.0));
}

// Across 300–800 nm (sim/optics/material.h: measured 400–700 nm, extrapolated 100 nm either
// side) the indices are one smooth formula: continuous at the joins of the cited ranges, n
// decreasing with λ (normal dispersion, away from absorption bands) and melanin's k decreasing
// (its absorption rises monotonically into the UV).
TEST(Material, DispersionIsContinuousAndMonotoneOver300To800Nanometres) {
    for (const auto& material : {keratin(), melanin()}) {
        double previous_n = std::numeric_limits<double>::infinity();
        double previous_k = std::numeric_limits<double>::infinity();
        for (double l = kDispersionMinNm; l <= kDispersionMaxNm + 1e-9; l += 0.5) {
            const auto n = material->index(l);
            EXPECT_LT(n.real(), previous_n) << material->name() << " " << l;
            EXPECT_LE(n.imag(), previous_k) << material->name() << " " << l;
            previous_n = n.real();
            previous_k = n.imag();
        }
        // At the joins (400 and 700 nm) the two sides meet to within the step's own change:
        // |n(λ ± 0.01) − n(λ)| ≤ |dn/dλ| · 0.01 (dn/dλ = −2B/λ³).
        for (double join : {400.0, 700.0}) {
            const double slope =
                std::abs(material->index(join + 0.5).real() - material->index(join - 0.5).real());
            EXPECT_LE(
                std::abs(material->index(join + 0.01).real() - material->index(join - 0.01).real()),
                0.021 * slope)
                << material->name() << " at " << join;
        }
    }
    // The extrapolated ends, as the parameter table quotes them.
    EXPECT_NEAR(keratin()->index(300.0).real(), 1.5974, 1e-4);
    EXPECT_NEAR(keratin()->index(800.0).real(), 1.5412, 1e-4);
    EXPECT_NEAR(melanin()->index(300.0).real(), 1.9113, 1e-4);
    EXPECT_NEAR(melanin()->index(300.0).imag(), 0.184, 1e-3);
    EXPECT_NEAR(melanin()->index(800.0).imag(), 0.0290, 1e-4);
}

TEST(Material, TabulatedInterpolatesAndRejectsOutOfRange) {
    const TabulatedMaterial m("glass", {400.0, 500.0, 600.0}, {1.50, 1.48, 1.47}, {0.0, 0.01, 0.0});
    EXPECT_DOUBLE_EQ(m.index(450.0).real(), 1.49);
    EXPECT_DOUBLE_EQ(m.index(450.0).imag(), 0.005);
    EXPECT_DOUBLE_EQ(m.index(600.0).real(), 1.47);
    EXPECT_NE(input_error_message([&] {
                  m.index(650.0);
              }).find("650 nm is outside its table (400..600 nm)"),
              std::string::npos);
}

TEST(Material, RejectsUnphysicalParameters) {
    EXPECT_NE(input_error_message([] { CauchyMaterial("x", -1.0, 0.0); }).find("A = -1"),
              std::string::npos);
    EXPECT_NE(input_error_message([] {
                  CauchyMaterial("x", 1.5, 0.0, -0.1, 100.0);
              }).find("C (k amplitude)"),
              std::string::npos);
    EXPECT_NE(input_error_message([] {
                  ConstantMaterial("x", {1.5, -0.1});
              }).find("k >= 0"),
              std::string::npos);
    EXPECT_NE(input_error_message([] {
                  TabulatedMaterial("t", {400.0, 500.0}, {1.5}, {0.0, 0.0});
              }).find("equal lengths"),
              std::string::npos);
    EXPECT_NE(input_error_message([] {
                  TabulatedMaterial("t", {500.0, 400.0}, {1.5, 1.5}, {0.0, 0.0});
              }).find("strictly increasing"),
              std::string::npos);
    EXPECT_NE(input_error_message([] { keratin()->index(-3.0); }).find("wavelength = -3 nm"),
              std::string::npos);
}

}  // namespace
}  // namespace plumage::optics
