// Directional albedo of an explicit scene lit over one period cell: the fraction of the power
// arriving along wi that leaves upwards (z > 0), by Monte Carlo with its standard error, and
// the share of paths (and of the albedo) that met a surface from the side they did not travel
// in — a diagnostic of geometry that interpenetrates (sim/tracer.h, medium_mismatches).
#pragma once

#include <cstdint>

#include "sim/scatterer/period_cell_entry.h"
#include "sim/tracer.h"

namespace plumage::sim {

struct AlbedoEstimate {
    double albedo = 0.0;
    double standard_error = 0.0;     // of the mean of `quanta` independent paths
    double mismatched_paths = 0.0;   // fraction of paths with a medium mismatch
    double mismatched_albedo = 0.0;  // the upward weight those paths carry, per quantum
};

// `quanta` paths, path q on the stream (seed, q); entry points from `cell`. The sum runs over
// fixed chunks added in order, so the result does not depend on the thread count.
AlbedoEstimate measure_albedo(const ExplicitScatterer& tracer, const PeriodCellEntry& cell,
                              const Vec3d& wi, double lambda_nm, std::uint64_t quanta,
                              std::uint64_t seed);

}  // namespace plumage::sim
