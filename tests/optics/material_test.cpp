#include "sim/optics/material.h"

#include <cmath>

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
