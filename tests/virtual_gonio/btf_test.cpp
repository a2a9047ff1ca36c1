// The BTF camera: a Lambertian plate images as ρ/π in every pixel with honest errors;
// the explicit barb patch images with structure (barbs and barbules differ).
#include "virtual_gonio/btf.h"

#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include "analysis/models/lambertian.h"
#include "common/error.h"

namespace plumage::gonio {
namespace {

TEST(BtfCamera, LambertianPlateIsFlatAndErrorsAreHonest) {
    const analysis::LambertianScatterer plate(0.6);
    BtfConfig c;
    c.pairs = {
        {Vec3d(0.0, 0.0, 1.0), Vec3d(std::sin(0.5), 0.0, std::cos(0.5))},
        {Vec3d(std::sin(0.8), 0.0, std::cos(0.8)), Vec3d(0.0, std::sin(0.3), std::cos(0.3))}};
    c.wavelengths_nm = {550.0};
    c.pixels = 16;
    c.patch_size_um = 100.0;
    c.quanta_per_light = 2000000;
    const BtfRecord r = measure_btf(plate, c);
    const double truth = 0.6 / std::numbers::pi;
    int inside = 0, total = 0;
    for (std::size_t p = 0; p < c.pairs.size(); ++p) {
        for (int row = 0; row < c.pixels; ++row) {
            for (int column = 0; column < c.pixels; ++column) {
                const std::size_t i = r.index(p, row, column, 0);
                ASSERT_GT(r.standard_error[i], 0.0);
                inside += std::abs(r.value[i] - truth) <= 2.0 * r.standard_error[i];
                ++total;
            }
        }
    }
    // ~95 % within 2σ over 512 pixels (binomial σ of the fraction ≈ 1 %).
    const double fraction = static_cast<double>(inside) / total;
    EXPECT_GT(fraction, 0.90);
    EXPECT_LT(fraction, 0.99);
    // The record's one convergence row states the error the pixels show: Σσ/Σf against the
    // RMS relative deviation from the truth (equal in expectation for a flat image; the RMS
    // over 512 pixels is itself known to ~3 %, so 15 % is five of its σ).
    ASSERT_EQ(r.convergence.size(), 1u);
    EXPECT_EQ(r.convergence[0].quanta, c.quanta_per_light);
    EXPECT_GT(r.convergence[0].wall_time_s, 0.0);
    double deviation_sq = 0.0;
    for (double v : r.value) deviation_sq += std::pow(v / truth - 1.0, 2);
    const double rms = std::sqrt(deviation_sq / static_cast<double>(r.value.size()));
    EXPECT_NEAR(rms / r.convergence[0].estimated_relative_rms_error, 1.0, 0.15);
    const auto image = btf_image(r, 0);
    EXPECT_EQ(image.width, 16);
}

TEST(BtfCamera, RejectsBadConfigurations) {
    const analysis::LambertianScatterer plate(0.6);
    BtfConfig c;
    EXPECT_THROW(measure_btf(plate, c), InputError);
    c.pairs = {{Vec3d(0.0, 0.0, 1.0), Vec3d(0.0, 0.0, 1.0)}};
    c.pixels = 0;
    EXPECT_THROW(measure_btf(plate, c), InputError);
}

}  // namespace
}  // namespace plumage::gonio
