// Issue 43, case 2: a goniometer checkpoint is resumed only when it was made from the same
// things as the run (goniometer.h, "Checkpoints"). A checkpoint of changed input, of a changed
// study, or one that is damaged, used to be resumed into a mixed record or to stop the run
// ("belongs to a different measurement ... remove it"); now the run starts afresh, says why in
// one line, and measures what a fresh run measures, bit for bit.
#include <unistd.h>

#include <csignal>
#include <filesystem>
#include <fstream>
#include <string>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "analysis/models/lambertian.h"
#include "common/constants.h"
#include "common/interrupt.h"
#include "tests/test_util.h"
#include "virtual_gonio/direction_sets.h"
#include "virtual_gonio/goniometer.h"

namespace plumage::gonio {
namespace {

namespace fs = std::filesystem;

class CheckpointIdentity : public ::testing::Test {
protected:
    void SetUp() override {
        dir_ = fs::temp_directory_path() /
               fmt::format("plumage_checkpoint_{}_{}", ::getpid(),
                           ::testing::UnitTest::GetInstance()->current_test_info()->name());
        fs::remove_all(dir_);
        fs::create_directories(dir_);
        config_.pairs = filip2024_in_plane_pairs();
        config_.detector_half_angle_rad = 10.0 * kPi / 180.0;
        config_.estimator = Estimator::photon;
        config_.quanta_per_pass = 3000;
        config_.max_passes = 4;
        config_.config_text = "study = \"measure\"\n[sample]\nfile = \"plate.obj\"\n";
    }
    void TearDown() override { fs::remove_all(dir_); }

    // A run checkpointed in checkpoint(), interrupted after `passes` passes (0: not at all),
    // with `input` as the sample file's content hash; its stderr in `said`.
    BrdfRecord run(const analysis::LambertianScatterer& plate, const std::string& input,
                   int passes = 0, std::string* said = nullptr) const {
        const ScopedInterruptHandler handler;
        RunControl control;
        control.interrupt = &handler.flag();
        control.checkpoint = checkpoint();
        control.checkpoint_inputs = {{"the content of the sample file 'plate.obj'", input}};
        if (passes > 0) {
            control.on_pass = [passes](const ConvergenceRow& row) {
                if (row.pass == passes) std::raise(SIGINT);
            };
        }
        ::testing::internal::CaptureStderr();
        BrdfRecord r = measure_brdf(plate, config_, control);
        const std::string text = ::testing::internal::GetCapturedStderr();
        if (said != nullptr) *said = text;
        return r;
    }
    fs::path checkpoint() const { return dir_ / "brdf.checkpoint"; }

