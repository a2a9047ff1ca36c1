// What every study's run is given and shares: the study file parsed once, the limits from the
// command line, the progress clock and the results root; then, once the study's read step has
// named it, its output folder (staged, committed at the end), its checkpoints and its random
// streams. A study's steps take the context instead of each carrying the text, the clock, the
// seed and the folders of their own.
//
// Randomness: stream(purpose, index) = derive_seed(seed, purpose, index) (common/seed.h) is the
// only way a study or the instruments it configures get random numbers; purposes are
// "<study>/<measurement>" (e.g. "rock_dove/brdf"), so that two measurements never share a stream
// and a study's numbers do not depend on the order its steps run in.
//
// Order of a run (studies/masking_study.cpp is the house example):
//   StudyContext ctx(text, source, results_root, limits, progress);   parse (file:line errors)
//   Settings s = read(ctx);                                           read; nothing written
//   ctx.begin(s.name);                       refuses a results folder plumage did not make
//   build …                                  (nothing is written before out())
//   ctx.out() / "record.h5" …                measure, compare, report into the staging folder
//   ctx.commit();                            the stage table, the commit, the checkpoints gone
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <string_view>

#include "studies/staged_directory.h"
#include "studies/study.h"
#include "studies/study_checkpoints.h"
#include "studies/study_file.h"
#include "studies/study_progress.h"

namespace plumage::studies {

class StudyContext {
public:
    // Parses `text` (InputError naming source:line:column when it is not TOML) and reads its
    // `seed` (studies/sections.h); writes nothing.
    StudyContext(std::string text, std::filesystem::path source,
                 std::filesystem::path results_root = {}, RunLimits limits = {},
                 bool progress = false);
    StudyContext(const StudyContext&) = delete;
    StudyContext& operator=(const StudyContext&) = delete;

    const std::string& text() const { return text_; }
    const std::filesystem::path& source() const { return source_; }
    StudyFile& file() { return *file_; }
    ParameterTable root() { return file_->root(); }
    const RunLimits& limits() const { return limits_; }
    bool progress() const { return progress_; }
    const StudyProgress& clock() const { return clock_; }
    const std::filesystem::path& results_root() const { return results_root_; }

    // A value from the study file, replaced by the command line's limit when one was given.
    double time_budget_s(double from_file) const;
    double target_relative_error(double from_file) const;

    // After the read step: the study's name (its output folder, results_root/name). Refuses
    // (InputError) a results folder plumage did not make, before any work.
    void begin(const std::string& name);
    const std::string& name() const { return name_; }
    // The user's `seed`, for the records' provenance; randomness comes from stream().
    std::uint64_t seed() const { return seed_; }

    // The stream of one purpose: derive_seed(seed, purpose, index). Available from the
    // construction on, so that a read step can configure its instruments.
    std::uint64_t stream(std::string_view purpose, std::uint64_t index = 0) const;

    // <results root>/.checkpoints/<name>/ (checkpoint_folder: created, held in use).
    std::filesystem::path checkpoints() const;

    // The staging folder, created at the first call: a run stopped before it leaves nothing
    // behind. Removed unless committed.
    const std::filesystem::path& out();
    // The final folder (results_root/name), valid before and after the commit.
    std::filesystem::path final_path() const { return results_root_ / name_; }

    // The report section "## Run time by stage" (and stages.csv in the staging folder).
    std::string run_time_by_stage();
    // Commits the staging folder, removes the study's checkpoints (the records supersede them)
    // and prints the done line naming `report`; returns the final folder.
    std::filesystem::path commit(const std::string& report = "report.md");

private:
    std::string text_;
    std::filesystem::path source_, results_root_;
    RunLimits limits_;
    bool progress_;
    StudyProgress clock_;
    std::shared_ptr<StudyFile> file_;
    std::string name_;
    std::uint64_t seed_ = 0;
    bool begun_ = false;
    std::optional<StagedDirectory> out_;
};

}  // namespace plumage::studies
