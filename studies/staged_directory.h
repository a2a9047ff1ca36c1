// A results folder that appears only when complete, and never at the cost of something the
// user owns or of another run's work.
//
// Outputs are written into a sibling staging folder "<final>.partial-<pid>-<tag>" (<tag>: 8
// random hex digits, so that two runs with the same pid in different PID namespaces, containers
// or hosts sharing --out never pick the same folder) that carries the marker file
// kResultsMarker; commit() swaps it into place. A folder already at <final> is replaced only if
// it carries the marker too (an earlier plumage result): a folder of the same name that plumage
// did not write is refused with an InputError, before any work when the study calls prepare()
// at read time, and again at commit(). While commit() swaps the folders, the earlier result
// waits in "<final>.previous-<pid>-<tag>".
//
// Ownership. The staging folder, and a displaced earlier result, hold an owner record
// (kOwnerRecord: host name, boot id, PID namespace, pid and start time of the process) that the
// owning process keeps locked with flock(2) for as long as it lives; the kernel drops the lock
// when the process dies, however it dies. Destroyed without commit() (an error, an interrupt)
// the staging folder is removed by its owner; if the process is killed instead, a later run
// removes it (and says so) only when its owner is provably gone: the record's lock can be taken
// and the record names this host and this boot (a lock is only trusted within one kernel: see
// owner_gone in the .cpp), and, in the same PID namespace, no live process has the record's pid
// and start time. Everything else — a live owner, an owner on another host or boot, a folder
// without a record (an older plumage's, or one the user named so) — is left alone, and said so
// once per process. Study names that could be mistaken for these folders are refused when the
// study file is read (staging_name_problem).
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "common/interrupt.h"

namespace plumage::studies {

inline constexpr const char* kResultsMarker = ".plumage-results";
// The owner record inside a staging or displaced folder (removed from a committed result).
inline constexpr const char* kOwnerRecord = ".plumage-owner";

// Empty when `name` (a study name) cannot be mistaken for one of plumage's own entries in a
// results root; else why: names containing ".partial-" or ".previous-" (staging folders), the
// checkpoint folder ".checkpoints", and names starting with ".plumage-" (marker files).
std::string staging_name_problem(std::string_view name);

// The owner record of this process at `path`, created, locked (flock, exclusive) and written;
// the lock lives as long as this object. IoError if the file cannot be created.
class OwnerLock {
public:
    explicit OwnerLock(const std::filesystem::path& path);
    ~OwnerLock();
    OwnerLock(const OwnerLock&) = delete;
    OwnerLock& operator=(const OwnerLock&) = delete;
    // Removes the record, now at `where` (its folder may have been renamed), and unlocks it.
    void remove(const std::filesystem::path& where);

private:
    int fd_ = -1;
};

class StagedDirectory {
public:
    // prepare(final_path), then creates the staging folder with its owner record and marker.
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
    // In `results_root`: "<name>.partial-*" folders whose owner is provably gone (see above) are
    // removed; "<name>.previous-*" ones (a result displaced by a commit that was killed halfway)
    // are moved back to <name> when <name> is missing, else removed. Returns one line per action
    // and per folder left alone for a reason the user may want to know (each folder at most
    // once per process), for the user.
    static std::vector<std::string> remove_orphans(const std::filesystem::path& results_root);

private:
    std::filesystem::path final_;
    std::filesystem::path staging_;
    std::string suffix_;  // "<pid>-<tag>", shared by the staging and the displaced folder
    std::optional<OwnerLock> owner_;
    std::optional<CleanupRegistration> cleanup_;
    bool committed_ = false;
};

// Whether process `pid` runs in this PID namespace (a zombie does not).
bool process_running(int pid);

// Whether the owner of `dir` (its kOwnerRecord, written by an OwnerLock) is provably gone, by
// the rule above (its lock free, recorded on this host and boot, and no live process with its
// pid and start time here). False when it lives or nothing can be proven (no record, another
// host, boot or PID namespace whose process cannot be seen): such folders are left alone.
bool owner_provably_gone(const std::filesystem::path& dir);

}  // namespace plumage::studies
