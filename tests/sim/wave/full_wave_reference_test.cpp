// The full-wave reference reader (sim/wave/compare/full_wave_reference.h): the shipped Meep folder
// reads into its 24 curves with a convergence row each, and bad files fail with the file, the line
// and what was expected.
#include "sim/wave/compare/full_wave_reference.h"

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "common/constants.h"
#include "common/error.h"

namespace plumage::sim::wave {
namespace {

namespace fs = std::filesystem;

fs::path reference_dir() { return fs::path(PLUMAGE_SOURCE_DIR) / "tests/reference/barbule_2d"; }

TEST(FullWaveReference, ReadsTheShippedCurves) {
    const FullWaveReference ref = read_full_wave_reference(reference_dir());
    EXPECT_EQ(ref.far_field.size(), 24u);
    EXPECT_EQ(ref.convergence.size(), 24u);
    const FullWaveCurve& c = ref.far_field.at({"single", "TE", 0, 450});
    ASSERT_EQ(c.theta_s_rad.size(), 720u);
    EXPECT_NEAR(c.theta_s_rad.front(), -179.5 * kDeg, 1e-12);
    EXPECT_NEAR(c.theta_s_rad.back(), 180.0 * kDeg, 1e-12);
    EXPECT_EQ(c.sigma_um_per_rad.front(), 220.7);  // the file's first row
    EXPECT_EQ(c.resolution_px_per_um, 60.0);
    EXPECT_EQ(ref.convergence.at({"row3", "TE", 0, 450}).sigma_rms_rel_diff, 0.0160);
    EXPECT_EQ(full_wave_row("row3").count, 3);
    EXPECT_NEAR(full_wave_projected_width("single", 0.0), 10.6, 1e-12);
    EXPECT_THROW(full_wave_shape("large"), InputError);
}

class BadReference : public ::testing::Test {
protected:
    void SetUp() override {
        dir = fs::temp_directory_path() /
              ("plumage_full_wave_reference_" + std::to_string(::getpid()));
        fs::remove_all(dir);
        fs::create_directories(dir);
        // A valid convergence.csv and the first rows of a far_field.csv.
        fs::copy_file(reference_dir() / "convergence.csv", dir / "convergence.csv");
    }
    void TearDown() override { fs::remove_all(dir); }
    void write_far_field(const std::string& text) { std::ofstream(dir / "far_field.csv") << text; }
    std::string error() {
        try {
            read_full_wave_reference(dir);
        } catch (const InputError& e) {
            return e.what();
        }
        return "(accepted)";
    }
    fs::path dir;
};

TEST_F(BadReference, MissingFileIsNamed) {
    const std::string e = error();
    EXPECT_NE(e.find("far_field.csv"), std::string::npos) << e;
    EXPECT_NE(e.find("cannot open"), std::string::npos) << e;
}

TEST_F(BadReference, MissingColumnIsNamedWithTheHeaderLine) {
    write_far_field(
        "case,polarisation,theta_i_deg,lambda_nm,resolution_px_per_um,theta_s_deg\r\n"
        "single,TE,0,450,60,-179.5\r\n");
    const std::string e = error();
    EXPECT_NE(e.find("far_field.csv:1:"), std::string::npos) << e;
    EXPECT_NE(e.find("expected a column 'sigma_um_per_rad'"), std::string::npos) << e;
}

TEST_F(BadReference, NonNumericValueIsNamedWithItsLine) {
    write_far_field(
        "case,polarisation,theta_i_deg,lambda_nm,resolution_px_per_um,theta_s_deg,"
        "sigma_um_per_rad\r\n"
        "single,TE,0,450,60,-179.5,220.7\r\n"
        "single,TE,0,450,60,-179.0,1.2x\r\n");
    const std::string e = error();
    EXPECT_NE(e.find("far_field.csv:3: column 'sigma_um_per_rad' = '1.2x': expected a finite "
                     "number"),
              std::string::npos)
        << e;
}

TEST_F(BadReference, ShortRowAndOffGridAngleAreNamedWithTheirLines) {
    write_far_field(
        "case,polarisation,theta_i_deg,lambda_nm,resolution_px_per_um,theta_s_deg,"
        "sigma_um_per_rad\r\n"
        "single,TE,0,450,60,-179.5\r\n");
    std::string e = error();
    EXPECT_NE(e.find("far_field.csv:2: expected 7 cells"), std::string::npos) << e;
    write_far_field(
        "case,polarisation,theta_i_deg,lambda_nm,resolution_px_per_um,theta_s_deg,"
        "sigma_um_per_rad\r\n"
        "single,TE,0,450,60,-179.5,220.7\r\n"
        "single,TE,0,450,60,-178.5,138.8\r\n");
    e = error();
    EXPECT_NE(e.find("far_field.csv:3: theta_s_deg = -178.5: expected -179"), std::string::npos)
        << e;
    // A short curve: named with its key.
    write_far_field(
        "case,polarisation,theta_i_deg,lambda_nm,resolution_px_per_um,theta_s_deg,"
        "sigma_um_per_rad\r\n"
        "single,TE,0,450,60,-179.5,220.7\r\n");
    e = error();
    EXPECT_NE(e.find("single TE θ_i = 0° λ = 450 nm has 1 points: expected 720"), std::string::npos)
        << e;
}

TEST_F(BadReference, UnknownCaseIsNamedWithItsLine) {
    write_far_field(
        "case,polarisation,theta_i_deg,lambda_nm,resolution_px_per_um,theta_s_deg,"
        "sigma_um_per_rad\r\n"
        "single,TE,0,450,60,-179.5,220.7\r\n"
        "large,TE,0,450,60,-179.5,220.7\r\n");
    const std::string e = error();
    EXPECT_NE(e.find("far_field.csv:3: case = 'large': expected single, small or row3"),
              std::string::npos)
        << e;
}

}  // namespace
}  // namespace plumage::sim::wave
