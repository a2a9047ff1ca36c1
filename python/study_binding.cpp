// plumage._core.run_study_text: a study (any kind `plumage run` knows, studies/study.h) from its
// TOML text, with the command line's limits, thread count and plots, for
// python/plumage/studies.py. The GIL is released while the study runs (its progress lines go to
// stderr as on the command line). Ctrl-C: while it runs, SIGINT and SIGTERM are the study's
// (common/interrupt.h): the study stops at its next check, keeps its checkpoints, removes its
// staging folder, and Python receives KeyboardInterrupt with the study's message; Python's own
// handlers are back when the call returns.
#include <optional>
#include <string>

#include <fmt/format.h>
#include <omp.h>
#include <pybind11/stl.h>

#include "common/interrupt.h"
#include "python/binding_util.h"
#include "studies/geometry_study.h"
#include "studies/plots.h"
#include "studies/study.h"

namespace plumage::python {
namespace {

// Restores OpenMP's thread count on every exit path.
class ThreadCount {
public:
    explicit ThreadCount(std::optional<int> threads) : previous_(omp_get_max_threads()) {
        if (threads) omp_set_num_threads(*threads);
    }
    ~ThreadCount() { omp_set_num_threads(previous_); }
    ThreadCount(const ThreadCount&) = delete;
    ThreadCount& operator=(const ThreadCount&) = delete;

private:
    int previous_;
};

std::string run_study_text(const std::string& text, const std::string& source,
                           const std::string& results_root, std::optional<int> threads,
                           double time_budget_s, double target_relative_error, bool plots) {
    if (threads && (*threads < 1 || *threads > 4096))
        throw py::value_error("threads: expected a whole number from 1 to 4096");
    if (time_budget_s < 0.0) throw py::value_error("time_budget_s: expected a number >= 0");
    if (target_relative_error < 0.0 || target_relative_error >= 1.0)
        throw py::value_error("target_error: expected a relative error in [0, 1)");
    const studies::RunLimits limits{time_budget_s, target_relative_error};
    const std::filesystem::path source_path(source);
    // Checked (file:line, key and expectation) before the signal handlers change.
    const studies::StudyEntry& entry = studies::study_of(text, source_path);
    entry.check(text, source_path);
    py::gil_scoped_release release;
    const ThreadCount thread_count(threads);
    studies::set_plots_enabled(plots);
    const ScopedInterruptHandler interrupt;
    try {
        return entry.run(text, source_path, results_root, limits);
    } catch (const Interrupted&) {
        throw;
    } catch (const std::exception& e) {
        // What a stage threw once the signal had arrived is the interruption's doing (as on the
        // command line, studies/main.cpp).
        if (interrupt.signal_number() == 0) throw;
        throw Interrupted(fmt::format(
            "{} (interrupted: finished measurement passes stay in checkpoints; run the same "
            "study again to resume)",
            e.what()));
    }
}

py::dict build_geometry_text(const std::string& text, const std::string& source,
                             const std::string& results_root, std::optional<int> threads,
                             bool plots) {
    if (threads && (*threads < 1 || *threads > 4096))
        throw py::value_error("threads: expected a whole number from 1 to 4096");
    studies::GeometryStudyResult r;
    {
        py::gil_scoped_release release;
        const ThreadCount thread_count(threads);
        studies::set_plots_enabled(plots);
        const ScopedInterruptHandler interrupt;
        r = studies::run_geometry_study(text, std::filesystem::path(source), results_root);
    }
    py::dict result;
    result["output_dir"] = r.output_dir.string();
    result["kind"] = r.kind;
    result["triangles"] = r.triangles;
    result["instances"] = r.instances;
    result["memory_bytes"] = r.memory_bytes;
    result["wall_seconds"] = r.wall_seconds;
    return result;
}

}  // namespace

void bind_studies(py::module_& m) {
    m.def("build_geometry_text", &build_geometry_text, py::arg("text"), py::arg("source"),
          py::arg("results_root"), py::arg("threads"), py::arg("plots"));
    m.def("run_study_text", &run_study_text, py::arg("text"), py::arg("source"),
          py::arg("results_root"), py::arg("threads"), py::arg("time_budget_s"),
          py::arg("target_relative_error"), py::arg("plots"));
    m.def("study_kinds", [] {
        std::vector<std::string> kinds;
        for (const studies::StudyEntry& e : studies::study_registry()) kinds.emplace_back(e.kind);
        return kinds;
    });
}

}  // namespace plumage::python
