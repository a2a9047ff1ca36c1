// The pass loop's checkpoints (virtual_gonio/pass_checkpoint.h) on the two instruments that
// gained them with it: a scatterogram and a detector-side BTF interrupted after pass 2 of 4
// keep their completed passes, and the same command resumes them to the bits of a run that was
// never interrupted; a changed study text starts afresh and says why.
#include <unistd.h>

#include <csignal>
#include <filesystem>
#include <string>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "analysis/models/lambertian.h"
#include "common/constants.h"
#include "common/interrupt.h"
#include "sim/tracer.h"
#include "tests/sim/sim_test_util.h"
#include "virtual_gonio/btf.h"
#include "virtual_gonio/scatterometer.h"

namespace plumage::gonio {
namespace {

namespace fs = std::filesystem;

class PassCheckpoint : public ::testing::Test {
protected:
    void SetUp() override {
        dir_ = fs::temp_directory_path() /
               fmt::format("plumage_pass_checkpoint_{}_{}", ::getpid(),
                           ::testing::UnitTest::GetInstance()->current_test_info()->name());
        fs::remove_all(dir_);
        fs::create_directories(dir_);
    }
    void TearDown() override { fs::remove_all(dir_); }

    // A run control checkpointed in `file`, interrupted after `passes` passes (0: never); its
    // progress lines on stderr.
    RunControl control(const ScopedInterruptHandler& handler, const fs::path& file,
                       int passes) const {
        RunControl c;
        c.interrupt = &handler.flag();
        c.checkpoint = file;
        c.progress = true;
        if (passes > 0) {
            c.on_pass = [passes](const ConvergenceRow& row) {
                if (row.pass == passes) std::raise(SIGINT);
            };
        }
        return c;
    }

    fs::path dir_;
};

ScatterometerConfig small_scatterogram() {
    ScatterometerConfig c;
    c.image_size = 21;
    c.wavelengths_nm = {450.0, 650.0};
    c.quanta_per_pass = 4000;
    c.max_passes = 4;
    c.beam_radius_um = 5.0;
    c.config_text = "study = \"measure\"\n";
    return c;
}

TEST_F(PassCheckpoint, AnInterruptedScatterogramResumesToTheSameBits) {
    const analysis::LambertianScatterer plate(0.6);
    const ScatterometerConfig c = small_scatterogram();
    const Scatterogram whole = measure_scatterogram(plate, c);
    const fs::path file = dir_ / "scatterogram.checkpoint";
    {
        const ScopedInterruptHandler handler;
        ::testing::internal::CaptureStderr();
        EXPECT_THROW(measure_scatterogram(plate, c, control(handler, file, 2)), Interrupted);
        ::testing::internal::GetCapturedStderr();
    }
    ASSERT_TRUE(fs::exists(file));
    const ScopedInterruptHandler handler;
    ::testing::internal::CaptureStderr();
    const Scatterogram resumed = measure_scatterogram(plate, c, control(handler, file, 0));
    const std::string said = ::testing::internal::GetCapturedStderr();
    EXPECT_NE(said.find("resuming after 2 completed passes"), std::string::npos) << said;
    EXPECT_EQ(resumed.passes, 4);
    EXPECT_EQ(resumed.convergence.size(), 4u);
    EXPECT_EQ(resumed.intensity, whole.intensity);
    EXPECT_EQ(resumed.standard_error, whole.standard_error);
    EXPECT_EQ(resumed.transmitted, whole.transmitted);

    // Another study text: not resumed, said in one line, and a fresh run's bits.
    ScatterometerConfig changed = c;
    changed.config_text += "# edited\n";
    ::testing::internal::CaptureStderr();
    const Scatterogram fresh = measure_scatterogram(plate, changed, control(handler, file, 0));
    const std::string why = ::testing::internal::GetCapturedStderr();
    EXPECT_NE(why.find("not resuming " + file.string() + ": the study file changed"),
              std::string::npos)
        << why;
    EXPECT_EQ(fresh.intensity, whole.intensity);
}

TEST_F(PassCheckpoint, AnInterruptedDetectorBtfResumesToTheSameBits) {
    const sim::ExplicitScatterer plate(sim::single_mesh_scene(
        testing::square_mesh(200.0), sim::diffuse_layer(sim::constant_albedo(0.6)), "plate"));
    BtfConfig c;
    c.pairs = {{direction_from_angles(40.0 * kDeg, kPi), direction_from_angles(30.0 * kDeg, 0.0)}};
    c.wavelengths_nm = {450.0, 650.0};
    c.patch_size_um = 40.0;
    c.pixels = 6;
    c.aperture = Aperture::both_cones;
    c.estimator = BtfEstimator::detector;
    c.quanta_per_pixel = 100;
    c.max_passes = 4;
    c.config_text = "study = \"species\"\n";
    const BtfRecord whole = measure_btf(plate, c);
    const fs::path file = dir_ / "btf.checkpoint";
    {
        const ScopedInterruptHandler handler;
        ::testing::internal::CaptureStderr();
        EXPECT_THROW(measure_btf(plate, c, control(handler, file, 2)), Interrupted);
        ::testing::internal::GetCapturedStderr();
    }
    ASSERT_TRUE(fs::exists(file));
    const ScopedInterruptHandler handler;
    ::testing::internal::CaptureStderr();
    const BtfRecord resumed = measure_btf(plate, c, control(handler, file, 0));
    const std::string said = ::testing::internal::GetCapturedStderr();
    EXPECT_NE(said.find("resuming after 2 completed passes"), std::string::npos) << said;
    EXPECT_EQ(resumed.convergence.size(), 4u);
    EXPECT_EQ(resumed.value, whole.value);
    EXPECT_EQ(resumed.standard_error, whole.standard_error);
}

}  // namespace
}  // namespace plumage::gonio
