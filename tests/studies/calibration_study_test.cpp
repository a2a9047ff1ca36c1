// The calibration study (the example of studies/README.md's "Adding a study"): registered by
// its one line, checked like every study, and the goniometer's photon estimator agrees with
// f = ρ/π on a white standard, χ² within its own spread.
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "studies/study.h"
#include "tests/studies/measurement_streams.h"
#include "tests/test_util.h"
#include "virtual_gonio/record/hdf5_file.h"

namespace plumage::studies {
namespace {

namespace fs = std::filesystem;

std::string read(const fs::path& p) { return testing::read_text_file(p); }

TEST(CalibrationStudy, RegisteredByItsOneLineAndAgreesWithTheClosedForm) {
    const fs::path study = fs::path(PLUMAGE_SOURCE_DIR) / "studies" / "calibration.toml";
    const std::string text = read(study);
    const StudyEntry& entry = study_of(text, study);
    EXPECT_EQ(entry.kind, "calibration");
    const fs::path root =
        fs::temp_directory_path() / ("plumage_calibration_" + std::to_string(::getpid()));
    fs::remove_all(root);
    clear_recorded_measurement_seeds();
    const std::string summary = entry.run(text, study, root, {});
    test::expect_each_measurement_its_own_streams();
    EXPECT_NE(summary.find("agrees"), std::string::npos) << summary;
    // 165 cells: χ²/dof within 4 standard deviations (sqrt(2/dof)) of 1.
    const double chi2 =
        record::read_number_attribute(root / "calibration" / "calibration.h5", "/", "chi_square");
    const double dof = record::read_number_attribute(root / "calibration" / "calibration.h5", "/",
                                                     "chi_square_dof");
    EXPECT_EQ(dof, 165.0);
    EXPECT_LT(std::abs(chi2 / dof - 1.0), 4.0 * std::sqrt(2.0 / dof));
    // The run time by stage, in the report and beside it; the record's CPU time.
    const fs::path dir = root / "calibration";
    const std::string report = read(dir / "report.md");
    EXPECT_NE(report.find("## Run time by stage"), std::string::npos);
    EXPECT_NE(report.find("| measuring the standard on 55 pairs | "), std::string::npos) << report;
    EXPECT_NE(report.find("| **total** |"), std::string::npos);
    const std::string csv = read(dir / "stages.csv");
    EXPECT_EQ(csv.rfind("stage,wall time (s),cpu time (s),cpu/wall\n"
                        "reading the study file,",
                        0),
              0u)
        << csv;
    const double cpu = record::read_number_attribute(dir / "brdf.h5", "/provenance", "cpu_time_s");
    const double wall =
        record::read_number_attribute(dir / "brdf.h5", "/provenance", "wall_time_s");
    EXPECT_GT(cpu, 0.0);
    EXPECT_NEAR(record::read_number_attribute(dir / "brdf.h5", "/provenance", "cpu_per_wall"),
                cpu / wall, 1e-12);
    fs::remove_all(root);
}

TEST(CalibrationStudy, BadKeysAreNamed) {
    const fs::path study = fs::path(PLUMAGE_SOURCE_DIR) / "studies" / "calibration.toml";
    std::string text = read(study);
    text.replace(text.find("albedo = 0.99"), 13, "albedo = 1.5");
    EXPECT_NE(testing::input_error_message([&] {
                  check_study(text, study);
              }).find("calibration.toml:13:10: standard.albedo = 1.5: expected a number in [0, 1]"),
              std::string::npos);
}

}  // namespace
}  // namespace plumage::studies
