#include "studies/study_progress.h"

#include <omp.h>

#include <fstream>
#include <iostream>

#include <fmt/format.h>

#include "common/cpu_time.h"
#include "common/interrupt.h"
#include "studies/text_files.h"

namespace plumage::studies {

StudyProgress::StudyProgress(bool enabled)
    : enabled_(enabled),
      open_name_("reading the study file"),
      open_wall_(start_),
      open_cpu_(process_cpu_seconds()) {}

double StudyProgress::elapsed_s() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
}

void StudyProgress::say(const std::string& what) const {
    // Every stage starts here, so a Ctrl-C between stages stops the study before the next.
    throw_if_interrupted(what);
    done(what);
    const auto now = std::chrono::steady_clock::now();
    const double cpu = process_cpu_seconds();
    const std::lock_guard lock(mutex_);
    closed_.push_back(
        {open_name_, std::chrono::duration<double>(now - open_wall_).count(), cpu - open_cpu_});
    open_name_ = what;
    open_wall_ = now;
    open_cpu_ = cpu;
}

void StudyProgress::done(const std::string& what) const {
    if (enabled_) std::cerr << fmt::format("plumage: [{:6.1f} s] {}\n", elapsed_s(), what);
}

std::vector<StageTiming> StudyProgress::stages() const {
    const auto now = std::chrono::steady_clock::now();
    const double cpu = process_cpu_seconds();
    const std::lock_guard lock(mutex_);
    std::vector<StageTiming> out = closed_;
    out.push_back(
        {open_name_, std::chrono::duration<double>(now - open_wall_).count(), cpu - open_cpu_});
    return out;
}

namespace {

// CPU/wall, or "–" when the wall time is too short to divide by.
std::string cpu_per_wall(double cpu_s, double wall_s, std::string_view none) {
    return wall_s > 1e-9 ? fmt::format("{:.2f}", cpu_s / wall_s) : std::string(none);
}

// A stage name as one markdown table cell.
std::string markdown_cell(const std::string& text) {
    std::string out;
    for (const char c : text) {
        if (c == '|') out += '\\';
        out += c == '\n' || c == '\r' ? ' ' : c;
    }
    return out;
}

// A stage name as one CSV field (RFC 4180): quoted, quotes doubled, when it needs to be.
std::string csv_field(const std::string& text) {
    if (text.find_first_of(",\"\n\r") == std::string::npos) return text;
    std::string out = "\"";
    for (const char c : text) out += c == '"' ? std::string("\"\"") : std::string(1, c);
    return out + "\"";
}

}  // namespace

std::string stage_table(std::span<const StageTiming> stages) {
    const int threads = omp_get_max_threads();
    const std::string reading =
        threads == 1
            ? "so CPU/wall stays near 1 unless a library starts threads of its own (Embree builds "
              "its bounding-volume hierarchies on all cores); rerun with --threads N to see which "
              "stages use N threads"
            : fmt::format(
                  "so CPU/wall near 1 marks a serial stage and near {} a stage using every "
                  "thread",
                  threads);
    std::string out = fmt::format(
        "Each stage runs from its progress line on stderr to the next (the first from the start "
        "of the run, the last up to the moment this report was written), on {} OpenMP "
        "thread{}; CPU time counts every thread of plumage (not child processes such as the "
        "plotter), {}. The same figures are in `stages.csv`.\n\n",
        threads, threads == 1 ? "" : "s", reading);
    out += "| stage | wall (s) | CPU (s) | CPU/wall |\n|---|---|---|---|\n";
    double wall = 0.0, cpu = 0.0;
    for (const StageTiming& s : stages) {
        out += fmt::format("| {} | {:.2f} | {:.2f} | {} |\n", markdown_cell(s.name), s.wall_s,
                           s.cpu_s, cpu_per_wall(s.cpu_s, s.wall_s, "–"));
        wall += s.wall_s;
        cpu += s.cpu_s;
    }
    out += fmt::format("| **total** | **{:.2f}** | **{:.2f}** | **{}** |\n", wall, cpu,
                       cpu_per_wall(cpu, wall, "–"));
    return out;
}

void write_stages_csv(const std::filesystem::path& path, std::span<const StageTiming> stages) {
    std::ofstream csv(path);
    csv << "stage,wall time (s),cpu time (s),cpu/wall\n";
    for (const StageTiming& s : stages) {
        csv << fmt::format("{},{:.6f},{:.6f},{}\n", csv_field(s.name), s.wall_s, s.cpu_s,
                           s.wall_s > 1e-9 ? fmt::format("{:.4f}", s.cpu_s / s.wall_s) : "");
    }
    close_written(csv, path);
}

std::string run_time_by_stage(const StudyProgress& clock, const std::filesystem::path& dir) {
    const std::vector<StageTiming> stages = clock.stages();
    write_stages_csv(dir / "stages.csv", stages);
    return "## Run time by stage\n\n" + stage_table(stages) + "\n";
}

}  // namespace plumage::studies
