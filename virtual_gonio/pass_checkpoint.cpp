#include "virtual_gonio/pass_checkpoint.h"

#include <algorithm>
#include <cmath>
#include <iostream>
#include <random>

#include <fmt/format.h>

#include "common/build_info.h"
#include "common/distributed.h"
#include "common/error.h"
#include "common/interrupt.h"
#include "common/version.h"
#include "virtual_gonio/record/hdf5_file.h"
#include "virtual_gonio/record_provenance.h"

namespace plumage::gonio {
namespace {

constexpr const char* kBuildPart = "the build";

// One part per line, "what<TAB>value" (tabs and line breaks inside either become spaces).
std::string identity_text(const std::vector<CheckpointPart>& parts) {
    auto flat = [](std::string text) {
        std::replace_if(
            text.begin(), text.end(), [](char c) { return c == '\t' || c == '\n' || c == '\r'; },
            ' ');
        return text;
    };
    std::string text;
    for (const CheckpointPart& p : parts) text += flat(p.what) + '\t' + flat(p.value) + '\n';
    return text;
}

std::vector<CheckpointPart> parse_identity(const std::string& text) {
    std::vector<CheckpointPart> parts;
    std::size_t start = 0;
    while (start < text.size()) {
        std::size_t end = text.find('\n', start);
        if (end == std::string::npos) end = text.size();
        const std::string line = text.substr(start, end - start);
        const auto tab = line.find('\t');
        if (tab != std::string::npos) parts.push_back({line.substr(0, tab), line.substr(tab + 1)});
        start = end + 1;
    }
    return parts;
}

void write_file(const std::filesystem::path& path, const std::vector<CheckpointPart>& identity,
                const std::vector<CheckpointSum>& sums, const CheckpointClocks& clocks) {
    record::Hdf5Writer h5(path);
    for (const CheckpointSum& s : sums) {
        h5.write(s.name, std::span<const double>(*s.values),
                 std::vector<std::uint64_t>{s.values->size()});
    }
    write_convergence(h5, clocks.rows);
    h5.set_attribute("/", "checkpoint_identity", identity_text(identity));
    h5.set_attribute("/", "passes", static_cast<double>(clocks.passes));
    h5.set_attribute("/", "wall_time_s", clocks.wall_time_s);
    h5.set_attribute("/", "cpu_time_s", clocks.cpu_time_s);
    h5.commit();
}

// The sums and clocks of a checkpoint made from `identity`, each checked; "" when resumable,
// else why not (`sums` and `clocks` then untouched).
std::string load(const std::filesystem::path& path, const std::vector<CheckpointPart>& identity,
                 const std::vector<CheckpointSum>& sums, CheckpointClocks& clocks) {
    const record::Hdf5Reader h5(path);
    if (!h5.has_attribute("/", "checkpoint_identity")) {
        return "it was written by an earlier plumage that did not record what it was made from";
    }
    std::string why = checkpoint_differences(
        parse_identity(h5.string_attribute("/", "checkpoint_identity")), identity);
    if (!why.empty()) return why;
    std::vector<std::vector<double>> loaded;
    for (const CheckpointSum& s : sums) {
        loaded.push_back(
            h5.dataset(s.name, {1, std::max<std::uint64_t>(s.values->size(), 1)}).values);
        const std::vector<double>& v = loaded.back();
        if (v.size() != s.values->size() ||
            !std::all_of(v.begin(), v.end(), [](double x) { return std::isfinite(x); })) {
            return fmt::format(
                "it is damaged (its '{}' has {} values, or values that are not finite; this "
                "measurement has {})",
                s.name, v.size(), s.values->size());
        }
    }
    const std::vector<ConvergenceRow> rows = read_convergence(path);
    const double passes = h5.number_attribute("/", "passes");
    const double wall = h5.number_attribute("/", "wall_time_s");
    // Checkpoints written before CPU time was recorded lack it: their passes count as none.
    const double cpu =
        h5.has_attribute("/", "cpu_time_s") ? h5.number_attribute("/", "cpu_time_s") : 0.0;
    if (!(passes >= 0.0 && passes <= 1e9 && passes == std::floor(passes)) ||
        rows.size() != static_cast<std::size_t>(passes) || !(wall >= 0.0) || !(cpu >= 0.0) ||
        !std::isfinite(wall) || !std::isfinite(cpu)) {
        return fmt::format(
            "it is damaged ({} passes with {} convergence rows, wall {} s, CPU {} s)", passes,
            rows.size(), wall, cpu);
    }
    for (std::size_t i = 0; i < sums.size(); ++i) *sums[i].values = std::move(loaded[i]);
    clocks = {static_cast<int>(passes), rows, wall, cpu};
    return {};
}

// Rank 0's reading of the checkpoint (a missing, unreadable, damaged or foreign one is not
// resumed, saying why on stderr).
bool read_on_rank0(const std::filesystem::path& path, const std::vector<CheckpointPart>& identity,
                   const std::vector<CheckpointSum>& sums, CheckpointClocks& clocks) {
    std::error_code error;
    if (path.empty() || !std::filesystem::exists(path, error)) return false;
    std::string why;
    try {
        why = load(path, identity, sums, clocks);
        if (why.empty()) return true;
    } catch (const Interrupted&) {
        throw;
    } catch (const std::exception& e) {
        why = fmt::format("it cannot be read ({})", e.what());
    }
    std::cerr << fmt::format(
        "plumage: not resuming {}: {}; starting afresh (this run's first pass replaces it)\n",
        path.string(), why);
    return false;
}

}  // namespace

std::string checkpoint_build() {
    return fmt::format("plumage {}, git {}, {}", kVersion, git_commit(), compiler());
}

std::string checkpoint_hash(const std::string& text) {
    std::uint64_t h = 1469598103934665603ULL;
    for (unsigned char c : text) h = (h ^ c) * 1099511628211ULL;
    return fmt::format("{:016x}", h);
}

std::vector<CheckpointPart> checkpoint_identity(const std::string& study_text,
                                                const std::string& configuration,
                                                const std::vector<CheckpointPart>& inputs) {
    std::vector<CheckpointPart> parts = {
        {kBuildPart, checkpoint_build()},
        {"the study file", checkpoint_hash(study_text)},
        {"the measurement's configuration", checkpoint_hash(configuration)}};
    parts.insert(parts.end(), inputs.begin(), inputs.end());
    return parts;
}

std::string checkpoint_differences(const std::vector<CheckpointPart>& stored,
                                   const std::vector<CheckpointPart>& current) {
    auto find = [](const std::vector<CheckpointPart>& parts, const std::string& what) {
        return std::find_if(parts.begin(), parts.end(),
                            [&](const CheckpointPart& p) { return p.what == what; });
    };
    std::vector<std::string> differences;
    for (const CheckpointPart& now : current) {
        const auto then = find(stored, now.what);
        if (then == stored.end()) {
            differences.push_back(fmt::format("{} is new", now.what));
        } else if (then->value != now.value) {
            // The build is said in words; the other parts are hashes, which would tell nothing.
            differences.push_back(
                now.what == kBuildPart
                    ? fmt::format("the build changed (from {} to {})", then->value, now.value)
                    : fmt::format("{} changed", now.what));
        }
    }
    for (const CheckpointPart& then : stored) {
        if (find(current, then.what) == current.end())
            differences.push_back(fmt::format("{} is no longer an input", then.what));
    }
    std::string text;
    for (const std::string& d : differences) text += (text.empty() ? "" : "; ") + d;
    return text;
}

// Another run of the same study may share the checkpoint (runs of one identity write the same
// sums pass by pass, so either's checkpoint is good for both), and in another PID namespace it
// may have our pid, which is all the writer's own temporary name carries: hence a random name.
// A run of it that finished meanwhile may have removed the folder.
void write_pass_checkpoint(const std::filesystem::path& path,
                           const std::vector<CheckpointPart>& identity,
                           const std::vector<CheckpointSum>& sums, const CheckpointClocks& clocks) {
    std::error_code error;
    std::filesystem::create_directories(path.parent_path(), error);
    static std::random_device random;
    std::filesystem::path unique = path;
    unique += fmt::format(".{:08x}{:08x}", random(), random());
    write_file(unique, identity, sums, clocks);
    std::filesystem::rename(unique, path, error);
    if (error) {
        std::filesystem::remove(unique, error);
        throw IoError(fmt::format("cannot rename checkpoint {} into place", path.string()));
    }
}

bool resume_pass_checkpoint(const std::filesystem::path& path,
                            const std::vector<CheckpointPart>& identity,
                            const std::vector<CheckpointSum>& sums, CheckpointClocks& clocks) {
    bool resumed = distributed::rank() == 0 && read_on_rank0(path, identity, sums, clocks);
    if (!distributed::active()) return resumed;
    // Under MPI only rank 0 reads: its state goes to every rank, so that all run the same passes.
    Bytes state;
    if (distributed::rank() == 0) {
        state.put(static_cast<char>(resumed));
        for (const CheckpointSum& s : sums) state.put_vector(*s.values);
        state.put_vector(clocks.rows);
        state.put(clocks.passes);
        state.put(clocks.wall_time_s);
        state.put(clocks.cpu_time_s);
    }
    state = distributed::broadcast_bytes(std::move(state));
    if (distributed::rank() == 0) return resumed;
    resumed = state.get<char>() != 0;
    for (const CheckpointSum& s : sums) *s.values = state.get_vector<double>();
    clocks.rows = state.get_vector<ConvergenceRow>();
    clocks.passes = state.get<int>();
    clocks.wall_time_s = state.get<double>();
    clocks.cpu_time_s = state.get<double>();
    return resumed;
}

}  // namespace plumage::gonio
