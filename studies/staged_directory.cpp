#include "studies/staged_directory.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <iostream>
#include <mutex>
#include <random>
#include <set>
#include <sstream>
#include <utility>

#include <fmt/format.h>

#include "common/error.h"

namespace fs = std::filesystem;

namespace plumage::studies {
namespace {

constexpr const char* kStagingKinds[] = {"partial", "previous"};

bool has_marker(const fs::path& dir) {
    std::error_code ignored;
    return fs::is_regular_file(dir / kResultsMarker, ignored);
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

// A file descriptor closed when it goes out of scope (closing also drops its flock).
class Fd {
public:
    explicit Fd(int fd) : fd_(fd) {}
    ~Fd() {
        if (fd_ >= 0) ::close(fd_);
    }
    Fd(const Fd&) = delete;
    Fd& operator=(const Fd&) = delete;
    Fd(Fd&& other) noexcept : fd_(std::exchange(other.fd_, -1)) {}
    int get() const { return fd_; }

private:
    int fd_;
};

std::string first_line_of(const fs::path& path) {
    std::ifstream in(path);
    std::string line;
    std::getline(in, line);
    return line;
}

// Field 22 of /proc/<pid>/stat: the process's start time in clock ticks after boot, which
// tells a process from a later one given the same pid. None for a zombie or no such process.
// `process`: a pid, or "self".
std::optional<std::string> start_time_of(const std::string& process) {
    const std::string line = first_line_of(fmt::format("/proc/{}/stat", process));
    const auto close = line.rfind(')');  // the command name may hold spaces and parentheses
    if (close == std::string::npos) return std::nullopt;
    std::istringstream fields(line.substr(close + 1));
    std::string field;
    for (int number = 3; number <= 22 && fields >> field; ++number) {
        if (number == 3 && field == "Z") return std::nullopt;
        if (number == 22) return field;
    }
    return std::nullopt;
}

// Who owns a staging folder: enough to tell, from another process, whether it still runs.
struct OwnerRecord {
    std::string host, boot_id, pid_namespace, start_time;
    long pid = 0;
};

OwnerRecord this_process() {
    static const OwnerRecord me = [] {
        OwnerRecord r;
        char host[256] = {};
        ::gethostname(host, sizeof host - 1);
        r.host = host;
        r.boot_id = first_line_of("/proc/sys/kernel/random/boot_id");
        struct stat ns = {};
        if (::stat("/proc/self/ns/pid", &ns) == 0) r.pid_namespace = std::to_string(ns.st_ino);
        r.pid = ::getpid();
        r.start_time = start_time_of("self").value_or("");
        return r;
    }();
    return me;
}

std::string record_text(const OwnerRecord& r) {
    return fmt::format(
        "# plumage: the run below owns this folder while it holds a lock on this file\n"
        "host={}\nboot_id={}\npid_namespace={}\npid={}\nstart_time={}\n",
        r.host, r.boot_id, r.pid_namespace, r.pid, r.start_time);
}

// The record, or none when a field is missing or empty (nothing can be proven from it).
std::optional<OwnerRecord> parse_record(const std::string& text) {
    OwnerRecord r;
    std::string pid;
    std::istringstream lines(text);
    for (std::string line; std::getline(lines, line);) {
        const auto eq = line.find('=');
        if (line.empty() || line[0] == '#' || eq == std::string::npos) continue;
        const std::string key = line.substr(0, eq), value = line.substr(eq + 1);
        for (auto [name, field] : {std::pair{"host", &r.host},
                                   {"boot_id", &r.boot_id},
                                   {"pid_namespace", &r.pid_namespace},
                                   {"start_time", &r.start_time},
                                   {"pid", &pid}})
            if (key == name) *field = value;
    }
    if (r.host.empty() || r.boot_id.empty() || r.pid_namespace.empty() || r.start_time.empty() ||
        pid.empty() || pid.find_first_not_of("0123456789") != std::string::npos || pid.size() > 9) {
        return std::nullopt;
    }
    r.pid = std::stol(pid);
    return r;
}

std::string read_all(int fd) {
    std::string text;
    char buffer[512];
    for (ssize_t n; (n = ::read(fd, buffer, sizeof buffer)) > 0 && text.size() < 4096;)
        text.append(buffer, static_cast<std::size_t>(n));
    return text;
}

struct Verdict {
    enum Kind { gone, alive, unknown } kind;
    std::string reason = {};      // unknown: why nothing can be proven
    OwnerRecord owner = {};       // gone
    std::optional<Fd> lock = {};  // gone: held while the folder is tidied
};

// Whether the owner of `dir` is provably gone. An flock is the kernel's own answer — it is
// dropped when its holder dies, however it dies — but only within one kernel: over NFS, Linux
// turns flock into POSIX locks that the server arbitrates between clients only when the mount
// has working locking (not with `nolock` or `local_lock=flock|all`, nor on some other network
// file systems), where a lock taken says nothing about a process on another machine. So the
// lock alone is trusted only for an owner recorded on this host and boot; then, in our PID
// namespace, its pid and start time are checked as a second witness.
Verdict judge_owner(const fs::path& dir) {
    Fd fd(::open((dir / kOwnerRecord).c_str(), O_RDONLY | O_CLOEXEC | O_NOFOLLOW));
    if (fd.get() < 0) {
        return {Verdict::unknown,
                errno == ENOENT
                    ? fmt::format("it has no owner record {} (a folder of an older plumage, or "
                                  "one named so by hand)",
                                  kOwnerRecord)
                    : fmt::format("its owner record cannot be opened ({})", std::strerror(errno))};
    }
    if (::flock(fd.get(), LOCK_EX | LOCK_NB) != 0) {
        if (errno == EWOULDBLOCK) return {Verdict::alive};
        return {Verdict::unknown,
                fmt::format("its owner's lock cannot be tested ({})", std::strerror(errno))};
    }
    const std::optional<OwnerRecord> owner = parse_record(read_all(fd.get()));
    if (!owner) return {Verdict::unknown, "its owner record is incomplete"};
    const OwnerRecord me = this_process();
    if (owner->host != me.host || owner->boot_id != me.boot_id || me.boot_id.empty()) {
        return {Verdict::unknown,
                fmt::format("its owner, process {} on host {} (boot {}), did not run on this host "
                            "and boot, so whether it still runs cannot be told from here",
                            owner->pid, owner->host, owner->boot_id)};
    }
    if (owner->pid_namespace == me.pid_namespace &&
        start_time_of(std::to_string(owner->pid)) ==
            std::optional<std::string>(owner->start_time)) {
        return {Verdict::alive};  // its lock is free, yet it runs: trust the process
    }
    return {Verdict::gone, {}, *owner, std::move(fd)};
}

// Each folder left alone is reported once per process (prepare() runs twice per study).
std::optional<std::string> once(const fs::path& dir, std::string line) {
    static std::mutex mutex;
    static std::set<std::string> said;
    const std::lock_guard lock(mutex);
    if (!said.insert(dir.string()).second) return std::nullopt;
    return line;
}

// What to do with `dir`, a "<final>.<kind>-..." folder, and what was done (none: nothing worth
// saying).
std::optional<std::string> tidy(const fs::path& dir, const std::string& kind,
                                const fs::path& final_path) {
    if (!has_marker(dir)) {
        if (judge_owner(dir).kind == Verdict::alive) return std::nullopt;  // being created
        return once(dir, fmt::format("left {} in place: it looks like an unfinished run's "
                                     "folder but has no {} marker",
                                     dir.string(), kResultsMarker));
    }
    Verdict v = judge_owner(dir);
    if (v.kind == Verdict::alive) return std::nullopt;
    if (v.kind == Verdict::unknown) {
        return once(dir, fmt::format("left {} alone: {}; remove it by hand if no run uses it",
                                     dir.string(), v.reason));
    }
    std::error_code error;
    if (kind == "previous" && !fs::exists(final_path, error)) {
        fs::rename(dir, final_path, error);
        if (error) {
            return once(dir, fmt::format("could not restore {} from {}: {}", final_path.string(),
                                         dir.string(), error.message()));
        }
        fs::remove(final_path / kOwnerRecord, error);
        return fmt::format("restored {} from {} (process {} was killed while replacing it)",
                           final_path.string(), dir.string(), v.owner.pid);
    }
    fs::remove_all(dir, error);
    if (error) {
        return once(dir, fmt::format("could not remove {}, left by process {} which is gone: {}",
                                     dir.string(), v.owner.pid, error.message()));
    }
    return fmt::format("removed {}, left by process {} which is gone", dir.string(), v.owner.pid);
}

}  // namespace

std::string staging_name_problem(std::string_view name) {
    for (const char* kind : kStagingKinds) {
        const std::string tag = fmt::format(".{}-", kind);
        if (name.find(tag) != std::string_view::npos)
            return fmt::format("contains \"{}\", reserved for the folders plumage stages in", tag);
    }
    if (name == ".checkpoints") return "is reserved for the folder plumage keeps checkpoints in";
    if (name.starts_with(".plumage-"))
        return "starts with \".plumage-\", reserved for plumage's marker files";
    return {};
}

OwnerLock::OwnerLock(const fs::path& path) {
    fd_ = ::open(path.c_str(), O_RDWR | O_CREAT | O_EXCL | O_CLOEXEC | O_NOFOLLOW, 0644);
    if (fd_ < 0) {
        throw IoError(fmt::format("cannot create owner record '{}': {}", path.string(),
                                  std::strerror(errno)));
    }
    // Blocking: another run testing this record holds its lock for a moment only. On a file
    // system without locks (ENOLCK) the record stays unlocked; the others cannot lock it either,
    // so they leave the folder alone.
    while (::flock(fd_, LOCK_EX) != 0 && errno == EINTR) {
    }
    const std::string text = record_text(this_process());
    if (::write(fd_, text.data(), text.size()) != static_cast<ssize_t>(text.size())) {
        const int error = errno;
        remove(path);
        throw IoError(
            fmt::format("cannot write owner record '{}': {}", path.string(), std::strerror(error)));
    }
}

OwnerLock::~OwnerLock() {
    if (fd_ >= 0) ::close(fd_);
}

void OwnerLock::remove(const fs::path& where) {
    ::unlink(where.c_str());  // before unlocking: nobody may judge a record we are removing
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
}

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
        for (const std::string kind : kStagingKinds) {
            const auto at = folder.rfind("." + kind + "-");
            if (at == std::string::npos || at == 0) continue;
            if (auto line = tidy(dir, kind, results_root / folder.substr(0, at)))
                actions.push_back(std::move(*line));
            break;
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
    std::error_code error;
    if (final_.has_parent_path()) fs::create_directories(final_.parent_path(), error);
    std::random_device random;
    for (int attempt = 0; !error; ++attempt) {
        suffix_ = fmt::format("{}-{:08x}", ::getpid(), random());
        staging_ = final_;
        staging_ += ".partial-" + suffix_;
        if (fs::create_directory(staging_, error)) break;  // new, so ours alone
        if (attempt == 8) error = std::make_error_code(std::errc::file_exists);
    }
    if (error) {
        throw IoError(fmt::format("cannot create results folder '{}': {}", staging_.string(),
                                  error.message()));
    }
    cleanup_.emplace(staging_);
    try {
        owner_.emplace(staging_ / kOwnerRecord);  // before the marker: see remove_orphans
        std::ofstream marker(staging_ / kResultsMarker);
        marker << "Written by plumage. A results folder with this file may be replaced by a "
                  "later run of the same study; one without it is never touched.\n";
        if (!marker) throw IoError(fmt::format("cannot write {}", kResultsMarker));
    } catch (const IoError& e) {
        fs::remove_all(staging_, error);
        throw IoError(
            fmt::format("cannot create results folder '{}': {}", staging_.string(), e.what()));
    }
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
    std::error_code error, ignored;
    fs::path previous = final_;
    previous += ".previous-" + suffix_;
    const bool had_previous = fs::exists(final_);
    // The earlier result carries our owner record while it waits beside the new one, so that a
    // run that finds it there after a kill restores it, and one that finds us alive leaves it.
    std::optional<OwnerLock> displaced;
    if (had_previous) {
        fs::remove(final_ / kOwnerRecord, ignored);  // a commit killed halfway may have left one
        displaced.emplace(final_ / kOwnerRecord);
        fs::rename(final_, previous, error);
        if (error) displaced->remove(final_ / kOwnerRecord);
    }
    if (!error) {
        fs::rename(staging_, final_, error);
        if (error && had_previous) {  // put it back
            fs::rename(previous, final_, ignored);
            displaced->remove(final_ / kOwnerRecord);
        }
    }
    if (error) {
        throw IoError(
            fmt::format("cannot move results into '{}': {}", final_.string(), error.message()));
    }
    committed_ = true;
    cleanup_.reset();
    if (had_previous) fs::remove_all(previous, ignored);
    owner_->remove(final_ / kOwnerRecord);  // a finished result has no owner
}

bool owner_provably_gone(const fs::path& dir) { return judge_owner(dir).kind == Verdict::gone; }

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
