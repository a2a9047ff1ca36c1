// The instruments' one progressive measurement loop: passes of work items until a stop rule,
// each pass's items dealt over threads and MPI ranks, a convergence row and a progress line per
// pass, every rank stopping with rank 0, Ctrl-C between items. An instrument supplies only what
// is its own (PassMeasurement): the work items of a pass and their reduction into its sums; the
// goniometer, the scatterometer, the BTF camera and the integrating sphere run on it.
//
// Order and bits: the items of a pass run in any order, on any thread or rank, and each writes
// only its own slot; reduce() adds them in item order on every rank, so the sums, the stop
// decisions (from the estimates) and the record are the same bits at any thread or rank count.
// Only a time rule can stop two runs after different passes; rank 0's clock then decides for
// every rank.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "common/distributed.h"

namespace plumage::gonio {

// One row per completed pass, in the record's /convergence.
struct ConvergenceRow {
    int pass;
    double wall_time_s;    // since the measurement started (a resumed run: its first part too)
    std::uint64_t quanta;  // per the instrument's unit (light direction and λ; pixel; ...)
    double estimated_relative_rms_error;
};

// What the estimate says after a pass.
struct PassEstimate {
    std::uint64_t quanta = 0;     // cumulative, per the instrument's unit
    double relative_error = 1.0;  // the instrument's one-number error (power-weighted, RMS, ...)
    // The per-pixel rule's statistic (e.g. the median relative error over lit pixels); NaN when
    // the instrument has none or the rule is off.
    double pixel_error = std::numeric_limits<double>::quiet_NaN();
};

// When to stop; checked after every pass (and on a resumed state before the first).
struct StopRule {
    int max_passes = 1;                // [1, ...]
    double target_error = -1.0;        // relative_error <= this: stop (< 0: off)
    double target_pixel_error = -1.0;  // pixel_error <= this: stop (<= 0: off)
    double time_budget_s = std::numeric_limits<double>::infinity();  // see below
    // false: stop once the last pass ended at or after the budget. true: stop when the next pass
    // would end after it, at the mean time per pass so far (a hard limit on the run's time).
    bool budget_holds_next_pass = false;
};

// One named sum of a measurement's state across passes, for its checkpoint
// (virtual_gonio/pass_checkpoint.h).
struct CheckpointSum {
    std::string name;
    std::vector<double>* values;  // sized for this run before a resume
};

class PassMeasurement {
public:
    virtual ~PassMeasurement() = default;
    // Prepares pass `pass` (0-based; its item slots, its streams) and returns its item count.
    virtual std::size_t start_pass(int pass) = 0;
    // Runs one item of the started pass; thread-safe, writing only that item's slot.
    virtual void run_item(std::size_t item) = 0;
    // Under MPI, an item's result to bytes on the rank that ran it and back on every rank.
    virtual void pack(std::size_t item, Bytes& out) const = 0;
    virtual void unpack(std::size_t item, Bytes& in) = 0;
    // Adds the finished pass's items to the sums, in item order.
    virtual void add_pass() = 0;
    // The estimate from the sums of `passes` passes (also after a resume).
    virtual PassEstimate estimate(int passes) = 0;
    // The sums a checkpoint keeps; empty: the measurement cannot be checkpointed.
    virtual std::vector<CheckpointSum> checkpoint_sums() { return {}; }
};

// What a checkpoint is made from (virtual_gonio/pass_checkpoint.h).
struct CheckpointPart {
    std::string what;   // for the user, e.g. "the content of the sample file 'plate.obj'"
    std::string value;  // compared as text: a content hash, a version
};

struct PassLoopControl {
    const std::atomic<bool>* interrupt = nullptr;  // polled between items
    std::string progress;    // non-empty: a progress line on stderr, starting with this
    std::string quanta_per;  // the progress line's unit ("direction", "pixel")
    std::size_t blocks_per_rank = 4;
    // Non-empty (and the measurement has checkpoint_sums): resumed from at the start when made
    // from `identity`, and written by rank 0 after every pass (pass_checkpoint.h).
    std::filesystem::path checkpoint;
    std::vector<CheckpointPart> identity;
    // After each pass, on every rank: after the checkpoint is written, after_pass (e.g. a record
    // of the pass so far), then the progress line, then on_pass with the pass's row.
    std::function<void()> after_pass;
    std::function<void(const ConvergenceRow&)> on_pass;
};

struct PassLoopState {
    int passes = 0;                    // completed passes (a resumed run: those of before)
    std::vector<ConvergenceRow> rows;  // one per completed pass
    PassEstimate estimate;             // after the last completed pass
    bool interrupted = false;          // stopped by Ctrl-C; the unfinished pass added nothing
    bool resumed = false;              // from a checkpoint, whose clocks follow
    double resumed_wall_s = 0.0, resumed_cpu_s = 0.0;
};

// Runs passes from a fresh `state`, or from the control's checkpoint when it resumes, until the
// rule holds or Ctrl-C. `elapsed_s` gives the wall time since this run of the measurement
// started; rows count from the first run's start (resumed_wall_s + elapsed_s()).
void run_passes(PassMeasurement& measurement, const StopRule& rule, const PassLoopControl& control,
                const std::function<double()>& elapsed_s, PassLoopState& state);

// Whether the rule holds after state's last pass (false before any pass).
bool stop_rule_holds(const StopRule& rule, const PassLoopState& state);

}  // namespace plumage::gonio
