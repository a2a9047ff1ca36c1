// Issue 43: every size a run will allocate is estimated from its validated inputs and refused at
// read time, naming the key, the value, the estimate and the limit (common/memory_limit.h), where
// before each ran until memory was gone: the spongy study at its documented maximum of 512 voxels
// per side (about 41 GB), the wave-validity detector step 1e-300 deg and its rows of b = 0.001.
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "common/memory_limit.h"
#include "studies/study.h"
#include "tests/test_util.h"

namespace plumage::studies {
namespace {

namespace fs = std::filesystem;

fs::path quick(const std::string& kind) {
    return fs::path(PLUMAGE_SOURCE_DIR) / "studies" / (kind + "_quick.toml");
}

// The quick study file of `kind` with the line matching `pattern` replaced by `line`.
std::string with_line(const std::string& kind, const std::string& pattern,
                      const std::string& line) {
    std::ifstream in(quick(kind));
    std::stringstream text;
    text << in.rdbuf();
    const std::string replaced =
        std::regex_replace(text.str(), std::regex(pattern, std::regex::multiline), line);
    EXPECT_NE(replaced, text.str()) << pattern;
    return replaced;
}

TEST(SizeLimits, SpongyVolumeOverTheMemoryLimitIsRefusedAtReadTime) {
    // 512 voxels of 0.025 µm per side: the documented maximum, about 41 GB.
    const std::string text = with_line("spongy", "^box_um = .*$", "box_um = 12.8");
    const std::string message =
        plumage::testing::input_error_message([&] { check_study(text, quick("spongy")); });
    EXPECT_NE(message.find("512 voxels per side"), std::string::npos) << message;
    EXPECT_NE(message.find("needs an estimated 4"), std::string::npos) << message;
    EXPECT_NE(message.find("over the limit of"), std::string::npos) << message;
    // 128 per side (0.7 GB) passes.
    const std::string smaller = with_line("spongy", "^box_um = .*$", "box_um = 3.2");
    EXPECT_NO_THROW(check_study(smaller, quick("spongy")));
}

TEST(SizeLimits, WaveValidityDetectorStepHasALowerBound) {
    for (const char* step : {"1e-300", "0.001"}) {
        const std::string text =
            with_line("wave_validity", "^\\[row\\]$",
                      std::string("[detector]\nstep_deg = ") + step + "\n\n[row]");
        const std::string message = plumage::testing::input_error_message(
            [&] { check_study(text, quick("wave_validity")); });
        EXPECT_NE(message.find("step_deg"), std::string::npos) << message;
        EXPECT_NE(message.find("0.01"), std::string::npos) << message;
    }
}

TEST(SizeLimits, WaveValidityRowsOfThinBarbulesAreRefusedAtReadTime) {
    // b = 0.001: tips of radius b²A, sampled at 0.95 of it: 6.5 × 10⁷ samples in the 2 µm row,
    // which ran without end before.
    const std::string text = with_line("wave_validity", "^b = .*$", "b = [0.001, 0.25]");
    const std::string message =
        plumage::testing::input_error_message([&] { check_study(text, quick("wave_validity")); });
    EXPECT_NE(message.find("the row of b = 0.001"), std::string::npos) << message;
    EXPECT_NE(message.find("at most 100000"), std::string::npos) << message;
    EXPECT_NO_THROW(check_study(with_line("wave_validity", "^b = .*$", "b = [0.1, 0.25]"),
                                quick("wave_validity")));
}

}  // namespace
}  // namespace plumage::studies
