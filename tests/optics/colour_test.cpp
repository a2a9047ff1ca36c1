// Colour: the CIE data and quadrature (white points), sRGB, CIELAB, and CIEDE2000
// against the 34 reference pairs of Sharma, Wu & Dalal (2005).
#include "sim/optics/colour.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "tests/test_util.h"

namespace plumage::optics {
namespace {

TEST(Colour, PerfectReflectorUnderD65HasTheD65WhitePoint) {
    const auto grid = WavelengthGrid::uniform(360.0, 830.0, 1.0);
    const ReflectanceToXyz to_xyz(grid, Illuminant::d65);
    const std::vector<double> ones(grid.size(), 1.0);
    const Xyz white = to_xyz(ones);
    EXPECT_NEAR(white.y, 1.0, 1e-15);
    // CIE 15:2004 Table T.3: D65, 2° observer: x = 0.31272, y = 0.32903.
    const double sum = white.x + white.y + white.z;
    EXPECT_NEAR(white.x / sum, 0.31272, 5e-5);
    EXPECT_NEAR(white.y / sum, 0.32903, 5e-5);
    // Its sRGB is (1, 1, 1) to the precision of the sRGB matrix's white.
    for (double c : linear_srgb_from_xyz(white)) EXPECT_NEAR(c, 1.0, 2e-3);
    const Lab lab = lab_from_xyz(white, to_xyz.white());
    EXPECT_NEAR(lab.l, 100.0, 1e-12);
    EXPECT_NEAR(lab.a, 0.0, 1e-12);
    EXPECT_NEAR(lab.b, 0.0, 1e-12);
}

TEST(Colour, EqualEnergyWhiteIsAchromaticInXyz) {
    // The CIE 1931 functions have equal integrals by construction: E is x = y = 1/3.
    const auto grid = WavelengthGrid::uniform(360.0, 830.0, 1.0);
    const ReflectanceToXyz to_xyz(grid, Illuminant::equal_energy);
    const Xyz w = to_xyz.white();
    EXPECT_NEAR(w.x, 1.0, 2e-4);
    EXPECT_NEAR(w.z, 1.0, 4e-4);
}

TEST(Colour, CoarseGridsAgreeWithTheFineOne) {
    // A smooth reflectance integrated on 5 and 10 nm grids: the quadrature error in
    // ΔE00 stays below a just-noticeable difference.
    auto reflectance = [](double l) { return 0.3 + 0.2 * std::sin(l / 40.0); };
    auto lab_on = [&](double step) {
        const auto grid = WavelengthGrid::uniform(380.0, 780.0, step);
        const ReflectanceToXyz to_xyz(grid, Illuminant::d65);
        std::vector<double> r;
        for (double l : grid.nm()) r.push_back(reflectance(l));
        return lab_from_xyz(to_xyz(r), to_xyz.white());
    };
    const Lab fine = lab_on(1.0);
    EXPECT_LT(ciede2000(fine, lab_on(5.0)), 0.05);
    EXPECT_LT(ciede2000(fine, lab_on(10.0)), 0.2);
}

TEST(Colour, SrgbTransferCurve) {
    EXPECT_DOUBLE_EQ(srgb_encode(0.0), 0.0);
    EXPECT_DOUBLE_EQ(srgb_encode(1.0), 1.0);
    EXPECT_NEAR(srgb_encode(0.0031308), 0.0404499, 1e-7);  // the knee: both branches agree
    EXPECT_NEAR(srgb_encode(0.18), 0.4613561, 1e-6);
    EXPECT_DOUBLE_EQ(srgb_encode(2.0), 1.0);
    EXPECT_DOUBLE_EQ(srgb_encode(-1.0), 0.0);
}

TEST(Colour, RejectsGridsOutsideTheColourMatchingRange) {
    using plumage::testing::input_error_message;
    const auto deep_uv = WavelengthGrid::uniform(290.0, 700.0, 10.0);
    EXPECT_NE(input_error_message([&] {
                  ReflectanceToXyz(deep_uv, Illuminant::d65);
              }).find("the grid spans 290–700 nm"),
              std::string::npos);
    const auto ir = WavelengthGrid::uniform(400.0, 900.0, 10.0);
    EXPECT_NE(
        input_error_message([&] { ReflectanceToXyz(ir, Illuminant::d65); }).find("300–830 nm"),
        std::string::npos);
    const auto only_uv = WavelengthGrid::uniform(300.0, 350.0, 10.0);
    EXPECT_FALSE(carries_colour(only_uv.nm()));
    EXPECT_THROW(ReflectanceToXyz(only_uv, Illuminant::d65), InputError);
}

// UV light is invisible in CIE colour: on a 300–800 nm grid a spectrum's colour does not depend
// on its values below 360 nm, and equals the colour of the same spectrum on the grid's visible
// part (the colour-matching functions are zero below 360 nm, and 360 nm is a grid node).
TEST(Colour, UltravioletHasNoWeightInCieColour) {
    const auto grid = WavelengthGrid::uniform(300.0, 800.0, 10.0);
    const auto visible = WavelengthGrid::uniform(360.0, 800.0, 10.0);
    ASSERT_TRUE(carries_colour(grid.nm()));
    const ReflectanceToXyz to_xyz(grid, Illuminant::d65), to_xyz_visible(visible, Illuminant::d65);
    std::vector<double> r(grid.size()), r_uv(grid.size()), r_visible;
    for (std::size_t i = 0; i < grid.size(); ++i) {
        r[i] = 0.3 + 0.2 * std::sin(grid[i] / 37.0);
        r_uv[i] = grid[i] < 360.0 ? 5.0 : r[i];  // a strong UV reflector, same visible part
        if (grid[i] >= 360.0) r_visible.push_back(r[i]);
    }
    const Xyz a = to_xyz(r), b = to_xyz(r_uv), c = to_xyz_visible(r_visible);
    EXPECT_DOUBLE_EQ(a.x, b.x);
    EXPECT_DOUBLE_EQ(a.y, b.y);
    EXPECT_DOUBLE_EQ(a.z, b.z);
    // Same nodes from 360 nm on; the only difference is the 360 nm node's half-interval to the
    // left (x̄ȳz̄(360) ~ 1e-4 of their peaks).
    EXPECT_NEAR(a.y, c.y, 1e-4);
    EXPECT_NEAR(a.x, c.x, 1e-4);
    EXPECT_NEAR(to_xyz.white().y, 1.0, 1e-12);
}

struct SharmaPair {
    int pair;
    Lab first, second;
    double delta_e00;
};

std::vector<SharmaPair> read_sharma_pairs() {
    std::ifstream file(std::string(PLUMAGE_TEST_DATA_DIR) + "/ciede2000_sharma2005.csv");
    std::vector<SharmaPair> pairs;
    std::string line;
    std::getline(file, line);  // header
    while (std::getline(file, line)) {
        if (line.empty()) continue;
        std::replace(line.begin(), line.end(), ',', ' ');
        std::istringstream row(line);
        SharmaPair p{};
        row >> p.pair >> p.first.l >> p.first.a >> p.first.b >> p.second.l >> p.second.a >>
            p.second.b >> p.delta_e00;
        pairs.push_back(p);
    }
    return pairs;
}

TEST(Ciede2000, MatchesTheSharmaWuDalalReferencePairs) {
    const auto pairs = read_sharma_pairs();
    ASSERT_EQ(pairs.size(), 34u);
    for (const SharmaPair& p : pairs) {
        // The published values are rounded to 4 decimals.
        EXPECT_NEAR(ciede2000(p.first, p.second), p.delta_e00, 1e-4) << "pair " << p.pair;
        EXPECT_NEAR(ciede2000(p.second, p.first), p.delta_e00, 1e-4)
            << "pair " << p.pair << " swapped";
    }
}

TEST(Ciede2000, IsZeroForIdenticalColours) {
    EXPECT_EQ(ciede2000({50.0, 10.0, -10.0}, {50.0, 10.0, -10.0}), 0.0);
    EXPECT_EQ(ciede2000({0.0, 0.0, 0.0}, {0.0, 0.0, 0.0}), 0.0);
}

TEST(Colour, HueAngles) {
    EXPECT_NEAR(hue_angle_deg({50.0, 10.0, 0.0}), 0.0, 1e-12);
    EXPECT_NEAR(hue_angle_deg({50.0, 0.0, 10.0}), 90.0, 1e-12);
    EXPECT_NEAR(hue_angle_deg({50.0, -10.0, 0.0}), 180.0, 1e-12);
    EXPECT_NEAR(hue_angle_deg({50.0, 0.0, -10.0}), 270.0, 1e-12);
}

}  // namespace
}  // namespace plumage::optics
