// The circular-cylinder series (sim/wave/volume/cylinder_series.h) on its own: the checks the
// series must pass before the full-wave level is judged by it.
#include "sim/wave/volume/cylinder_series.h"

#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include "common/error.h"

namespace plumage::sim::wave {
namespace {

constexpr double kPi = std::numbers::pi;

double integrated_sigma(const CylinderSeries& s, double k) {
    const int n = 4000;  // the integrand is a trigonometric polynomial: the rule is exact
    double sum = 0.0;
    for (int i = 0; i < n; ++i) sum += cylinder_sigma(s, k, 2.0 * kPi * i / n);
    return sum * 2.0 * kPi / n;
}

// Lossless: no absorption, so extinction (optical theorem) equals scattering.
TEST(CylinderSeries, LosslessExtinctionEqualsScattering) {
    for (const Polarisation2d pol : {Polarisation2d::te, Polarisation2d::tm})
        for (const double x : {0.3, 3.0, 25.0}) {
            const CylinderSeries s = cylinder_series({1.55, 0.0}, x, pol);
            const CylinderWidths w = cylinder_widths(s, 1.0);
            EXPECT_NEAR(w.absorption_um / w.extinction_um, 0.0, 1e-12) << x;
        }
}

// ∫σ dψ over the circle is the scattering width; absorption is positive for k > 0.
TEST(CylinderSeries, FarFieldIntegratesToScatteringWidth) {
    const double k = 2.0 * kPi / 0.55;
    for (const Polarisation2d pol : {Polarisation2d::te, Polarisation2d::tm}) {
        const CylinderSeries s = cylinder_series({1.75, 0.2}, k * 0.8, pol);
        const CylinderWidths w = cylinder_widths(s, k);
        EXPECT_NEAR(integrated_sigma(s, k) / w.scattering_um, 1.0, 1e-12);
        EXPECT_GT(w.absorption_um, 0.0);
    }
}

// Thin cylinder, TE (E along the axis): the quasi-static limit C_sca = (π² k³ a⁴ / 4)|m² − 1|²
// (Bohren & Huffman eq. 8.42 with x = ka), to O(x²).
TEST(CylinderSeries, RayleighLimitTE) {
    const double a = 0.005, k = 2.0 * kPi / 0.5;
    const std::complex<double> m{1.5, 0.0};
    const CylinderWidths w = cylinder_widths(cylinder_series(m, k * a, Polarisation2d::te), k);
    const double expected =
        kPi * kPi * std::pow(k, 3) * std::pow(a, 4) / 4.0 * std::norm(m * m - 1.0);
    EXPECT_NEAR(w.scattering_um / expected, 1.0, 5.0 * std::pow(k * a, 2));
}

// A huge absorbing cylinder: extinction → twice the diameter (the extinction paradox), with
// the edge term of order x^{−2/3} (van de Hulst §17.2).
TEST(CylinderSeries, LargeAbsorbingCylinderExtinguishesTwiceItsWidth) {
    const double k = 1.0, a = 300.0;
    const CylinderWidths w =
        cylinder_widths(cylinder_series({1.6, 0.5}, k * a, Polarisation2d::te), k);
    EXPECT_NEAR(w.extinction_um / (4.0 * a), 1.0, 2.0 * std::pow(k * a, -2.0 / 3.0));
}

TEST(CylinderSeries, RefusesBadInput) {
    EXPECT_THROW(cylinder_series({1.5, -0.1}, 1.0, Polarisation2d::te), InputError);
    EXPECT_THROW(cylinder_series({1.5, 0.0}, 0.0, Polarisation2d::te), InputError);
    EXPECT_THROW(cylinder_series({1.5, 0.0}, NAN, Polarisation2d::tm), InputError);
}

}  // namespace
}  // namespace plumage::sim::wave
