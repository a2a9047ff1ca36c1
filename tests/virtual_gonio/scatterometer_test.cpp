// The imaging scatterometer: a Lambertian plate images as ρ cos θ / π under every
// illumination; power is accounted for; Huang's T lobe leaves below the patch in the
// proportion Eq. 15 predicts; images and records are written.
#include "virtual_gonio/scatterometer.h"
#include "common/constants.h"

#include <unistd.h>

#include <cmath>
#include <filesystem>

#include <gtest/gtest.h>

#include "analysis/huang2022.h"
#include "analysis/lambertian.h"
#include "common/error.h"
#include "virtual_gonio/hdf5_file.h"

namespace plumage::gonio {
namespace {

TEST(Scatterometer, LambertianPlateImagesAsCosineUnderEveryIllumination) {
    const analysis::LambertianScatterer plate(0.7);
    for (Illumination mode : {Illumination::beam, Illumination::cone, Illumination::hemisphere}) {
        ScatterometerConfig c;
        c.illumination = mode;
        c.image_size = 33;
        c.wavelengths_nm = {550.0};
        c.quanta_per_pass = 400000;
        c.max_passes = 1;
        const Scatterogram s = measure_scatterogram(plate, c);
        double power = 0.0, worst = 0.0;
        for (int row = 0; row < c.image_size; ++row) {
            for (int column = 0; column < c.image_size; ++column) {
                const std::size_t p = static_cast<std::size_t>(row) * c.image_size + column;
                const auto w = s.direction(column, row);
                if (!w || s.solid_angle_sr[p] <= 0.0) continue;
                power += s.intensity[p] * s.solid_angle_sr[p];
                // Pixel-centre cos θ vs the pixel average: curvature error ≲ 1e-3 here.
                const double expected = 0.7 * w->z() / kPi;
                if (s.standard_error[p] > 0.0) {
                    worst = std::max(worst, std::abs(s.intensity[p] - expected) /
                                                (s.standard_error[p] + 2e-3 * expected));
                }
            }
        }
        // Pixels at the rim are cut by the disc edge: power within 2 % of ρ.
        EXPECT_NEAR(power, 0.7, 0.014) << static_cast<int>(mode);
        EXPECT_LT(worst, std::sqrt(2.0 * std::log(900.0 / 1e-3))) << static_cast<int>(mode);
    }
}

TEST(Scatterometer, HuangTLobeLeavesBelowInTheProportionOfEq15) {
    analysis::Huang2022Params p;
    p.H = 2.0;  // gaps between barbules: a sizeable T lobe at oblique light
    const analysis::Huang2022Bsdf model(p);
    ScatterometerConfig c;
    c.beam_direction = Vec3d(std::sin(0.6), 0.0, std::cos(0.6));
    c.image_size = 33;
    c.wavelengths_nm = {500.0, 600.0};
    c.quanta_per_pass = 100000;
    c.max_passes = 1;
    const Scatterogram s = measure_scatterogram(model, c);
    const double expected = model.t_lobe_mass(c.beam_direction);
    EXPECT_GT(expected, 0.05);
    for (std::size_t k = 0; k < c.wavelengths_nm.size(); ++k) {
        // The T lobe's share below the patch; binomial σ = sqrt(p(1 − p)/N). (R can also
        // leave downwards, off the barbules' steep edges: the total below is larger.)
        const double t =
            s.transmitted_lobes[analysis::Huang2022Bsdf::kT * c.wavelengths_nm.size() + k];
        EXPECT_NEAR(t, expected, 4.0 * std::sqrt(expected * (1.0 - expected) / 1e5));
        EXPECT_GE(s.transmitted[k], t);
    }
}

TEST(Scatterometer, WritesImagesAndARecord) {
    const analysis::LambertianScatterer plate(0.5);
    ScatterometerConfig c;
    c.image_size = 31;
    c.quanta_per_pass = 20000;
    c.max_passes = 2;
    const Scatterogram s = measure_scatterogram(plate, c);
    const auto dir = std::filesystem::temp_directory_path() /
                     ("plumage_scatterometer_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    write_scatterogram_record(s, dir / "s.h5");
    record::write_png(dir / "s.png", scatterogram_srgb(s));
    const auto intensity = record::read_dataset(dir / "s.h5", "image/intensity");
    EXPECT_EQ(intensity.dims, (std::vector<std::uint64_t>{31, 31, 5}));
    EXPECT_EQ(record::read_string_attribute(dir / "s.h5", "/instrument", "illumination"), "beam");
    EXPECT_EQ(record::read_dataset(dir / "s.h5", "convergence").dims,
              (std::vector<std::uint64_t>{2, 4}));
    // A white plate images grey: equal sRGB channels, averaged over the central 9 × 9
    // pixels (each pixel alone carries ~10 % Monte Carlo noise per wavelength here).
    const auto img = scatterogram_srgb(s, 0.0, false);
    std::array<double, 3> mean{};
    for (int row = 11; row < 20; ++row)
        for (int column = 11; column < 20; ++column)
            for (int ch = 0; ch < 3; ++ch)
                mean[ch] += img.pixels[(row * 31 + column) * 3 + ch] / 81.0;
    EXPECT_NEAR(mean[0], mean[1], 3.0);
    EXPECT_NEAR(mean[1], mean[2], 3.0);
    std::filesystem::remove_all(dir);
}

TEST(Scatterometer, RejectsBadConfigurations) {
    const analysis::LambertianScatterer plate(0.5);
    ScatterometerConfig c;
    c.beam_direction = Vec3d(0.0, 0.0, -1.0);
    EXPECT_THROW(measure_scatterogram(plate, c), InputError);
    c = {};
    c.illumination = Illumination::cone;
    c.beam_direction = Vec3d(std::sin(1.5), 0.0, std::cos(1.5));
    EXPECT_THROW(measure_scatterogram(plate, c), InputError);
    c = {};
    c.image_size = 3;
    EXPECT_THROW(measure_scatterogram(plate, c), InputError);
}

}  // namespace
}  // namespace plumage::gonio
