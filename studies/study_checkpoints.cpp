#include "studies/study_checkpoints.h"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <fstream>
#include <map>
#include <mutex>
#include <vector>

#include <fmt/format.h>

#include "common/error.h"

namespace plumage::studies {

namespace {

std::mutex checkpoint_mutex;
// Checkpoint folders this process uses, each with the descriptor holding its shared lock.
std::map<std::filesystem::path, int> checkpoint_leases;

constexpr int kInUseElsewhere = -2;

// The descriptor of `folder`'s in-use file, locked `how` (LOCK_SH, LOCK_EX | LOCK_NB);
// kInUseElsewhere when another process holds it, -1 when it cannot be locked (no such file, a
// file system without flock). A run removing the folder holds it exclusively; one that waited
// for it meanwhile finds its file unlinked and starts again.
int lock_in_use(const std::filesystem::path& folder, int how) {
    const std::filesystem::path file = folder / kCheckpointsInUse;
    for (int attempt = 0; attempt < 100; ++attempt) {
        std::error_code ignored;
        if (how == LOCK_SH) std::filesystem::create_directories(folder, ignored);
        const int fd =
            ::open(file.c_str(), O_RDONLY | O_CLOEXEC | (how == LOCK_SH ? O_CREAT : 0), 0644);
        if (fd < 0) return -1;
        int locked;
        while ((locked = ::flock(fd, how)) != 0 && errno == EINTR) {
        }
        struct stat held = {};
        struct stat named = {};
        if (locked == 0 && ::fstat(fd, &held) == 0 && ::stat(file.c_str(), &named) == 0 &&
            held.st_ino == named.st_ino && held.st_dev == named.st_dev) {
            return fd;
        }
        const bool busy = locked != 0 && errno == EWOULDBLOCK;
        ::close(fd);
        if (locked != 0) return busy ? kInUseElsewhere : -1;
    }
    return -1;
}

}  // namespace

std::filesystem::path checkpoint_folder(const std::filesystem::path& results_root,
                                        const std::string& name) {
    const std::filesystem::path folder = results_root / ".checkpoints" / name;
    const std::lock_guard lock(checkpoint_mutex);
    // Without a lock (a file system without flock) the checkpoints still work; only a run of the
    // same study finishing first may remove them under us.
    if (!checkpoint_leases.contains(folder))
        checkpoint_leases[folder] = lock_in_use(folder, LOCK_SH);
    return folder;
}

void remove_checkpoints(const std::filesystem::path& results_root, const std::string& name) {
    const std::filesystem::path folder = results_root / ".checkpoints" / name;
    const std::lock_guard lock(checkpoint_mutex);
    if (const auto lease = checkpoint_leases.find(folder); lease != checkpoint_leases.end()) {
        if (lease->second >= 0) ::close(lease->second);
        checkpoint_leases.erase(lease);
    }
    const int fd = lock_in_use(folder, LOCK_EX | LOCK_NB);
    if (fd == kInUseElsewhere) return;  // another run of the study still measures into it
    std::error_code ignored;
    std::filesystem::remove_all(folder, ignored);
    if (fd >= 0) ::close(fd);
    std::filesystem::remove(results_root / ".checkpoints", ignored);  // only when empty
}

gonio::CheckpointPart input_file_part(const std::string& what, const std::filesystem::path& file) {
    std::ifstream in(file, std::ios::binary);
    std::uint64_t hash = 1469598103934665603ULL, size = 0;  // FNV-1a, 64 bits
    std::vector<char> buffer(std::size_t{1} << 20);
    while (in.read(buffer.data(), static_cast<std::streamsize>(buffer.size())) || in.gcount() > 0) {
        const auto n = static_cast<std::size_t>(in.gcount());
        for (std::size_t i = 0; i < n; ++i)
            hash = (hash ^ static_cast<unsigned char>(buffer[i])) * 1099511628211ULL;
        size += n;
    }
    if (!in.eof()) {
        throw IoError(
            fmt::format("cannot read {} ({}) to key its checkpoint", file.string(), what));
    }
    return {what, fmt::format("{:016x}, {} bytes", hash, size)};
}

std::string interrupted_with_checkpoint(const std::string& what, int passes,
                                        const std::filesystem::path& checkpoint) {
    if (passes > 0) {
        return fmt::format(
            "interrupted in {} after {} completed passes, kept in {}; run the same "
            "command again to resume from them",
            what, passes, checkpoint.string());
    }
    // <root>/.checkpoints/<name>/<file>: remove the two folders if nothing but our lease is in
    // them (and no other run of the study uses them).
    const std::filesystem::path folder = checkpoint.parent_path();
    std::error_code ignored;
    bool only_lease = true;
    for (const auto& entry : std::filesystem::directory_iterator(folder, ignored))
        only_lease = only_lease && entry.path().filename() == kCheckpointsInUse;
    if (only_lease) {
        remove_checkpoints(folder.parent_path().parent_path(), folder.filename().string());
    }
    return fmt::format("interrupted in {} before its first pass completed (nothing to resume)",
                       what);
}

}  // namespace plumage::studies
