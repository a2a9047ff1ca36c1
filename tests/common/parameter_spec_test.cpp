// ParameterSpec (common/parameter_spec.h): open and closed bounds, whole numbers, non-finite
// values, the range as text, and the message naming the parameter, its range and unit; and the
// models' tables: every default inside its own range.
#include "common/parameter_spec.h"

#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "analysis/models/filip2024.h"
#include "analysis/models/huang2022.h"
#include "tests/test_util.h"

namespace plumage {
namespace {

TEST(ParameterSpec, BoundsOpenAndClosedWholeNumbersAndNonFinite) {
    const ParameterSpec closed{
        .name = "b", .unit = "1", .default_value = 0.5, .min = 1e-3, .max = 1.0};
    EXPECT_TRUE(closed.contains(1e-3));
    EXPECT_TRUE(closed.contains(1.0));
    EXPECT_FALSE(closed.contains(0.0));
    EXPECT_FALSE(closed.contains(std::numeric_limits<double>::quiet_NaN()));
    const ParameterSpec open{
        .name = "mu", .unit = "rad", .min = -1.0, .max = 1.0, .min_open = true, .max_open = true};
    EXPECT_FALSE(open.contains(-1.0));
    EXPECT_FALSE(open.contains(1.0));
    EXPECT_TRUE(open.contains(0.999));
    const ParameterSpec whole{.name = "passes", .unit = "1", .min = 1, .max = 10, .integer = true};
    EXPECT_TRUE(whole.contains(3.0));
    EXPECT_FALSE(whole.contains(2.5));
    const ParameterSpec unbounded{.name = "phi0", .unit = "rad"};
    EXPECT_TRUE(unbounded.contains(-1e9));
    EXPECT_FALSE(unbounded.contains(std::numeric_limits<double>::infinity()));
}

TEST(ParameterSpec, RangeTextAndMessageNameWhatWasExpected) {
    const ParameterSpec h{
        .name = "H", .unit = "1", .min = 0.0, .min_open = true, .meaning = "a spacing"};
    EXPECT_EQ(h.range_text(), "> 0");
    const ParameterSpec d{
        .name = "d_um", .unit = "µm", .min = 0.0, .max = 50.0, .meaning = "a film thickness"};
    EXPECT_EQ(d.range_text(), "[0, 50]");
    EXPECT_EQ(ParameterSpec{.name = "x"}.range_text(), "any finite value");
    EXPECT_EQ(testing::input_error_message([&] { d.require(80.0, "huang2022"); }),
              "huang2022: d_um = 80 µm: expected a film thickness in [0, 50] µm");
    EXPECT_NO_THROW(d.require(0.59, "huang2022"));
}

TEST(ParameterSpec, TheModelsTablesHoldTheirOwnDefaults) {
    for (const ParameterSpec& p : analysis::kHuang2022ParameterTable)
        EXPECT_TRUE(p.contains(p.default_value)) << p.name;
    for (const ParameterSpec& p : analysis::kFilip2024ParameterTable)
        EXPECT_TRUE(p.contains(p.default_value)) << p.name;
    // The model refuses by its table: the table's bound, the table's words.
    EXPECT_NE(testing::input_error_message([] {
                  analysis::Huang2022Params p;
                  p.theta_d = 0.0;
                  analysis::Huang2022Bsdf bsdf(p);
              }).find("huang2022: theta_d = 0 rad: expected a longitudinal half-opening in (0, "),
              std::string::npos);
}

}  // namespace
}  // namespace plumage
