#include "studies/study.h"

#include <algorithm>
#include <vector>

#include <fmt/format.h>

#include "common/error.h"
#include "studies/study_file.h"

namespace plumage::studies {
namespace {

namespace fs = std::filesystem;

// The registry: one line per study. X(kind) takes kind_study_entry() from
// studies/<kind>_study.cpp (declared in study.h by the same list).
const std::vector<StudyEntry>& registry() {
#define PLUMAGE_STUDY_ENTRY(kind) kind##_study_entry(),
    static const std::vector<StudyEntry> entries{PLUMAGE_STUDIES(PLUMAGE_STUDY_ENTRY)};
#undef PLUMAGE_STUDY_ENTRY
    return entries;
}

}  // namespace

std::span<const StudyEntry> study_registry() { return registry(); }

const StudyEntry& study_of(const std::string& text, const fs::path& source) {
    auto file = StudyFile::parse(text, source);
    ParameterTable root = file->root();
    if (!root.has("study") && root.has("geometry")) {
        throw InputError(fmt::format(
            "{}: this is a geometry file (a [geometry] table and no `study` key): build it with "
            "`plumage geometry {}`",
            source.string(), source.string()));
    }
    std::vector<std::string> kinds;
    for (const StudyEntry& entry : registry()) kinds.emplace_back(entry.kind);
    const std::string kind =
        root.required_string("study", kinds, "which study this file describes");
    return *std::find_if(registry().begin(), registry().end(),
                         [&](const StudyEntry& e) { return e.kind == kind; });
}

void check_study(const std::string& text, const fs::path& source) {
    study_of(text, source).check(text, source);
}

void refuse_limits(std::string_view study, const RunLimits& limits, std::string_view why) {
    if (!limits.any()) return;
    throw InputError(fmt::format(
        "--time-budget and --target-error do not apply to the {} study: {} (Ctrl-C still stops "
        "it)",
        study, why));
}

}  // namespace plumage::studies
