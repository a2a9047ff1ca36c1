// A results folder that appears only when complete, and never at the cost of something the
// user owns.
//
// Outputs are written into a sibling staging folder "<final>.partial-<pid>" that carries the
// marker file kResultsMarker; commit() swaps it into place. A folder already at <final> is
// replaced only if it carries the marker too (an earlier plumage result): a folder of the same
// name that plumage did not write is refused with an InputError, before any work when the
// study calls prepare() at read time, and again at commit(). Destroyed without commit() (an
// error, an interrupt) the staging folder is removed; if the process is killed instead, the
// next run in the same results root removes the orphan (its process is gone) and says so.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "common/interrupt.h"

namespace plumage::studies {

inline constexpr const char* kResultsMarker = ".plumage-results";

class StagedDirectory {
public:
    // prepare(final_path), then creates the staging folder with its marker.
    explicit StagedDirectory(std::filesystem::path final_path);
    ~StagedDirectory();
    StagedDirectory(const StagedDirectory&) = delete;
    StagedDirectory& operator=(const StagedDirectory&) = delete;

    const std::filesystem::path& path() const { return staging_; }
    const std::filesystem::path& final_path() const { return final_; }
    // Moves the staging folder to final_path; throws Interrupted instead if Ctrl-C arrived.
    void commit();

    // Before any work: InputError if final_path exists and is not a plumage results folder;
    // removes orphaned staging folders beside it (remove_orphans) and reports each on stderr.
    static void prepare(const std::filesystem::path& final_path);
    // In `results_root`: "<name>.partial-<pid>" folders with the marker whose process is gone
    // are removed; "<name>.previous-<pid>" (a result displaced by a commit that was killed
    // halfway) is moved back to <name> when <name> is missing, else removed. Returns one line
    // per action, for the user.
    static std::vector<std::string> remove_orphans(const std::filesystem::path& results_root);

private:
    std::filesystem::path final_;
    std::filesystem::path staging_;
    std::optional<CleanupRegistration> cleanup_;
    bool committed_ = false;
};

// Whether process `pid` runs on this host (a zombie does not): whose orphans may be removed.
bool process_running(int pid);

}  // namespace plumage::studies
