// The thin-film study end to end (coarse grid, no matplotlib): rock-dove film colours
// and the written record.
#include "studies/thin_film_chart.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include <OpenEXR/ImfStringAttribute.h>

#include <gtest/gtest.h>

#include "tests/test_util.h"
#include "tests/virtual_gonio/exr_test_util.h"
#include "virtual_gonio/record/hdf5_file.h"
#include "virtual_gonio/record/hdf5_reader.h"

namespace plumage::studies {
namespace {

std::filesystem::path scratch_root() {
    return std::filesystem::temp_directory_path() /
           ("plumage_study_test_" + std::to_string(::getpid()));
}

ThinFilmChartOptions quick_options(const std::filesystem::path& dir) {
    ThinFilmChartOptions o;
    o.output_dir = dir;
    o.thickness_step_nm = 5.0;
    o.angle_step_deg = 5.0;
    o.plots = false;
    o.progress = false;
    return o;
}

const FilmColour& colour_of(const ThinFilmChartResult& r, double d, bool background) {
    for (const FilmColour& c : r.normal_incidence) {
        if (c.thickness_nm == d && c.with_melanin_background == background) return c;
    }
    throw std::runtime_error("film colour missing");
}

TEST(ThinFilmStudy, RockDoveFilmsAreGreenAndPurpleAtNormalIncidence) {
    const auto dir = scratch_root() / "thin_film";
    const ThinFilmChartResult result = run_thin_film_chart(quick_options(dir));
    // CIELAB hue angle: green occupies roughly 120–180° (a* < 0 < b*, towards −a*),
    // purple/magenta roughly 290–350° (a* > 0 > b*). Yin et al. 2006 / Huang 2022:
    // the 595 nm upper-neck film is green, the 530 nm lower-neck film purple.
    for (bool background : {false, true}) {
        const FilmColour& green = colour_of(result, 595.0, background);
        const FilmColour& purple = colour_of(result, 530.0, background);
        EXPECT_GT(green.hue_deg, 120.0);
        EXPECT_LT(green.hue_deg, 180.0);
        EXPECT_GT(purple.hue_deg, 290.0);
        EXPECT_LT(purple.hue_deg, 350.0);
        // Saturated enough to be called a colour, and the melanin background only
        // desaturates (Huang: it "mainly decreases the color saturation").
        EXPECT_GT(green.chroma, 15.0);
        EXPECT_GT(purple.chroma, 15.0);
        // The 5 nm chart grid resolves these colours well below a visible difference.
        EXPECT_LT(green.delta_e00_chart_grid, 0.1);
        EXPECT_LT(purple.delta_e00_chart_grid, 0.1);
    }
    EXPECT_LT(colour_of(result, 595.0, true).chroma, colour_of(result, 595.0, false).chroma);

    // The record holds the chart with the stated shape, and the CSV and PNG exist.
    const auto h5 = dir / "thin_film_chart.h5";
    const auto xyz = record::read_dataset(h5, "chart/xyz");
    EXPECT_EQ(xyz.dims, (std::vector<std::uint64_t>{19, 201, 3}));
    const auto reflectance = record::read_dataset(h5, "chart/reflectance");
    for (double r : reflectance.values) {
        ASSERT_TRUE(r >= 0.0 && r <= 1.0);
    }
    // Zero thickness is the bare-interface pair, no film colour: R ≈ 0 at normal incidence.
    EXPECT_LT(reflectance.values[0], 1e-7);
    EXPECT_EQ(record::read_string_attribute(h5, "/chart", "illuminant"), "D65");
    EXPECT_TRUE(std::filesystem::exists(dir / "spectra_normal_incidence.csv"));
    EXPECT_TRUE(std::filesystem::exists(dir / "thin_film_chart_pixels.png"));
    EXPECT_TRUE(std::filesystem::exists(dir / "report.md"));
    std::filesystem::remove_all(scratch_root());
}

// Issue 18 (4b): the chart's spectra as OpenEXR beside its PNG, opened by OpenEXR's reader:
// linear sRGB plus one reflectance channel per chart wavelength, the record's values.
TEST(ThinFilmStudy, ChartExrBesidePngOpensWithOpenExr) {
    const auto dir = scratch_root() / "thin_film_exr";
    run_thin_film_chart(quick_options(dir));
    const auto exr = dir / "thin_film_chart_pixels.exr";
    ASSERT_TRUE(std::filesystem::exists(dir / "thin_film_chart_pixels.png"));
    ASSERT_TRUE(std::filesystem::exists(exr));
    Imf::MultiPartInputFile file(exr.c_str());
    ASSERT_EQ(file.parts(), 1);
    const Imf::Header& h = file.header(0);
    const auto window = h.dataWindow();
    EXPECT_EQ(window.max.x - window.min.x + 1, 201);  // thicknesses
    EXPECT_EQ(window.max.y - window.min.y + 1, 19);   // angles
    const auto names = testing::exr_channel_names(h);
    ASSERT_EQ(names.size(), 3u + 81u);  // R, G, B and 380–780 nm in 5 nm steps
    for (const char* c : {"R", "G", "B", "T.380nm", "T.555nm", "T.780nm"})
        EXPECT_NE(std::find(names.begin(), names.end(), c), names.end()) << c;
    EXPECT_EQ(h.findTypedAttribute<Imf::StringAttribute>("units")->value(), "1");
    EXPECT_EQ(h.findTypedAttribute<Imf::StringAttribute>("study")->value(), "thin_film");
    // Row 0 is 90° incidence (the record's last angle), as in the PNG.
    const auto reflectance = record::read_dataset(dir / "thin_film_chart.h5", "chart/reflectance");
    const std::vector<float> t555 = testing::exr_channel(file, 0, "T.555nm");
    const std::size_t k555 = (555 - 380) / 5;
    for (std::size_t t : {0u, 100u, 200u}) {
        EXPECT_EQ(t555[t], static_cast<float>(reflectance.values[(18 * 201 + t) * 81 + k555]));
        EXPECT_EQ(t555[18 * 201 + t], static_cast<float>(reflectance.values[t * 81 + k555]));
    }
    std::filesystem::remove_all(scratch_root());
}

// Issue 41: the chart had a seam at 60° incidence. The reflectance is smooth in angle there
// (keratin's Brewster angle, 57°, is no discontinuity of the unpolarised Airy reflectance); the
// seam was the display's: an exposure anchored at the brightest colour below 60° sent the colours
// above over range, and the thick films, all about as bright, crossed into the over-range
// rescaling at the same angle. One exposure under which no colour is over range has no such
// kink: the display colour's curvature along the angle at 59–61° is that of its surroundings.
TEST(ThinFilmStudy, ChartHasNoSeamAcrossSixtyDegrees) {
    const auto dir = scratch_root() / "thin_film_seam";
    ThinFilmChartOptions o = quick_options(dir);
    o.angle_step_deg = 1.0;
    const ThinFilmChartResult result = run_thin_film_chart(o);
    const auto h5 = dir / "thin_film_chart.h5";
    const auto linear = record::read_dataset(h5, "chart/srgb_linear");
    const auto srgb8 = record::read_dataset(h5, "chart/srgb8");
    ASSERT_EQ(srgb8.dims, (std::vector<std::uint64_t>{91, 201, 3}));
    EXPECT_DOUBLE_EQ(record::read_number_attribute(h5, "/chart", "exposure"), result.exposure);
    double largest = 0.0;
    for (double c : linear.values) largest = std::max(largest, c * result.exposure);
    EXPECT_NEAR(largest, 1.0, 1e-12);  // the brightest component is white, nothing beyond
    // Mean |second difference| of the display colour along the angle, per row a (1° rows).
    const std::size_t row = 201 * 3;
    auto curvature = [&](std::size_t a) {
        double sum = 0.0;
        for (std::size_t i = 0; i < row; ++i) {
            sum += std::abs(srgb8.values[(a + 1) * row + i] - 2.0 * srgb8.values[a * row + i] +
                            srgb8.values[(a - 1) * row + i]);
        }
        return sum / static_cast<double>(row);
    };
    std::vector<double> around;
    for (std::size_t a = 40; a <= 80; ++a) around.push_back(curvature(a));
    std::nth_element(around.begin(), around.begin() + 20, around.end());
    const double median = around[20];
    // Mean over the seam's rows 59–61°: 1.37 times the median before the fix (1.42 at 60°),
    // 1.04 after; the 8-bit rounding alone moves a single row's value by about 10 %.
    const double seam = (curvature(59) + curvature(60) + curvature(61)) / 3.0;
    EXPECT_LT(seam, 1.15 * median) << "median " << median;
    std::filesystem::remove_all(scratch_root());
}

TEST(ThinFilmStudy, BadOptionsWriteNothing) {
    const auto dir = scratch_root() / "bad";
    ThinFilmChartOptions o = quick_options(dir);
    o.thickness_step_nm = 0.0;
    EXPECT_NE(plumage::testing::input_error_message([&] {
                  run_thin_film_chart(o);
              }).find("thickness_step_nm = 0"),
              std::string::npos);
    EXPECT_FALSE(std::filesystem::exists(dir));
    std::filesystem::remove_all(scratch_root());
}

}  // namespace
}  // namespace plumage::studies
