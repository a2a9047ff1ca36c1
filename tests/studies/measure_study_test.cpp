// The measure study against closed forms: a flat plate imported from an OBJ file, measured by
// the goniometer. Under a thin film (free-standing, or on melanin) every specular pair must read
// the Airy reflectance R(θ, λ) over the detector's projected solid angle π sin²α cos θ (the
// photon estimator's mean, exact for a mirror whose reflection lands inside the cone); a
// Lambertian plate must read albedo/π on every pair. Both within the Monte Carlo error: χ² of the
// cells' z-scores against its own distribution, and no cell beyond 4.5 σ.
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <numbers>
#include <string>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "analysis/metrics/statistics.h"
#include "sim/optics/material.h"
#include "sim/optics/thin_film.h"
#include "studies/study.h"
#include "tests/studies/measurement_streams.h"
#include "tests/test_util.h"
#include "virtual_gonio/record/hdf5_file.h"

namespace plumage::studies {
namespace {

namespace fs = std::filesystem;

constexpr double kDetectorHalfAngleDeg = 2.5;
constexpr double kSignificance = 1e-3;  // per test's χ² verdict
constexpr double kMaxAbsZ = 4.5;        // no single cell further out (≈ 1e-5 two-sided per cell)

struct Measurement {
    fs::path root, dir;
    record::Dataset value, error, angles, wavelengths;
};

// Runs a measure study on studies/measure/plate.obj (scaled by `scale`: 200 µm × scale square)
// with the given [sample] lines and [brdf] table; returns its record.
Measurement run_study(const std::string& name, const std::string& sample, const std::string& brdf,
                      double scale = 1.0) {
    const std::string text = fmt::format(
        "study = \"measure\"\nname = \"{}\"\nseed = 7\n[spectrum]\nfirst_nm = 400\nlast_nm = "
        "700\nstep_nm = 100\n[sample]\nfile = \"measure/plate.obj\"\nscale_to_um = {}\n"
        "require_closed = false\n{}\n[brdf]\ndetector_half_angle_deg = {}\nbeam_radius_um = "
        "20\n{}\n",
        name, scale, sample, kDetectorHalfAngleDeg, brdf);
    const fs::path source = fs::path(PLUMAGE_SOURCE_DIR) / "studies" / "measure_test.toml";
    Measurement r;
    r.root = fs::temp_directory_path() / fmt::format("plumage_measure_{}_{}", name, ::getpid());
    fs::remove_all(r.root);
    const StudyEntry& entry = study_of(text, source);
    EXPECT_EQ(entry.kind, "measure");
    entry.run(text, source, r.root, {});
    r.dir = r.root / name;
    const fs::path h5 = r.dir / "brdf.h5";
    r.value = record::read_dataset(h5, "brdf/value");
    r.error = record::read_dataset(h5, "brdf/standard_error");
    r.angles = record::read_dataset(h5, "instrument/angles_deg");
    r.wavelengths = record::read_dataset(h5, "wavelength_nm");
    return r;
}

// χ² of z = (measured − expected)/σ over every cell, its p-value and the largest |z|.
template <class Expected>
void expect_within_monte_carlo_error(const Measurement& r, Expected expected) {
    const std::size_t nl = r.wavelengths.values.size();
    const std::size_t pairs = r.value.values.size() / nl;
    double chi2 = 0.0, max_z = 0.0;
    for (std::size_t p = 0; p < pairs; ++p) {
        for (std::size_t l = 0; l < nl; ++l) {
            const double f = expected(r.angles.values[4 * p], r.angles.values[4 * p + 2],
                                      r.wavelengths.values[l]);
            const double z = (r.value.values[p * nl + l] - f) / r.error.values[p * nl + l];
            chi2 += z * z;
            max_z = std::max(max_z, std::abs(z));
            EXPECT_LT(std::abs(z), kMaxAbsZ)
                << "pair " << p << " at " << r.wavelengths.values[l]
                << " nm: " << r.value.values[p * nl + l] << " vs " << f;
        }
    }
    const int dof = static_cast<int>(pairs * nl);
    EXPECT_GT(analysis::chi_square_p_value(chi2, dof), kSignificance)
        << "chi2 " << chi2 << " over " << dof << " cells, max |z| " << max_z;
}

double projected_solid_angle(double theta_view_deg) {
    const double a = kDetectorHalfAngleDeg * std::numbers::pi / 180.0;
    return std::numbers::pi * std::sin(a) * std::sin(a) *
           std::cos(theta_view_deg * std::numbers::pi / 180.0);
}

// Airy reflectance of air | film | below at θ, over the detector's projected solid angle.
auto specular(std::shared_ptr<const optics::Material> below, double thickness_um) {
    return [below, thickness_um](double theta_light_deg, double theta_view_deg, double lambda) {
        const optics::FilmMedia media{1.0, optics::keratin()->index(lambda), below->index(lambda)};
        const double r =
            optics::airy_film_intensities_unpolarised(
                media, thickness_um, lambda, std::cos(theta_light_deg * std::numbers::pi / 180.0))
                .reflectance;
        return r / projected_solid_angle(theta_view_deg);
    };
}

TEST(MeasureStudy, FreeStandingKeratinFilmReadsTheAiryReflectance) {
    const Measurement r = run_study("film",
                                    "material = \"air\"\n[sample.film]\nmaterial = \"keratin\"\n"
                                    "thickness_um = 0.5",
                                    "direction_set = \"mirror\"\nmirror_angles_deg = [10, 40, 70]\n"
                                    "quanta_per_pass = 20000\npasses = 2");
    expect_within_monte_carlo_error(r, specular(optics::air(), 0.5));
    EXPECT_TRUE(fs::exists(r.dir / "brdf.png"));
    EXPECT_TRUE(fs::exists(r.dir / "brdf_curves.csv"));
    const std::string report = testing::read_text_file(r.dir / "report.md");
    EXPECT_NE(report.find("| goniometer (BRDF) | 3 pairs × 4 λ"), std::string::npos) << report;
    fs::remove_all(r.root);
}

TEST(MeasureStudy, KeratinFilmOnMelaninReadsTheAbsorbingAiryReflectance) {
    const Measurement r = run_study(
        "melanin",
        "material = \"melanin\"\n[sample.film]\nmaterial = \"keratin\"\n"
        "thickness_um = 0.59",
        "direction_set = \"mirror\"\nmirror_angles_deg = [20, 60]\nquanta_per_pass = 20000\n"
        "passes = 2");
    expect_within_monte_carlo_error(r, specular(optics::melanin(), 0.59));
    fs::remove_all(r.root);
}

TEST(MeasureStudy, LambertianPlateReadsAlbedoOverPi) {
    // A 2 mm plate, so that the 20 µm beam's footprint stays on it up to 81° (the in-plane set).
    const Measurement r =
        run_study("lambertian", "material = \"lambertian\"\nalbedo = 0.6",
                  "direction_set = \"filip2024_in_plane\"\nquanta_per_pass = 20000\n"
                  "passes = 1",
                  10.0);
    expect_within_monte_carlo_error(r,
                                    [](double, double, double) { return 0.6 / std::numbers::pi; });
    fs::remove_all(r.root);
}

TEST(MeasureStudy, BadSamplesAreRefusedNamingTheKey) {
    const fs::path source = fs::path(PLUMAGE_SOURCE_DIR) / "studies" / "measure_test.toml";
    const auto message = [&](const std::string& sample) {
        const std::string text =
            "study = \"measure\"\n[sample]\n" + sample + "\n[brdf]\ndirection_set = \"mirror\"\n";
        return testing::input_error_message([&] { check_study(text, source); });
    };
    EXPECT_NE(message("file = \"measure/none.ply\"\nmaterial = \"keratin\"")
                  .find("measure_test.toml:3:8: sample.file = \"measure/none.ply\": no such file"),
              std::string::npos);
    EXPECT_NE(message("file = \"measure/plate.obj\"\nmaterial = \"gold\"").find("sample.material"),
              std::string::npos);
    EXPECT_NE(message("file = \"measure/plate.obj\"\nmaterial = \"keratin\"\n[sample.film]\n"
                      "material = \"keratin\"\nthickness_um = -1")
                  .find("sample.film.thickness_um = -1"),
              std::string::npos);
    EXPECT_NE(message("file = \"measure/plate.obj\"\nmaterial = \"air\"").find("would not scatter"),
              std::string::npos);
    EXPECT_NE(testing::input_error_message([&] {
                  check_study(
                      "study = \"measure\"\n[sample]\nfile = \"measure/plate.obj\"\n"
                      "material = \"keratin\"\n",
                      source);
              }).find("at least one instrument"),
              std::string::npos);
}

// [btf] is read by the BTF camera's shared reader (studies/instrument_tables.h): the measure
// study images with the detector-side estimator in passes and stratified groups, as the species
// study does, and refuses the detector walk under collimated light or a group that does not
// divide the quanta, naming the key.
TEST(MeasureStudy, BtfTableTakesTheDetectorEstimatorAndItsPasses) {
    const fs::path source = fs::path(PLUMAGE_SOURCE_DIR) / "studies" / "measure_test.toml";
    const std::string base =
        "study = \"measure\"\nname = \"btf_detector\"\n[spectrum]\nfirst_nm = 450\nlast_nm = "
        "650\nstep_nm = 100\n[sample]\nfile = \"measure/plate.obj\"\nrequire_closed = false\n"
        "material = \"lambertian\"\nalbedo = 0.6\n[btf]\nmirror_angles_deg = [30]\n"
        "patch_size_um = 40\npixels = 4\nestimator = \"detector\"\nquanta_per_pixel = 400\n"
        "max_passes = 3\n";
    const std::string refused = testing::input_error_message([&] { check_study(base, source); });
    EXPECT_NE(
        refused.find("measure_test.toml:16:13: [btf] estimator = \"detector\" needs aperture"),
        std::string::npos)
        << refused;
    const std::string odd_group = testing::input_error_message(
        [&] { check_study(base + "aperture = \"both_cones\"\nstratified_group = 48\n", source); });
    EXPECT_NE(odd_group.find("[btf] stratified_group = 48: expected a power of two that divides "
                             "quanta_per_pixel (400)"),
              std::string::npos)
        << odd_group;
    const std::string text = base + "aperture = \"both_cones\"\nstratified_group = 16\n";
    const fs::path root =
        fs::temp_directory_path() / fmt::format("plumage_measure_btf_{}", ::getpid());
    fs::remove_all(root);
    study_of(text, source).run(text, source, root, {});
    const fs::path h5 = root / "btf_detector" / "btf.h5";
    EXPECT_EQ(record::read_string_attribute(h5, "/instrument", "estimator"), "detector");
    EXPECT_EQ(record::read_dataset(h5, "convergence").dims.at(0), 3u);  // max_passes, no target
    EXPECT_EQ(record::read_number_attribute(h5, "/instrument", "stratified_group"), 16.0);
    // A Lambertian plate images as ρ/π in every pixel, within the Monte Carlo error.
    const record::Dataset value = record::read_dataset(h5, "btf/value");
    const record::Dataset error = record::read_dataset(h5, "btf/standard_error");
    double chi2 = 0.0;
    for (std::size_t i = 0; i < value.values.size(); ++i) {
        const double z = (value.values[i] - 0.6 / std::numbers::pi) / error.values[i];
        chi2 += z * z;
    }
    EXPECT_GT(analysis::chi_square_p_value(chi2, static_cast<int>(value.values.size())),
              kSignificance);
    fs::remove_all(root);
}

// The integrating sphere is a registered instrument (virtual_gonio/instrument_registry.h): the
// measure study reads its table by its parameter table, and it measures a free-standing keratin
// film's R as the Airy reflectance at the light's angle, with T = 1 − R (nothing absorbs).
TEST(MeasureStudy, RegisteredInstrumentIsReadFromItsOwnTable) {
    const fs::path source = fs::path(PLUMAGE_SOURCE_DIR) / "studies" / "measure_test.toml";
    const std::string base =
        "study = \"measure\"\nname = \"sphere\"\nseed = 3\n[spectrum]\nfirst_nm = 400\n"
        "last_nm = 700\nstep_nm = 100\n[sample]\nfile = \"measure/plate.obj\"\n"
        "require_closed = false\nmaterial = \"air\"\n[sample.film]\nmaterial = \"keratin\"\n"
        "thickness_um = 0.5\n[integrating_sphere]\nquanta_per_pass = 20000\nmax_passes = 2\n"
        "target_relative_error = 0\n";
    const std::string refused =
        testing::input_error_message([&] { check_study(base + "incidence_deg = 90\n", source); });
    EXPECT_NE(refused.find("measure_test.toml:19:17: integrating_sphere.incidence_deg"),
              std::string::npos)
        << refused;
    const std::string text = base + "incidence_deg = 40\n";
    const fs::path root =
        fs::temp_directory_path() / fmt::format("plumage_measure_sphere_{}", ::getpid());
    fs::remove_all(root);
    study_of(text, source).run(text, source, root, {});
    const fs::path h5 = root / "sphere" / "integrating_sphere.h5";
    const record::Dataset wl = record::read_dataset(h5, "wavelength_nm");
    const record::Dataset r = record::read_dataset(h5, "reflectance");
    const record::Dataset r_error = record::read_dataset(h5, "reflectance_standard_error");
    const record::Dataset t = record::read_dataset(h5, "transmittance");
    const record::Dataset t_error = record::read_dataset(h5, "transmittance_standard_error");
    ASSERT_EQ(wl.values.size(), 4u);
    double chi2 = 0.0;
    for (std::size_t l = 0; l < wl.values.size(); ++l) {
        const optics::FilmMedia media{1.0, optics::keratin()->index(wl.values[l]), 1.0};
        const double airy = optics::airy_film_intensities_unpolarised(
                                media, 0.5, wl.values[l], std::cos(40.0 * std::numbers::pi / 180.0))
                                .reflectance;
        const double z = (r.values[l] - airy) / r_error.values[l];
        chi2 += z * z;
        EXPECT_LT(std::abs(z), kMaxAbsZ)
            << wl.values[l] << " nm: " << r.values[l] << " vs " << airy;
        EXPECT_NEAR(r.values[l] + t.values[l], 1.0,
                    1e-9 + kMaxAbsZ * (r_error.values[l] + t_error.values[l]));
    }
    EXPECT_GT(analysis::chi_square_p_value(chi2, static_cast<int>(wl.values.size())),
              kSignificance);
    const std::string report = testing::read_text_file(root / "sphere" / "report.md");
    EXPECT_NE(report.find("| integrating sphere (directional-hemispherical"), std::string::npos)
        << report;
    EXPECT_TRUE(fs::exists(root / "sphere" / "integrating_sphere_curves.h5"));
    EXPECT_TRUE(fs::exists(root / "sphere" / "integrating_sphere_curves.png"));
    fs::remove_all(root);
}

TEST(MeasureStudy, ExampleRunsAndMeasuresEveryInstrumentItNames) {
    const fs::path study = fs::path(PLUMAGE_SOURCE_DIR) / "studies" / "measure_example.toml";
    const std::string text = testing::read_text_file(study);
    const fs::path root =
        fs::temp_directory_path() / fmt::format("plumage_measure_example_{}", ::getpid());
    fs::remove_all(root);
    clear_recorded_measurement_seeds();
    study_of(text, study).run(text, study, root, {});
    // Measurements the report compares must not share their noise (issue 39).
    test::expect_each_measurement_its_own_streams();
    for (const char* f : {"brdf.h5", "brdf.png", "scatterogram.h5", "scatterogram.exr",
                          "integrating_sphere.h5", "report.md"})
        EXPECT_TRUE(fs::exists(root / "measure_example" / f)) << f;
    // Issue 41: the report embeds the figures it drew, not only names them in the table.
    const std::string report = testing::read_text_file(root / "measure_example" / "report.md");
    for (const char* png :
         {"](brdf.png)", "](scatterogram.png)", "](integrating_sphere_curves.png)"})
        EXPECT_NE(report.find(png), std::string::npos) << png << " not embedded:\n" << report;
    EXPECT_FALSE(fs::exists(root / ".checkpoints"));
    fs::remove_all(root);
}

}  // namespace
}  // namespace plumage::studies
