// The OpenEXR writer, read back with OpenEXR's own reader (Imf::MultiPartInputFile), not ours:
// channels named by the spectral layout, values bit-exact in float32, attributes present.
#include "virtual_gonio/exr_image.h"

#include <unistd.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFloatVectorAttribute.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfInputPart.h>
#include <OpenEXR/ImfMultiPartInputFile.h>
#include <OpenEXR/ImfStandardAttributes.h>
#include <OpenEXR/ImfStringAttribute.h>
#include <gtest/gtest.h>

#include "common/error.h"
#include "tests/virtual_gonio/exr_test_util.h"

namespace plumage::gonio {
namespace {

using testing::exr_channel;
using testing::exr_channel_names;

std::filesystem::path scratch(const std::string& name) {
    const auto dir =
        std::filesystem::temp_directory_path() / ("plumage_exr_test_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    return dir / name;
}

// 5 × 3 pixels, 4 wavelengths (one not whole), values that float32 rounds, and an error layer.
SpectralImage small_image(const std::string& name) {
    SpectralImage image;
    image.name = name;
    image.width = 5;
    image.height = 3;
    image.wavelengths_nm = {450.0, 532.5, 600.0, 650.0};
    image.units = "1/sr";
    image.quantity_description = "test intensity";
    image.description = "a ramp";
    const std::size_t n = 5 * 3 * 4;
    std::vector<double> error;
    for (std::size_t i = 0; i < n; ++i) {
        image.values.push_back(0.1 * static_cast<double>(i) + 1.0 / 3.0);
        error.push_back(1e-3 * static_cast<double>(i));
    }
    image.layers.push_back({"stderr", error});
    image.attributes["scatterer"] = "test plate";
    return image;
}

TEST(ExrImage, ChannelNamesFollowTheSpectralLayout) {
    using Q = SpectralImage::Quantity;
    EXPECT_EQ(spectral_channel_name(Q::emissive, 450.0), "S0.450nm");
    EXPECT_EQ(spectral_channel_name(Q::emissive, 532.5), "S0.532,5nm");
    EXPECT_EQ(spectral_channel_name(Q::reflective, 380.0), "T.380nm");
}

TEST(ExrImage, SpectralImageReadsBackBitExactWithOpenExr) {
    const auto path = scratch("small.exr");
    const SpectralImage image = small_image("simulation");
    write_spectral_exr(path, {image}, "unit test");
    ASSERT_TRUE(std::filesystem::exists(path));
    for (const auto& entry : std::filesystem::directory_iterator(path.parent_path()))
        EXPECT_EQ(entry.path().string().find(".partial-"), std::string::npos) << entry.path();

    // One image is a single-part file: readers older than multi-part files open it too.
    EXPECT_EQ(exr_channel_names(Imf::InputFile(path.c_str()).header()).size(), 11u);
    Imf::MultiPartInputFile file(path.c_str());
    ASSERT_EQ(file.parts(), 1);
    const Imf::Header& h = file.header(0);
    const auto window = h.dataWindow();
    EXPECT_EQ(window.max.x - window.min.x + 1, 5);
    EXPECT_EQ(window.max.y - window.min.y + 1, 3);
    EXPECT_EQ(exr_channel_names(h),
              (std::vector<std::string>{"B", "G", "R", "S0.450nm", "S0.532,5nm", "S0.600nm",
                                        "S0.650nm", "stderr.S0.450nm", "stderr.S0.532,5nm",
                                        "stderr.S0.600nm", "stderr.S0.650nm"}));
    for (auto c = h.channels().begin(); c != h.channels().end(); ++c)
        EXPECT_EQ(c.channel().type, Imf::FLOAT) << c.name();

    auto text = [&h](const char* key) {
        const auto* a = h.findTypedAttribute<Imf::StringAttribute>(key);
        return a ? a->value() : std::string("<missing>");
    };
    EXPECT_EQ(text("spectralLayoutVersion"), "1.0");
    EXPECT_EQ(text("units"), "1/sr");
    EXPECT_EQ(text("study"), "unit test");
    EXPECT_EQ(text("description"), "a ramp");
    EXPECT_EQ(text("quantity"), "test intensity");
    EXPECT_EQ(text("scatterer"), "test plate");
    EXPECT_NE(text("rgb").find("linear sRGB"), std::string::npos);
    EXPECT_TRUE(Imf::hasChromaticities(h));
    const auto* wl = h.findTypedAttribute<Imf::FloatVectorAttribute>("wavelengths_nm");
    ASSERT_NE(wl, nullptr);
    EXPECT_EQ(wl->value(), (std::vector<float>{450.0f, 532.5f, 600.0f, 650.0f}));

    // Every spectral value is exactly the float32 of the double written.
    for (std::size_t k = 0; k < 4; ++k) {
        const std::string name = spectral_channel_name(image.quantity, image.wavelengths_nm[k]);
        const std::vector<float> v = exr_channel(file, 0, name);
        const std::vector<float> e = exr_channel(file, 0, "stderr." + name);
        ASSERT_EQ(v.size(), 15u);
        for (std::size_t p = 0; p < 15; ++p) {
            const float want = static_cast<float>(image.values[p * 4 + k]);
            const float want_e = static_cast<float>(image.layers[0].values[p * 4 + k]);
            EXPECT_EQ(std::memcmp(&v[p], &want, sizeof(float)), 0) << name << " pixel " << p;
            EXPECT_EQ(std::memcmp(&e[p], &want_e, sizeof(float)), 0) << name << " pixel " << p;
        }
    }
    // A flat spectrum v is grey v in linear sRGB: pixel values are not flat here, but RGB must
    // be finite and the luminance positive where every wavelength is.
    const std::vector<float> g = exr_channel(file, 0, "G");
    for (float x : g) EXPECT_TRUE(std::isfinite(x) && x > 0.0f);
    std::filesystem::remove_all(path.parent_path());
}

TEST(ExrImage, FlatSpectrumIsGreyOfTheSameValue) {
    SpectralImage image = small_image("flat");
    for (double& v : image.values) v = 0.25;
    const auto path = scratch("flat.exr");
    write_spectral_exr(path, {image}, "unit test");
    Imf::MultiPartInputFile file(path.c_str());
    for (const char* c : {"R", "G", "B"}) {
        for (float x : exr_channel(file, 0, c)) EXPECT_NEAR(x, 0.25f, 2e-3f) << c;
    }
    std::filesystem::remove_all(path.parent_path());
}

TEST(ExrImage, SeveralImagesArePartsNamedByTheirImage) {
    const auto path = scratch("parts.exr");
    SpectralImage reflectance = small_image("model");
    reflectance.quantity = SpectralImage::Quantity::reflective;
    reflectance.units = "1";
    reflectance.layers.clear();
    write_spectral_exr(path, {small_image("simulation"), reflectance}, "unit test");
    Imf::MultiPartInputFile file(path.c_str());
    ASSERT_EQ(file.parts(), 2);
    EXPECT_EQ(file.header(0).name(), "simulation");
    EXPECT_EQ(file.header(1).name(), "model");
    EXPECT_EQ(
        exr_channel_names(file.header(1)),
        (std::vector<std::string>{"B", "G", "R", "T.450nm", "T.532,5nm", "T.600nm", "T.650nm"}));
    std::filesystem::remove_all(path.parent_path());
}

TEST(ExrImage, BadImagesAreRefusedAndLeaveNothing) {
    const auto path = scratch("bad.exr");
    SpectralImage image = small_image("a");
    image.values.pop_back();
    EXPECT_THROW(write_spectral_exr(path, {image}, "unit test"), Error);
    EXPECT_THROW(write_spectral_exr(path, {small_image("a"), small_image("a")}, "unit test"),
                 Error);
    EXPECT_FALSE(std::filesystem::exists(path));
    EXPECT_THROW(write_spectral_exr(scratch("no_such_dir") / "x.exr", {small_image("a")}, "t"),
                 IoError);
    std::filesystem::remove_all(path.parent_path());
}

}  // namespace
}  // namespace plumage::gonio
