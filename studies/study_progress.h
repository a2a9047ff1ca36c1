// A study's clock: progress lines on stderr and the wall and CPU time of every stage, as the
// reports' "Run time by stage" section and stages.csv print them.
#pragma once

#include <chrono>
#include <filesystem>
#include <mutex>
#include <span>
#include <string>
#include <vector>

namespace plumage::studies {

// One stage of a study: from the say() that named it to the next say() (or, for the stage still
// open, to now). CPU time is the process's, all threads (common/cpu_time.h), so cpu_s / wall_s
// is the number of threads the stage kept busy on average.
struct StageTiming {
    std::string name;
    double wall_s;
    double cpu_s;
};

// A study's wall clock and its progress lines on stderr, "plumage: [  12.3 s] what", and the
// wall and CPU time of each stage. The first stage, "reading the study file", opens at
// construction (the studies construct their clock first), so the stages add up to the run.
class StudyProgress {
public:
    explicit StudyProgress(bool enabled);
    double elapsed_s() const;
    // Starts a stage: throws Interrupted if Ctrl-C arrived, then prints (when enabled), closes
    // the open stage and opens one named `what`.
    void say(const std::string& what) const;
    // Prints without the interrupt check: a result line, or the last line once committed. Opens
    // no stage.
    void done(const std::string& what) const;
    // The stages so far, in order; the open one measured up to now.
    std::vector<StageTiming> stages() const;

private:
    std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
    bool enabled_;
    // Stage accounting is bookkeeping beside the run, not its state: the studies hand their
    // steps the clock by const reference and say() is const, so these are mutable. The mutex
    // keeps them whole should a say() ever come from a worker thread.
    mutable std::mutex mutex_;
    mutable std::vector<StageTiming> closed_;
    mutable std::string open_name_;
    mutable std::chrono::steady_clock::time_point open_wall_;
    mutable double open_cpu_ = 0.0;
};

// The stages as a markdown table, "| stage | wall (s) | CPU (s) | CPU/wall |" with a total row,
// after one sentence giving the OpenMP thread count and how to read CPU/wall.
std::string stage_table(std::span<const StageTiming> stages);

// The same figures as CSV: stage,wall time (s),cpu time (s),cpu/wall (names quoted as needed).
// IoError if the file cannot be written.
void write_stages_csv(const std::filesystem::path& path, std::span<const StageTiming> stages);

// The report section "## Run time by stage" (stage_table of the clock's stages now), with the
// same figures written to <dir>/stages.csv.
std::string run_time_by_stage(const StudyProgress& clock, const std::filesystem::path& dir);

}  // namespace plumage::studies
