// Issue 18: study files take wavelengths over 300–800 nm (where keratin and melanin dispersion is
// cited, sim/optics/material.h), and refuse anything outside it naming the key and the range.
// The calibration study (a goniometer on a white standard, seconds) runs the whole range.
#include <unistd.h>

#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "studies/study.h"
#include "tests/test_util.h"

namespace plumage::studies {
namespace {

namespace fs = std::filesystem;

std::string calibration_with_spectrum(const std::string& first, const std::string& last,
                                      const std::string& step) {
    const fs::path study = fs::path(PLUMAGE_SOURCE_DIR) / "studies" / "calibration.toml";
    std::string text = testing::read_text_file(study);
    text.replace(text.find("first_nm = 450"), 14, "first_nm = " + first);
    text.replace(text.find("last_nm = 650"), 13, "last_nm = " + last);
    text.replace(text.find("step_nm = 100"), 13, "step_nm = " + step);
    return text;
}

TEST(SpectralRange, A300To800NanometreStudyValidatesAndRuns) {
    const fs::path source = "calibration.toml";
    const std::string text = calibration_with_spectrum("300", "800", "250");
    check_study(text, source);
    const fs::path root =
        fs::temp_directory_path() / ("plumage_spectral_range_" + std::to_string(::getpid()));
    fs::remove_all(root);
    const std::string summary = study_of(text, source).run(text, source, root, {});
    EXPECT_NE(summary.find("agrees"), std::string::npos) << summary;
    const std::string report = testing::read_text_file(root / "calibration" / "report.md");
    EXPECT_NE(report.find("300"), std::string::npos);
    fs::remove_all(root);
}

TEST(SpectralRange, OutsideTheRangeIsRefusedWithKeyAndRange) {
    const fs::path source = "calibration.toml";
    const std::string low = testing::input_error_message(
        [&] { check_study(calibration_with_spectrum("290", "800", "100"), source); });
    EXPECT_NE(low.find("spectrum.first_nm = 290: expected a number in [300, 800]"),
              std::string::npos)
        << low;
    const std::string high = testing::input_error_message(
        [&] { check_study(calibration_with_spectrum("300", "830", "100"), source); });
    EXPECT_NE(high.find("spectrum.last_nm = 830: expected a number in [300, 800]"),
              std::string::npos)
        << high;
}

}  // namespace
}  // namespace plumage::studies
