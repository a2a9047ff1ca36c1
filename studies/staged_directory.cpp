#include "studies/staged_directory.h"

#include <signal.h>
#include <unistd.h>

#include <cerrno>
#include <charconv>
#include <fstream>
#include <iostream>

#include <fmt/format.h>

#include "common/error.h"

namespace fs = std::filesystem;

namespace plumage::studies {
namespace {

bool has_marker(const fs::path& dir) {
    std::error_code ignored;
    return fs::is_regular_file(dir / kResultsMarker, ignored);
}

// The pid in "<name>.<kind>-<pid>", if the folder name has that form.
std::optional<pid_t> pid_suffix(const std::string& folder, const std::string& kind) {
    const std::string tag = "." + kind + "-";
    const auto at = folder.rfind(tag);
    if (at == std::string::npos || at == 0) return std::nullopt;
    const char* first = folder.data() + at + tag.size();
    const char* last = folder.data() + folder.size();
    long pid = 0;
    const auto [end, error] = std::from_chars(first, last, pid);
    if (error != std::errc() || end != last || first == last || pid <= 0) return std::nullopt;
    return static_cast<pid_t>(pid);
}

void refuse_foreign(const fs::path& final_path) {
    std::error_code error;
    if (!fs::exists(final_path, error)) return;
    if (fs::is_directory(final_path, error) && has_marker(final_path)) return;
    throw InputError(fmt::format(
        "results folder '{}' exists and was not written by plumage (it has no {} marker): "
        "refusing to replace it; move it away, or choose another `name` or --out",
        final_path.string(), kResultsMarker));
}

}  // namespace

std::vector<std::string> StagedDirectory::remove_orphans(const fs::path& results_root) {
    std::vector<std::string> actions;
    std::error_code error;
    if (!fs::is_directory(results_root, error)) return actions;
    std::vector<fs::path> entries;
    for (const auto& entry : fs::directory_iterator(results_root, error)) {
        if (entry.is_directory(error)) entries.push_back(entry.path());
    }
    for (const fs::path& dir : entries) {
        const std::string folder = dir.filename().string();
        for (const std::string kind : {"partial", "previous"}) {
            const auto pid = pid_suffix(folder, kind);
            if (!pid || *pid == ::getpid() || process_running(*pid)) continue;
            if (!has_marker(dir)) {
                actions.push_back(
                    fmt::format("left {} in place: it looks like an unfinished run's "
                                "folder but has no {} marker",
                                dir.string(), kResultsMarker));
                continue;
            }
            const fs::path final_path =
                results_root / folder.substr(0, folder.rfind("." + kind + "-"));
            std::error_code step;
            if (kind == "previous" && !fs::exists(final_path, step)) {
                fs::rename(dir, final_path, step);
                actions.push_back(
                    fmt::format("restored {} from {} (process {} was killed while "
                                "replacing it)",
                                final_path.string(), dir.string(), *pid));
            } else {
                fs::remove_all(dir, step);
                actions.push_back(fmt::format("removed {}, left by process {} which is gone",
                                              dir.string(), *pid));
            }
        }
    }
    return actions;
}

void StagedDirectory::prepare(const fs::path& final_path) {
    refuse_foreign(final_path);
    const fs::path root = final_path.has_parent_path() ? final_path.parent_path() : fs::path(".");
    for (const std::string& line : remove_orphans(root)) std::cerr << "plumage: " << line << '\n';
}

StagedDirectory::StagedDirectory(fs::path final_path) : final_(std::move(final_path)) {
    prepare(final_);
    staging_ = final_;
    staging_ += fmt::format(".partial-{}", ::getpid());
    std::error_code error;
    fs::remove_all(staging_, error);  // our own pid: an earlier staging of this process
    fs::create_directories(staging_, error);
    if (!error) {
        std::ofstream marker(staging_ / kResultsMarker);
        marker << "Written by plumage. A results folder with this file may be replaced by a "
                  "later run of the same study; one without it is never touched.\n";
        if (!marker) error = std::make_error_code(std::errc::io_error);
    }
    if (error) {
        throw IoError(fmt::format("cannot create results folder '{}': {}", staging_.string(),
                                  error.message()));
    }
    cleanup_.emplace(staging_);
}

StagedDirectory::~StagedDirectory() {
    if (!committed_) {
        std::error_code ignored;
        fs::remove_all(staging_, ignored);
    }
}

void StagedDirectory::commit() {
    // An interrupt that arrived during the last stage still means "stop": nothing is replaced.
    throw_if_interrupted(fmt::format("replacing {}", final_.string()));
    refuse_foreign(final_);  // a folder may have appeared while we worked
    std::error_code error;
    fs::path previous = final_;
    previous += fmt::format(".previous-{}", ::getpid());
    const bool had_previous = fs::exists(final_);
    if (had_previous) fs::rename(final_, previous, error);
    if (!error) {
        fs::rename(staging_, final_, error);
        std::error_code ignored;
        if (error && had_previous) fs::rename(previous, final_, ignored);  // put it back
    }
    if (error) {
        throw IoError(
            fmt::format("cannot move results into '{}': {}", final_.string(), error.message()));
    }
    committed_ = true;
    cleanup_.reset();
    if (had_previous) fs::remove_all(previous, error);
}

bool process_running(int pid) {
    if (::kill(pid, 0) != 0 && errno != EPERM) return false;
    // A zombie (killed, not yet reaped: an MPI rank whose launcher is gone, under an init that
    // reaps late) is gone too: its folders are orphans.
    std::ifstream stat(fmt::format("/proc/{}/stat", pid));
    std::string line;
    std::getline(stat, line);
    const auto close = line.rfind(')');
    return close == std::string::npos || close + 2 >= line.size() || line[close + 2] != 'Z';
}

}  // namespace plumage::studies
