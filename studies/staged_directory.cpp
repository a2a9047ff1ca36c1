#include "studies/staged_directory.h"

#include <unistd.h>

#include <fmt/format.h>

#include "common/error.h"

namespace plumage::studies {

StagedDirectory::StagedDirectory(std::filesystem::path final_path) : final_(std::move(final_path)) {
    staging_ = final_;
    staging_ += fmt::format(".partial-{}", ::getpid());
    std::error_code error;
    std::filesystem::remove_all(staging_, error);
    std::filesystem::create_directories(staging_, error);
    if (error) {
        throw IoError(fmt::format("cannot create results folder '{}': {}", staging_.string(),
                                  error.message()));
    }
}

StagedDirectory::~StagedDirectory() {
    if (!committed_) {
        std::error_code ignored;
        std::filesystem::remove_all(staging_, ignored);
    }
}

void StagedDirectory::commit() {
    std::error_code error;
    std::filesystem::path previous = final_;
    previous += fmt::format(".previous-{}", ::getpid());
    const bool had_previous = std::filesystem::exists(final_);
    if (had_previous) std::filesystem::rename(final_, previous, error);
    if (!error) std::filesystem::rename(staging_, final_, error);
    if (error) {
        throw IoError(fmt::format("cannot move results into '{}': {}", final_.string(),
                                  error.message()));
    }
    committed_ = true;
    if (had_previous) std::filesystem::remove_all(previous, error);
}

}  // namespace plumage::studies
