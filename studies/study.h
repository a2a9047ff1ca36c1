// The studies `plumage run` knows, by the value of a study file's `study` key.
//
// Each entry reads and checks a study file (check: every key, range and cross-key rule, with
// file:line:column; nothing built, measured or written) and runs it (read → build → measure →
// compare → report into <results root>/<name>/). A new study is one file plus one line in
// PLUMAGE_STUDIES below.
#pragma once

#include <filesystem>
#include <span>
#include <string>
#include <string_view>

namespace plumage::studies {

// Limits from the command line (--time-budget, --target-error); when set they override the
// study file's, for each progressive measurement of the study. Ctrl-C (SIGINT/SIGTERM) is
// handled process-wide (common/interrupt.h): every study stops at its next check, removes its
// staging folder and keeps its checkpoints.
struct RunLimits {
    double time_budget_s = 0.0;          // 0: the study file's (default: none)
    double target_relative_error = 0.0;  // 0: the study file's (default: none)
    bool any() const { return time_budget_s > 0.0 || target_relative_error > 0.0; }
};

struct StudyEntry {
    std::string_view kind;         // the `study` key's value
    std::string_view description;  // one line, for --help
    // InputError on bad input; nothing is written.
    void (*check)(const std::string& text, const std::filesystem::path& source);
    // Runs the study; returns the summary printed on stdout.
    std::string (*run)(const std::string& text, const std::filesystem::path& source,
                       const std::filesystem::path& results_root, const RunLimits& limits);
};

// The studies `plumage run` knows: one line each. A new study is studies/<kind>_study.cpp
// defining `StudyEntry <kind>_study_entry()`, plus its line here.
#define PLUMAGE_STUDIES(X) \
    X(rock_dove)           \
    X(ablation)            \
    X(extremes)            \
    X(species)             \
    X(masking)             \
    X(calibration)         \
    X(spongy)              \
    X(wave_validity)       \
    X(measure)

#define PLUMAGE_DECLARE_STUDY_ENTRY(kind) StudyEntry kind##_study_entry();
PLUMAGE_STUDIES(PLUMAGE_DECLARE_STUDY_ENTRY)
#undef PLUMAGE_DECLARE_STUDY_ENTRY

std::span<const StudyEntry> study_registry();

// The entry named by the file's `study` key; InputError naming the key's line and the known
// kinds (or, for a geometry file, saying to use `plumage geometry`).
const StudyEntry& study_of(const std::string& text, const std::filesystem::path& source);

// Reads and checks a study file exactly as `plumage run` does before any work.
void check_study(const std::string& text, const std::filesystem::path& source);

// InputError when a study without progressive measurements is given --time-budget or
// --target-error (they would otherwise be silently ignored).
void refuse_limits(std::string_view study, const RunLimits& limits, std::string_view why);

}  // namespace plumage::studies
