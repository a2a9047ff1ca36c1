// Every instrument's record says which run made it and what each number is (RECORD.md):
// /provenance with the commit, date, host, compiler and library versions, the seed as an exact
// uint64 and the thread count as an integer; the polarisation stated; `units` and `description`
// on every dataset; the scatterogram's per-pixel directions written out.
#include "virtual_gonio/record_provenance.h"

#include <omp.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <ctime>
#include <filesystem>
#include <iomanip>
#include <regex>
#include <sstream>

#include <gtest/gtest.h>

#include "analysis/models/lambertian.h"
#include "common/build_info.h"
#include "common/constants.h"
#include "virtual_gonio/btf.h"
#include "virtual_gonio/goniometer.h"
#include "virtual_gonio/record/hdf5_file.h"
#include "virtual_gonio/scatterometer.h"

namespace plumage::gonio {
namespace {

namespace fs = std::filesystem;
using record::AttributeType;

// Above 2^53: a double could not hold it, the uint64 attribute must.
constexpr std::uint64_t kSeed = 18446744073709551557ULL;  // the largest 64-bit prime

fs::path scratch_dir() {
    return fs::temp_directory_path() / ("plumage_records_" + std::to_string(::getpid()));
}

fs::path scratch(const std::string& name) {
    fs::create_directories(scratch_dir());
    return scratch_dir() / name;
}

std::vector<DirectionPair> two_pairs() {
    return {{Vec3d(0.0, 0.0, 1.0), Vec3d(std::sin(0.5), 0.0, std::cos(0.5))},
            {Vec3d(std::sin(0.8), 0.0, std::cos(0.8)), Vec3d(0.0, std::sin(0.3), std::cos(0.3))}};
}

fs::path goniometer_record() {
    const analysis::LambertianScatterer plate(0.6);
    GoniometerConfig c;
    c.pairs = two_pairs();
    c.direction_set = "custom";
    c.detector_half_angle_rad = 10.0 * kPi / 180.0;
    c.wavelengths_nm = {500.0, 600.0};
    c.seed = kSeed;
    c.quanta_per_pass = 2000;
    c.max_passes = 2;
    const auto path = scratch("brdf.h5");
    write_brdf_record(measure_brdf(plate, c), path);
    return path;
}

fs::path scatterometer_record() {
    const analysis::LambertianScatterer plate(0.5);
    ScatterometerConfig c;
    c.image_size = 15;
    c.wavelengths_nm = {500.0, 600.0};
    c.seed = kSeed;
    c.quanta_per_pass = 4000;
    c.max_passes = 2;
    const auto path = scratch("scatterogram.h5");
    write_scatterogram_record(measure_scatterogram(plate, c), path);
    return path;
}

fs::path btf_record() {
    const analysis::LambertianScatterer plate(0.6);
    BtfConfig c;
    c.pairs = two_pairs();
    c.wavelengths_nm = {550.0};
    c.pixels = 4;
    c.patch_size_um = 100.0;
    c.seed = kSeed;
    c.quanta_per_light = 20000;
    const auto path = scratch("btf.h5");
    write_btf_record(measure_btf(plate, c), path);
    return path;
}

struct Instrument {
    const char* kind;
    fs::path (*write)();
};
void PrintTo(const Instrument& instrument, std::ostream* out) { *out << instrument.kind; }

const Instrument kInstruments[] = {{"goniometer", goniometer_record},
                                   {"imaging_scatterometer", scatterometer_record},
                                   {"btf_camera", btf_record}};

std::string attribute(const fs::path& file, const std::string& object, const std::string& name) {
    return record::read_string_attribute(file, object, name);
}

// Seconds between the record's @date ("YYYY-MM-DDTHH:MM:SSZ", UTC) and now.
double age_of_date(const std::string& date) {
    std::tm t{};
    std::istringstream(date) >> std::get_time(&t, "%Y-%m-%dT%H:%M:%SZ");
    const std::time_t written = ::timegm(&t);
    return std::difftime(std::time(nullptr), written);
}

class InstrumentRecord : public ::testing::TestWithParam<Instrument> {
protected:
    void TearDown() override { fs::remove_all(scratch_dir()); }
};

TEST_P(InstrumentRecord, ProvenanceSaysWhichRunMadeIt) {
    const fs::path file = GetParam().write();
    EXPECT_EQ(attribute(file, "/instrument", "kind"), GetParam().kind);
    const std::string p = "/provenance";
    for (const char* name : {"scatterer", "plumage_version", "git_commit", "date", "host",
                             "compiler", "embree_version", "hdf5_version", "eigen_version",
                             "openvdb_version", "cgal_version", "config"}) {
        ASSERT_TRUE(record::has_attribute(file, p, name)) << name;
        EXPECT_EQ(record::attribute_type(file, p, name), AttributeType::string) << name;
    }
    EXPECT_EQ(attribute(file, p, "git_commit"), git_commit());
    EXPECT_FALSE(attribute(file, p, "git_commit").empty());
    EXPECT_FALSE(attribute(file, p, "host").empty());
    EXPECT_EQ(attribute(file, p, "compiler"), compiler());
    for (const LibraryVersion& library : library_versions()) {
        EXPECT_FALSE(library.version.empty()) << library.name << ": CMake found no version";
    }
    const std::string date = attribute(file, p, "date");
    EXPECT_TRUE(std::regex_match(date, std::regex(R"(\d{4}-\d\d-\d\dT\d\d:\d\d:\d\dZ)"))) << date;
    EXPECT_LT(std::abs(age_of_date(date)), 600.0) << date << " is not the time of the run";

    EXPECT_EQ(record::attribute_type(file, p, "seed"), AttributeType::unsigned_integer);
    EXPECT_EQ(record::read_unsigned_attribute(file, p, "seed"), kSeed);
    EXPECT_EQ(record::attribute_type(file, p, "threads"), AttributeType::signed_integer);
    EXPECT_EQ(record::read_number_attribute(file, p, "threads"), omp_get_max_threads());
    for (const char* name : {"wall_time_s", "cpu_time_s", "cpu_per_wall"}) {
        EXPECT_EQ(record::attribute_type(file, p, name), AttributeType::floating_point) << name;
    }
}

TEST_P(InstrumentRecord, StatesThePolarisation) {
    const fs::path file = GetParam().write();
    EXPECT_EQ(attribute(file, "/instrument", "polarisation").rfind("unpolarised", 0), 0u);
}

TEST_P(InstrumentRecord, EveryDatasetHasUnitsAndADescription) {
    const fs::path file = GetParam().write();
    const std::vector<std::string> datasets = record::dataset_paths(file);
    EXPECT_GE(datasets.size(), 3u);
    for (const std::string& dataset : datasets) {
        for (const char* name : {"units", "description"}) {
            ASSERT_TRUE(record::has_attribute(file, dataset, name)) << dataset << " @" << name;
            EXPECT_EQ(record::attribute_type(file, dataset, name), AttributeType::string);
            EXPECT_FALSE(attribute(file, dataset, name).empty()) << dataset << " @" << name;
        }
    }
}

INSTANTIATE_TEST_SUITE_P(EveryInstrument, InstrumentRecord, ::testing::ValuesIn(kInstruments),
                         [](const auto& instrument) { return std::string(instrument.param.kind); });

TEST(ScatterogramRecord, EveryPixelHasItsDirection) {
    const fs::path file = scatterometer_record();
    const auto directions = record::read_dataset(file, "image/directions");
    const auto solid_angle = record::read_dataset(file, "image/solid_angle_sr");
    ASSERT_EQ(directions.dims, (std::vector<std::uint64_t>{15, 15, 3}));
    int inside = 0;
    for (int row = 0; row < 15; ++row) {
        for (int column = 0; column < 15; ++column) {
            const std::size_t pixel = static_cast<std::size_t>(row) * 15 + column;
            const double* w = &directions.values[pixel * 3];
            if (solid_angle.values[pixel] == 0.0) {  // outside the disc
                EXPECT_TRUE(std::isnan(w[0]) && std::isnan(w[1]) && std::isnan(w[2]));
                continue;
            }
            ++inside;
            EXPECT_NEAR(std::hypot(w[0], w[1], w[2]), 1.0, 1e-12);
            EXPECT_GE(w[2], 0.0);  // the upper hemisphere, away from the patch
            // The mapping string's rule: theta = 90° · hypot(u, v), phi = atan2(v, u).
            const double u = (column + 0.5) * 2.0 / 15 - 1.0, v = 1.0 - (row + 0.5) * 2.0 / 15;
            EXPECT_NEAR(std::acos(w[2]), 0.5 * kPi * std::hypot(u, v), 1e-9);
            if (std::hypot(u, v) > 1e-9) {  // φ, wrapped: ±π are one azimuth
                EXPECT_NEAR(std::remainder(std::atan2(w[1], w[0]) - std::atan2(v, u), 2.0 * kPi),
                            0.0, 1e-9);
            }
        }
    }
    EXPECT_GT(inside, 150);                                           // π/4 of 225 pixels
    EXPECT_FALSE(attribute(file, "/instrument", "mapping").empty());  // kept beside the array
    fs::remove_all(scratch_dir());
}

}  // namespace
}  // namespace plumage::gonio
