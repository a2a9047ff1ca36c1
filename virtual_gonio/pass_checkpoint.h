// Checkpoints of the pass loop (virtual_gonio/pass_loop.h), one format for every instrument: the
// sums after the last completed pass, its convergence rows and clocks, and what the run was made
// from. A checkpoint is resumed only when it was made from the same things as this run, each
// recorded in it as one part: the build (plumage version, git commit, compiler:
// checkpoint_build()), the study file, the instrument's configuration and whatever the caller
// adds (the content hash of every input file the scene was built from). When a part differs,
// or the checkpoint cannot be read or is damaged, the run starts afresh and says so on stderr in
// one line naming the checkpoint and what differs; it never stops the run. The old checkpoint is
// replaced when the new run completes its first pass, not before: interrupted earlier, the new
// run keeps nothing and the old checkpoint stays as it was.
//
// The file: HDF5, one dataset per named sum (doubles), /convergence as in records, and root
// attributes @checkpoint_identity, @passes, @wall_time_s, @cpu_time_s.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "virtual_gonio/pass_loop.h"  // CheckpointPart, CheckpointSum, ConvergenceRow

namespace plumage::gonio {

// "plumage <version>, git <commit>, <compiler>": the build part of every checkpoint.
std::string checkpoint_build();
// Why `stored` (a checkpoint's parts) does not describe `current`: "; "-separated differences
// ("the study file changed", ...), or empty when they agree.
std::string checkpoint_differences(const std::vector<CheckpointPart>& stored,
                                   const std::vector<CheckpointPart>& current);
// A stable 64-bit hash (FNV-1a) as 16 hex digits: the value of a part made from a long text.
std::string checkpoint_hash(const std::string& text);
// The parts every instrument's checkpoint starts with: the build, the study file and the
// measurement's configuration (`configuration`: a canonical text of everything that decides the
// sums), then `inputs` (the caller's).
std::vector<CheckpointPart> checkpoint_identity(const std::string& study_text,
                                                const std::string& configuration,
                                                const std::vector<CheckpointPart>& inputs);

// What a checkpoint holds besides the sums.
struct CheckpointClocks {
    int passes = 0;
    std::vector<ConvergenceRow> rows;
    double wall_time_s = 0.0, cpu_time_s = 0.0;
};

// Written by rank 0 under a name of this process alone, then renamed over `path`.
void write_pass_checkpoint(const std::filesystem::path& path,
                           const std::vector<CheckpointPart>& identity,
                           const std::vector<CheckpointSum>& sums, const CheckpointClocks& clocks);

// Rank 0 reads `path`; every rank gets the result. True and `sums` and `clocks` filled when the
// checkpoint is resumable; else false, saying why on stderr (nothing said when there is none),
// `sums` and `clocks` untouched.
bool resume_pass_checkpoint(const std::filesystem::path& path,
                            const std::vector<CheckpointPart>& identity,
                            const std::vector<CheckpointSum>& sums, CheckpointClocks& clocks);

}  // namespace plumage::gonio
