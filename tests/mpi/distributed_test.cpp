// common/distributed.h in one process (no launcher): the dealer is a loop over the chunks in
// order, with per-chunk checkpoints and the interrupt. The multi-rank behaviour is tested
// through mpirun (tests/mpi/records_across_ranks.sh, kill_rank_resume.py).
#include "common/distributed.h"

#include <gtest/gtest.h>

#include "common/error.h"

#include <atomic>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <vector>

namespace plumage::distributed {
namespace {

namespace fs = std::filesystem;

Bytes square(std::size_t i) {
    Bytes b;
    b.put(static_cast<double>(i * i));
    b.put_string("chunk " + std::to_string(i));
    b.put_vector(std::vector<int>(i, 7));
    return b;
}

// square(), noting which chunks ran.
std::function<Bytes(std::size_t)> logging_square(std::vector<std::size_t>& ran) {
    return [&ran](std::size_t i) {
        ran.push_back(i);
        return square(i);
    };
}

void expect_squares(ChunkResults& r, std::size_t n) {
    ASSERT_EQ(r.results.size(), n);
    for (std::size_t i = 0; i < n; ++i) {
        EXPECT_EQ(r.results[i].get<double>(), static_cast<double>(i * i));
        EXPECT_EQ(r.results[i].get_string(), "chunk " + std::to_string(i));
        EXPECT_EQ(r.results[i].get_vector<int>(), std::vector<int>(i, 7));
    }
}

class DistributedAlone : public ::testing::Test {
protected:
    void SetUp() override {
        dir = fs::temp_directory_path() /
              ("plumage_distributed_" +
               std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
        fs::remove_all(dir);
    }
    void TearDown() override { fs::remove_all(dir); }
    fs::path dir;
};

// PLUMAGE_CHUNK_LOG naming a file that cannot be opened: one warning naming it, however many
// calls, and the work goes on. In a fresh process: the log is opened once per process.
TEST(DistributedChunkLog, AnUnopenableLogIsNamedOnceAndTheWorkGoesOn) {
    GTEST_FLAG_SET(death_test_style, "threadsafe");
    EXPECT_EXIT(
        {
            ::setenv("PLUMAGE_CHUNK_LOG", "/nonexistent-plumage-folder/chunks.csv", 1);
            const std::size_t first = deal_chunks(3, square).results.size();
            const std::size_t second = deal_chunks(3, square).results.size();
            std::exit(first == 3 && second == 3 ? 0 : 1);
        },
        ::testing::ExitedWithCode(0),
        "^plumage: warning: PLUMAGE_CHUNK_LOG: cannot open "
        "'/nonexistent-plumage-folder/chunks\\.csv' \\(No such file or directory\\); no chunk "
        "log is written\n$");
}

TEST_F(DistributedAlone, RunsEveryChunkOnceInOrder) {
    ASSERT_FALSE(active());
    EXPECT_EQ(rank(), 0);
    EXPECT_EQ(size(), 1);
    std::vector<std::size_t> order;
    auto r = deal_chunks(6, [&](std::size_t i) {
        order.push_back(i);
        return square(i);
    });
    EXPECT_EQ(order, (std::vector<std::size_t>{0, 1, 2, 3, 4, 5}));
    EXPECT_FALSE(r.interrupted);
    EXPECT_EQ(r.resumed, 0u);
    expect_squares(r, 6);
}

TEST_F(DistributedAlone, ResumesFinishedChunksFromCheckpoints) {
    ChunkOptions options;
    options.checkpoint_dir = dir;
    options.checkpoint_key = "study text";
    std::atomic<bool> stop{false};
    options.interrupt = &stop;
    // First run: interrupted after three chunks (as a Ctrl-C between chunks would).
    int ran = 0;
    auto first = deal_chunks(
        6,
        [&](std::size_t i) {
            if (++ran == 3) stop = true;
            return square(i);
        },
        options);
    EXPECT_TRUE(first.interrupted);
    EXPECT_TRUE(first.results.empty());
    // Rerun: only the three others run; the results equal an uninterrupted run's.
    stop = false;
    std::vector<std::size_t> rerun;
    auto second = deal_chunks(6, logging_square(rerun), options);
    EXPECT_EQ(second.resumed, 3u);
    EXPECT_EQ(rerun, (std::vector<std::size_t>{3, 4, 5}));
    expect_squares(second, 6);
}

TEST_F(DistributedAlone, IgnoresCheckpointsOfAnotherKeyOrCutShort) {
    ChunkOptions options;
    options.checkpoint_dir = dir;
    options.checkpoint_key = "one study";
    deal_chunks(4, square, options);
    // A chunk file cut short (as a crash inside a write would, were it not renamed into place).
    const fs::path two = dir / "chunk-000002.bin";
    fs::resize_file(two, fs::file_size(two) - 1);
    std::vector<std::size_t> rerun;
    auto again = deal_chunks(4, logging_square(rerun), options);
    EXPECT_EQ(rerun, (std::vector<std::size_t>{2}));
    expect_squares(again, 4);
    // ... and said why, so the caller can tell the user (not skipped in silence)
    EXPECT_EQ(again.not_resumed, (std::map<std::string, std::size_t>{{"damaged (cut short)", 1}}));
    // Another key (a changed study), or another chunk count: nothing is resumed, and why.
    options.checkpoint_key = "another study";
    const ChunkResults other_key = deal_chunks(4, square, options);
    EXPECT_EQ(other_key.resumed, 0u);
    EXPECT_EQ(other_key.not_resumed,
              (std::map<std::string, std::size_t>{
                  {"made by another run (a different build, study or limits)", 4}}));
    options.checkpoint_key = "another study";
    const ChunkResults other_count = deal_chunks(5, square, options);
    EXPECT_EQ(other_count.resumed, 0u);
    EXPECT_EQ(other_count.not_resumed,
              (std::map<std::string, std::size_t>{{"made for another number of chunks", 4}}));
    // No temporary file is left beside the checkpoints.
    for (const auto& entry : fs::directory_iterator(dir))
        EXPECT_EQ(entry.path().extension(), ".bin") << entry.path();
}

TEST_F(DistributedAlone, BroadcastsAreTheIdentityAlone) {
    EXPECT_TRUE(broadcast_flag(true));
    EXPECT_FALSE(broadcast_flag(false));
    auto b = broadcast_bytes(square(3));
    EXPECT_EQ(b.get<double>(), 9.0);
}

TEST_F(DistributedAlone, ReadingPastTheEndIsAnError) {
    Bytes b;
    b.put(1.0);
    b.get<double>();
    EXPECT_THROW(b.get<double>(), Error);
}

}  // namespace
}  // namespace plumage::distributed
