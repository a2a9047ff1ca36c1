#include "sim/optics/spectrum.h"

#include <cmath>

#include <gtest/gtest.h>

#include "tests/test_util.h"

namespace plumage::optics {
namespace {

using plumage::testing::input_error_message;

TEST(WavelengthGrid, UniformIncludesBothEnds) {
    const auto g = WavelengthGrid::uniform(380.0, 780.0, 5.0);
    EXPECT_EQ(g.size(), 81u);
    EXPECT_DOUBLE_EQ(g.first(), 380.0);
    EXPECT_DOUBLE_EQ(g.last(), 780.0);
    EXPECT_EQ(WavelengthGrid::uniform(550.0, 550.0, 1.0).size(), 1u);
}

TEST(WavelengthGrid, RejectsEmptyUnsortedAndNonFiniteGrids) {
    EXPECT_NE(input_error_message([] { WavelengthGrid({}); }).find("empty"), std::string::npos);
    EXPECT_NE(input_error_message([] {
                  WavelengthGrid({400.0, 500.0, 450.0});
              }).find("entry 2 = 450 nm follows 500 nm"),
              std::string::npos);
    EXPECT_NE(input_error_message([] {
                  WavelengthGrid({400.0, 400.0});
              }).find("strictly increasing"),
              std::string::npos);
    EXPECT_NE(input_error_message([] {
                  WavelengthGrid({400.0, NAN});
              }).find("entry 1 = nan"),
              std::string::npos);
    EXPECT_NE(input_error_message([] { WavelengthGrid({-5.0}); }).find("positive"),
              std::string::npos);
    EXPECT_NE(input_error_message([] {
                  WavelengthGrid::uniform(500.0, 400.0, 1.0);
              }).find("first <= last"),
              std::string::npos);
    EXPECT_NE(
        input_error_message([] { WavelengthGrid::uniform(400.0, 500.0, 0.0); }).find("step > 0"),
        std::string::npos);
}

TEST(WavelengthGrid, InterpolatesUniformTablesLinearly) {
    const std::vector<double> table = {0.0, 10.0, 30.0};
    EXPECT_DOUBLE_EQ(interpolate_uniform_table(table, 400.0, 5.0, 402.5), 5.0);
    EXPECT_DOUBLE_EQ(interpolate_uniform_table(table, 400.0, 5.0, 410.0), 30.0);
    EXPECT_DOUBLE_EQ(interpolate_uniform_table(table, 400.0, 5.0, 399.0), 0.0);
    EXPECT_DOUBLE_EQ(interpolate_uniform_table(table, 400.0, 5.0, 411.0), 0.0);
}

}  // namespace
}  // namespace plumage::optics
