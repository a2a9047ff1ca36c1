// The StudyContext (studies/study_context.h): the file parsed once with its seed, the streams as
// derive_seed of that seed and nothing else, the command line's limits over the file's values,
// and the output folder: nothing on disk before out(), a foreign folder refused at begin(), a
// staging folder removed when the run does not commit, the result and no checkpoints after
// commit().
#include "studies/study_context.h"

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <optional>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "common/seed.h"
#include "tests/test_util.h"

namespace plumage::studies {
namespace {

namespace fs = std::filesystem;

const fs::path kSource = "context_test.toml";

fs::path fresh_root(const std::string& what) {
    const fs::path root =
        fs::temp_directory_path() / fmt::format("plumage_context_{}_{}", what, ::getpid());
    fs::remove_all(root);
    return root;
}

TEST(StudyContext, StreamsAreDerivedFromTheFilesSeedAndNothingElse) {
    const StudyContext ctx("study = \"masking\"\nseed = 42\n", kSource);
    EXPECT_EQ(ctx.seed(), 42u);
    EXPECT_EQ(ctx.stream("masking/section"), derive_seed(42, "masking/section", 0));
    EXPECT_EQ(ctx.stream("masking/patch", 7), derive_seed(42, "masking/patch", 7));
    EXPECT_NE(ctx.stream("masking/patch", 7), ctx.stream("masking/patch", 8));
    EXPECT_NE(ctx.stream("masking/patch", 0), ctx.stream("masking/section", 0));
    const StudyContext other("study = \"masking\"\nseed = 43\n", kSource);
    EXPECT_NE(other.stream("masking/section"), ctx.stream("masking/section"));
}

TEST(StudyContext, BadTomlAndABadSeedAreNamedBeforeAnything) {
    EXPECT_NE(testing::input_error_message([] {
                  StudyContext("seed = [", kSource);
              }).find("context_test.toml:1:"),
              std::string::npos);
    EXPECT_NE(testing::input_error_message([] {
                  StudyContext("seed = -1\n", kSource);
              }).find("context_test.toml:1:8: seed = -1"),
              std::string::npos);
}

TEST(StudyContext, CommandLineLimitsReplaceTheFilesValues) {
    const StudyContext none("seed = 1\n", kSource);
    EXPECT_EQ(none.time_budget_s(30.0), 30.0);
    EXPECT_EQ(none.target_relative_error(0.05), 0.05);
    const StudyContext given("seed = 1\n", kSource, {}, RunLimits{12.0, 0.01});
    EXPECT_EQ(given.time_budget_s(30.0), 12.0);
    EXPECT_EQ(given.target_relative_error(0.05), 0.01);
}

TEST(StudyContext, NothingIsWrittenBeforeOutAndAnUncommittedRunLeavesNothing) {
    const fs::path root = fresh_root("uncommitted");
    {
        StudyContext ctx("seed = 1\n", kSource, root);
        ctx.begin("run");
        EXPECT_FALSE(fs::exists(root / "run"));
        const fs::path out = ctx.out();
        EXPECT_TRUE(fs::is_directory(out));
        EXPECT_EQ(ctx.out(), out);  // one staging folder
        std::ofstream(out / "record.txt") << "half";
    }  // no commit: an error or Ctrl-C
    EXPECT_FALSE(fs::exists(root / "run"));
    if (fs::exists(root)) {
        for (const auto& e : fs::directory_iterator(root))
            EXPECT_EQ(e.path().filename().string().find("run.partial-"), std::string::npos)
                << e.path();
    }
    fs::remove_all(root);
}

TEST(StudyContext, CommitPlacesTheResultAndRemovesTheCheckpoints) {
    const fs::path root = fresh_root("commit");
    StudyContext ctx("seed = 1\n", kSource, root);
    ctx.begin("run");
    std::ofstream(ctx.out() / "report.md") << "# report\n";
    const fs::path checkpoints = ctx.checkpoints();
    std::ofstream(checkpoints / "brdf.checkpoint") << "passes";
    EXPECT_NE(ctx.run_time_by_stage().find("Run time by stage"), std::string::npos);
    const fs::path final_path = ctx.commit();
    EXPECT_EQ(final_path, root / "run");
    EXPECT_TRUE(fs::exists(root / "run" / "report.md"));
    EXPECT_TRUE(fs::exists(root / "run" / "stages.csv"));
    EXPECT_FALSE(fs::exists(checkpoints));
    fs::remove_all(root);
}

TEST(StudyContext, AFolderPlumageDidNotMakeIsRefusedAtBeginAndKept) {
    const fs::path root = fresh_root("foreign");
    fs::create_directories(root / "run");
    std::ofstream(root / "run" / "mine.txt") << "the user's";
    StudyContext ctx("seed = 1\n", kSource, root);
    EXPECT_THROW(ctx.begin("run"), InputError);
    EXPECT_TRUE(fs::exists(root / "run" / "mine.txt"));
    fs::remove_all(root);
}

}  // namespace
}  // namespace plumage::studies