    fs::path dir_;
    GoniometerConfig config_;
};

TEST_F(CheckpointIdentity, AChangedInputFileStartsAfreshAndEqualsAFreshRun) {
    const analysis::LambertianScatterer before(0.6), after(0.2);  // the file's two contents
    const BrdfRecord interrupted = run(before, "hash-before", 2);
    ASSERT_TRUE(interrupted.interrupted);
    ASSERT_TRUE(fs::exists(checkpoint()));
    const BrdfRecord fresh = measure_brdf(after, config_);
    std::string said;
    const BrdfRecord rerun = run(after, "hash-after", 0, &said);
    EXPECT_EQ(said, fmt::format("plumage: not resuming {}: the content of the sample file "
                                "'plate.obj' changed; starting afresh (this run's first pass "
                                "replaces it)\n",
                                checkpoint().string()));
    EXPECT_EQ(rerun.passes, 4);
    EXPECT_EQ(rerun.convergence.size(), 4u);
    EXPECT_EQ(rerun.value, fresh.value);  // bit for bit: nothing of the old content mixed in
    EXPECT_EQ(rerun.standard_error, fresh.standard_error);
    // And its own checkpoint, made from the new content, resumes without a word.
    std::string quiet;
    run(after, "hash-after", 0, &quiet);
    EXPECT_EQ(quiet, "");
}

TEST_F(CheckpointIdentity, TheSameInputResumesToTheSameBits) {
    const analysis::LambertianScatterer plate(0.6);
    const BrdfRecord uninterrupted = measure_brdf(plate, config_);
    ASSERT_TRUE(run(plate, "hash", 1).interrupted);
    std::string said;
    const BrdfRecord resumed = run(plate, "hash", 0, &said);
    EXPECT_EQ(said, "");
    EXPECT_EQ(resumed.value, uninterrupted.value);
    EXPECT_EQ(resumed.standard_error, uninterrupted.standard_error);
}

TEST_F(CheckpointIdentity, ADamagedCheckpointDoesNotBlockTheRun) {
    const analysis::LambertianScatterer plate(0.6);
    const BrdfRecord fresh = measure_brdf(plate, config_);
    ASSERT_TRUE(run(plate, "hash", 2).interrupted);
    const std::string whole = testing::read_text_file(checkpoint());
    const std::vector<std::pair<std::string, std::string>> damages = {
        {"empty", ""},
        {"truncated", whole.substr(0, whole.size() / 2)},
        {"garbage", std::string(4096, '\x5a')},
        {"not HDF5", "plumage checkpoint\n"}};
    for (const auto& [damage, content] : damages) {
        std::ofstream(checkpoint(), std::ios::binary | std::ios::trunc) << content;
        std::string said;
        BrdfRecord r;
        EXPECT_NO_THROW(r = run(plate, "hash", 0, &said)) << damage;
        EXPECT_NE(said.find(fmt::format("plumage: not resuming {}: it cannot be read",
                                        checkpoint().string())),
                  std::string::npos)
            << damage << ": " << said;
        EXPECT_EQ(r.value, fresh.value) << damage;
        EXPECT_EQ(std::count(said.begin(), said.end(), '\n'), 1) << damage << ": " << said;
    }
}

TEST_F(CheckpointIdentity, AStaleCheckpointIsReplacedOnlyByAFirstPass) {
    const analysis::LambertianScatterer plate(0.6);
    ASSERT_TRUE(run(plate, "old", 2).interrupted);
    const std::string stale = testing::read_text_file(checkpoint());
    // Stopped before its first pass: nothing to keep, so the old checkpoint stays as it was.
    {
        const std::atomic<bool> stop{true};
        RunControl control;
        control.interrupt = &stop;
        control.checkpoint = checkpoint();
        control.checkpoint_inputs = {{"the content of the sample file 'plate.obj'", "new"}};
        ::testing::internal::CaptureStderr();
        EXPECT_EQ(measure_brdf(plate, config_, control).passes, 0);
        ::testing::internal::GetCapturedStderr();
        EXPECT_EQ(testing::read_text_file(checkpoint()), stale);
    }
    // After one pass the new run's checkpoint has replaced it.
    ASSERT_TRUE(run(plate, "new", 1).interrupted);
    EXPECT_NE(testing::read_text_file(checkpoint()), stale);
    std::string said;
    run(plate, "new", 0, &said);
    EXPECT_EQ(said, "");
}

TEST(CheckpointDifferences, NameWhatChanged) {
    const std::vector<CheckpointPart> then = {{"the build", "plumage 1, git a"},
                                              {"the study file", "1"},
                                              {"the content of the sample file 'a.obj'", "x"}};
    EXPECT_EQ(checkpoint_differences(then, then), "");
    std::vector<CheckpointPart> now = then;
    now[0].value = "plumage 1, git b";
    now[2] = {"the content of the sample file 'b.obj'", "x"};
    EXPECT_EQ(checkpoint_differences(then, now),
              "the build changed (from plumage 1, git a to plumage 1, git b); the content of the "
              "sample file 'b.obj' is new; the content of the sample file 'a.obj' is no longer "
              "an input");
    EXPECT_NE(checkpoint_build().find(fmt::format("git ")), std::string::npos);
}

}  // namespace
}  // namespace plumage::gonio
