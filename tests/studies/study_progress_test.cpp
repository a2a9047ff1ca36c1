// StudyProgress's stage accounting (studies/study_progress.h): every say() closes the open stage
// and opens the next, with wall and process CPU time; a stage that keeps two threads busy shows
// CPU/wall near 2; the report table and stages.csv render the same figures.
#include <omp.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <ctime>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "common/cpu_time.h"
#include "studies/study_progress.h"
#include "tests/test_util.h"

namespace plumage::studies {
namespace {

namespace fs = std::filesystem;

// The CPU time of the calling thread alone.
double thread_cpu_seconds() {
    timespec t{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
    return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

// Spins until the calling thread has used `seconds` of CPU.
void spin(double seconds) {
    const double until = thread_cpu_seconds() + seconds;
    volatile double sink = 0.0;
    while (thread_cpu_seconds() < until) {
        for (int i = 0; i < 10000; ++i) sink = sink + 1e-9 * i;
    }
}

TEST(StudyProgress, RecordsStagesInOrderWithWallAndCpuTime) {
    const StudyProgress clock(false);
    clock.say("first");
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    clock.done("a result line opens no stage");
    clock.say("second, with \"quotes\"");
    spin(0.05);
    const std::vector<StageTiming> stages = clock.stages();
    ASSERT_EQ(stages.size(), 3u);
    EXPECT_EQ(stages[0].name, "reading the study file");
    EXPECT_EQ(stages[1].name, "first");
    EXPECT_EQ(stages[2].name, "second, with \"quotes\"");
    double wall = 0.0;
    for (const StageTiming& s : stages) {
        EXPECT_GE(s.wall_s, 0.0) << s.name;
        EXPECT_GE(s.cpu_s, 0.0) << s.name;
        wall += s.wall_s;
    }
    EXPECT_GE(stages[1].wall_s, 0.015);  // the sleep: wall time
    EXPECT_GE(stages[2].cpu_s, 0.045);   // the spin: CPU time
    // The stages cover the run: their wall times add up to the clock's elapsed time.
    EXPECT_NEAR(wall, clock.elapsed_s(), 0.01);
    // The open stage is measured up to now: it grows.
    spin(0.02);
    EXPECT_GT(clock.stages().back().cpu_s, stages[2].cpu_s);
}

TEST(StudyProgress, AStageOnTwoThreadsShowsCpuOverWallAboveOne) {
    if (omp_get_max_threads() < 2 || std::thread::hardware_concurrency() < 2) {
        GTEST_SKIP() << "needs 2 OpenMP threads on 2 cores (has " << omp_get_max_threads()
                     << " threads, " << std::thread::hardware_concurrency() << " cores)";
    }
    // Each thread spins 0.3 s of its own CPU time, so the stage holds 0.6 s of CPU whatever the
    // load. CPU/wall near 2 needs both threads to run side by side, which another process busy
    // on one of the two cores prevents: up to three attempts, and a skip if none overlapped
    // (judged by the region's own wall time, not by the clock under test).
    bool overlapped = false;
    for (int attempt = 0; attempt < 3 && !overlapped; ++attempt) {
        const StudyProgress clock(false);
        clock.say("busy on two threads");
        const auto began = std::chrono::steady_clock::now();
#pragma omp parallel num_threads(2)
        spin(0.3);
        const double region_s =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - began).count();
        clock.say("after");
        const StageTiming busy = clock.stages()[1];
        ASSERT_EQ(busy.name, "busy on two threads");
        EXPECT_GE(busy.cpu_s, 0.59);  // both threads' CPU time, not the calling thread's alone
        EXPECT_GE(busy.wall_s, region_s);
        overlapped = 0.6 / region_s > 1.4;
        if (overlapped) {
            EXPECT_GT(busy.cpu_s / busy.wall_s, 1.3) << busy.wall_s;
        }
    }
    if (!overlapped) GTEST_SKIP() << "the two threads never ran side by side (a busy machine)";
}

TEST(StudyProgress, TableAndCsvShowTheSameFigures) {
    const std::vector<StageTiming> stages = {{"reading the study file", 0.5, 0.5},
                                             {"measuring | on, \"both\" threads", 2.0, 3.5}};
    const std::string table = stage_table(stages);
    EXPECT_NE(table.find(std::to_string(omp_get_max_threads()) + " OpenMP thread"),
              std::string::npos)
        << table;
    EXPECT_NE(table.find(omp_get_max_threads() > 1 ? "near 1 marks a serial stage"
                                                   : "rerun with --threads N"),
              std::string::npos)
        << table;
    EXPECT_NE(table.find("| stage | wall (s) | CPU (s) | CPU/wall |\n|---|---|---|---|\n"),
              std::string::npos)
        << table;
    EXPECT_NE(table.find("| reading the study file | 0.50 | 0.50 | 1.00 |\n"), std::string::npos)
        << table;
    EXPECT_NE(table.find("| measuring \\| on, \"both\" threads | 2.00 | 3.50 | 1.75 |\n"),
              std::string::npos)
        << table;
    EXPECT_NE(table.find("| **total** | **2.50** | **4.00** | **1.60** |\n"), std::string::npos)
        << table;

    const fs::path csv =
        fs::temp_directory_path() / ("plumage_stages_" + std::to_string(::getpid()) + ".csv");
    write_stages_csv(csv, stages);
    EXPECT_EQ(testing::read_text_file(csv),
              "stage,wall time (s),cpu time (s),cpu/wall\n"
              "reading the study file,0.500000,0.500000,1.0000\n"
              "\"measuring | on, \"\"both\"\" threads\",2.000000,3.500000,1.7500\n");
    fs::remove(csv);
}

TEST(StudyProgress, ProcessCpuSecondsGrowsWithWork) {
    const double before = process_cpu_seconds();
    spin(0.02);
    EXPECT_GE(process_cpu_seconds() - before, 0.019);
}

}  // namespace
}  // namespace plumage::studies
