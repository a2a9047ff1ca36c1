// A results folder that appears only when complete. Outputs are written into a
// sibling staging folder ("<final>.partial-<pid>"); commit() swaps it into place
// (replacing an earlier result of the same name). Destroyed without commit(), e.g. on
// an error, the staging folder is removed: nothing half-written is left behind.
#pragma once

#include <filesystem>

namespace plumage::studies {

class StagedDirectory {
public:
    explicit StagedDirectory(std::filesystem::path final_path);
    ~StagedDirectory();
    StagedDirectory(const StagedDirectory&) = delete;
    StagedDirectory& operator=(const StagedDirectory&) = delete;

    const std::filesystem::path& path() const { return staging_; }
    const std::filesystem::path& final_path() const { return final_; }
    void commit();

private:
    std::filesystem::path final_;
    std::filesystem::path staging_;
    bool committed_ = false;
};

}  // namespace plumage::studies
