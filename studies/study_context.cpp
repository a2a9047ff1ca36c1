#include "studies/study_context.h"

#include "common/error.h"
#include "common/seed.h"
#include "studies/sections.h"

namespace plumage::studies {

namespace fs = std::filesystem;

StudyContext::StudyContext(std::string text, fs::path source, fs::path results_root,
                           RunLimits limits, bool progress)
    : text_(std::move(text)),
      source_(std::move(source)),
      results_root_(std::move(results_root)),
      limits_(limits),
      progress_(progress),
      clock_(progress),
      file_(StudyFile::parse(text_, source_)) {
    ParameterTable root = file_->root();
    seed_ = read_seed(root);
}

double StudyContext::time_budget_s(double from_file) const {
    return limits_.time_budget_s > 0.0 ? limits_.time_budget_s : from_file;
}

double StudyContext::target_relative_error(double from_file) const {
    return limits_.target_relative_error > 0.0 ? limits_.target_relative_error : from_file;
}

void StudyContext::begin(const std::string& name) {
    PLUMAGE_CHECK(!begun_, "StudyContext::begin called twice");
    name_ = name;
    begun_ = true;
    StagedDirectory::prepare(final_path());
}

std::uint64_t StudyContext::stream(std::string_view purpose, std::uint64_t index) const {
    return derive_seed(seed_, purpose, index);
}

fs::path StudyContext::checkpoints() const {
    PLUMAGE_CHECK(begun_, "StudyContext::checkpoints before begin()");
    return checkpoint_folder(results_root_, name_);
}

const fs::path& StudyContext::out() {
    PLUMAGE_CHECK(begun_, "StudyContext::out before begin()");
    if (!out_) out_.emplace(final_path());
    return out_->path();
}

std::string StudyContext::run_time_by_stage() { return studies::run_time_by_stage(clock_, out()); }

fs::path StudyContext::commit(const std::string& report) {
    out();
    out_->commit();
    remove_checkpoints(results_root_, name_);
    clock_.done("done: " + (out_->final_path() / report).string());
    return out_->final_path();
}

}  // namespace plumage::studies
