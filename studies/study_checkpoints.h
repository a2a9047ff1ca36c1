// Where a study keeps its measurements' checkpoints, how they are held in use against another
// run of the same study, keyed to input files, removed after the commit, and reported on Ctrl-C.
#pragma once

#include <filesystem>
#include <string>

#include "virtual_gonio/pass_loop.h"  // CheckpointPart

namespace plumage::studies {

// Where a study keeps the checkpoints of its measurements: <results root>/.checkpoints/<name>/,
// created, and held in use by this process (a shared flock on its kCheckpointsInUse file, until
// remove_checkpoints or exit) so that another run of the same study sharing --out, finishing
// first, leaves it to this one (runs of one study may share checkpoints: goniometer.h,
// "Checkpoints"). The same path on every call.
inline constexpr const char* kCheckpointsInUse = ".plumage-in-use";
std::filesystem::path checkpoint_folder(const std::filesystem::path& results_root,
                                        const std::string& name);
// An input file as a part of a checkpoint's identity (virtual_gonio/goniometer.h, "Checkpoints"):
// the FNV-1a hash and size of its content, so that a checkpoint made before the file changed is
// not resumed. `what` names it for the user ("the content of the sample file 'plate.obj'").
// IoError if it cannot be read.
gonio::CheckpointPart input_file_part(const std::string& what, const std::filesystem::path& file);
// After the commit: the finished records supersede the study's checkpoints; .checkpoints goes
// too when no other study's remain. Left in place while another live run of the study uses them
// (it removes them when it finishes).
void remove_checkpoints(const std::filesystem::path& results_root, const std::string& name);

// The Interrupted message of a measurement stopped with a checkpoint, after `passes` completed
// passes: where to resume from, or, with no pass completed, nothing kept (the empty checkpoint
// folders are removed).
std::string interrupted_with_checkpoint(const std::string& what, int passes,
                                        const std::filesystem::path& checkpoint);

}  // namespace plumage::studies
