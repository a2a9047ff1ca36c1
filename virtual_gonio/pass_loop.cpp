#include "virtual_gonio/pass_loop.h"

#include <cmath>
#include <iostream>

#include <fmt/format.h>

#include "common/cpu_time.h"
#include "virtual_gonio/pass_checkpoint.h"

namespace plumage::gonio {

bool stop_rule_holds(const StopRule& rule, const PassLoopState& state) {
    if (state.passes >= rule.max_passes) return true;
    if (state.rows.empty()) return false;
    const PassEstimate& e = state.estimate;
    if (rule.target_error >= 0.0 && e.relative_error <= rule.target_error) return true;
    if (rule.target_pixel_error > 0.0 && e.pixel_error <= rule.target_pixel_error) return true;
    const double wall = state.rows.back().wall_time_s;
    if (!rule.budget_holds_next_pass) return wall >= rule.time_budget_s;
    return wall * (state.passes + 1) / state.passes > rule.time_budget_s;
}

namespace {

void print_progress(const PassLoopControl& control, const StopRule& rule,
                    const PassLoopState& state) {
    const ConvergenceRow& row = state.rows.back();
    std::string line = fmt::format(
        "\r  {}: pass {} of at most {}, {} quanta per {}, est. error "
        "{:.3g} %",
        control.progress, row.pass, rule.max_passes, row.quanta, control.quanta_per,
        100.0 * row.estimated_relative_rms_error);
    if (std::isfinite(state.estimate.pixel_error))
        line += fmt::format(", median pixel error {:.3g} %", 100.0 * state.estimate.pixel_error);
    std::cerr << line << fmt::format(", {:.1f} s   ", row.wall_time_s) << std::flush;
}

}  // namespace

void run_passes(PassMeasurement& measurement, const StopRule& rule, const PassLoopControl& control,
                const std::function<double()>& elapsed_s, PassLoopState& state) {
    const double cpu_start = process_cpu_seconds();
    const std::vector<CheckpointSum> sums =
        control.checkpoint.empty() ? std::vector<CheckpointSum>{} : measurement.checkpoint_sums();
    if (!sums.empty()) {
        CheckpointClocks clocks;
        if (resume_pass_checkpoint(control.checkpoint, control.identity, sums, clocks) &&
            clocks.passes > 0) {
            state.resumed = true;
            state.passes = clocks.passes;
            state.rows = std::move(clocks.rows);
            state.resumed_wall_s = clocks.wall_time_s;
            state.resumed_cpu_s = clocks.cpu_time_s;
            state.estimate = measurement.estimate(state.passes);
            if (!control.progress.empty()) {
                std::cerr << fmt::format("  {}: resuming after {} completed passes from {}\n",
                                         control.progress, state.passes,
                                         control.checkpoint.string());
            }
        }
    }
    distributed::ItemTransport transport;
    transport.pack = [&](std::size_t it, Bytes& out) { measurement.pack(it, out); };
    transport.unpack = [&](std::size_t it, Bytes& in) { measurement.unpack(it, in); };
    auto run = [&](std::size_t it) { measurement.run_item(it); };
    // Rank 0's clock decides for every rank (the passes are collective under MPI).
    while (!distributed::broadcast_flag(stop_rule_holds(rule, state))) {
        const std::size_t items = measurement.start_pass(state.passes);
        if (!distributed::run_items(items, run, transport, control.interrupt,
                                    control.blocks_per_rank)) {
            state.interrupted = true;  // the checkpoint, if any, holds the last completed pass
            break;
        }
        measurement.add_pass();
        ++state.passes;
        state.estimate = measurement.estimate(state.passes);
        state.rows.push_back({state.passes, state.resumed_wall_s + elapsed_s(),
                              state.estimate.quanta, state.estimate.relative_error});
        if (!sums.empty() && distributed::rank() == 0) {
            write_pass_checkpoint(control.checkpoint, control.identity, sums,
                                  {state.passes, state.rows, state.rows.back().wall_time_s,
                                   state.resumed_cpu_s + process_cpu_seconds() - cpu_start});
        }
        if (control.after_pass) control.after_pass();
        if (!control.progress.empty()) print_progress(control, rule, state);
        if (control.on_pass) control.on_pass(state.rows.back());
    }
    if (!control.progress.empty() && state.passes > 0) std::cerr << '\n';
}

}  // namespace plumage::gonio
