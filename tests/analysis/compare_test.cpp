// Record comparison against closed forms: two Lambertian plates.
#include "analysis/compare.h"

#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include "analysis/lambertian.h"
#include "common/error.h"
#include "sim/optics/colour.h"

namespace plumage::analysis {
namespace {

gonio::BrdfRecord measure(double albedo, std::vector<double> wavelengths) {
    gonio::GoniometerConfig c;
    c.pairs = gonio::filip2024_in_plane_pairs();
    c.wavelengths_nm = std::move(wavelengths);
    c.estimator = gonio::Estimator::eval;
    return gonio::measure_brdf(LambertianScatterer(albedo), c);
}

TEST(CompareRecords, LambertianPlatesDifferByTheClosedForms) {
    const std::vector<double> grid = {400.0, 450.0, 500.0, 550.0, 600.0, 650.0, 700.0};
    const auto a = measure(0.6, grid), b = measure(0.5, grid);
    const RecordComparison c = compare_records(a, b);
    EXPECT_NEAR(c.total.rmse, 0.1 / std::numbers::pi, 1e-12);
    EXPECT_NEAR(c.total.relative_l1, 0.2, 1e-12);
    EXPECT_NEAR(c.total.cosine_weighted_rmse, 0.1 / std::numbers::pi, 1e-12);
    ASSERT_EQ(c.lobes.size(), 1u);
    EXPECT_NEAR(c.lobes[0].second.relative_l1, 0.2, 1e-12);
    // Two greys of reflectance factor 0.6 and 0.5: ΔE00 from their L* alone.
    ASSERT_TRUE(c.colour_available);
    auto lab = [](double y) {
        const double f = std::cbrt(y);
        return optics::Lab{116.0 * f - 16.0, 0.0, 0.0};
    };
    EXPECT_NEAR(c.mean_delta_e00, optics::ciede2000(lab(0.5), lab(0.6)), 1e-9);
    EXPECT_EQ(c.worst.size(), 10u);
    EXPECT_NE(comparison_markdown(c, a, "a", "b").find("| diffuse |"), std::string::npos);
    // A record against itself: all zero.
    const RecordComparison same = compare_records(a, a);
    EXPECT_EQ(same.total.rmse, 0.0);
    EXPECT_EQ(same.max_delta_e00, 0.0);
}

TEST(CompareRecords, RefusesRecordsFromDifferentInstruments) {
    const auto a = measure(0.6, {550.0});
    auto b = measure(0.6, {550.0, 600.0});
    EXPECT_THROW(compare_records(a, b), InputError);
}

}  // namespace
}  // namespace plumage::analysis
