#include "sim/albedo.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

namespace plumage::sim {

AlbedoEstimate measure_albedo(const ExplicitScatterer& tracer, const PeriodCellEntry& cell,
                              const Vec3d& wi, double lambda_nm, std::uint64_t quanta,
                              std::uint64_t seed) {
    const auto n = static_cast<std::int64_t>(quanta);
    constexpr std::int64_t kChunk = 4096;
    const std::int64_t chunks = (n + kChunk - 1) / kChunk;
    // Per chunk: Σw, Σw², mismatched paths, their Σw.
    std::vector<std::array<double, 4>> partial(static_cast<std::size_t>(chunks),
                                               {0.0, 0.0, 0.0, 0.0});
#pragma omp parallel for schedule(dynamic, 1)
    for (std::int64_t c = 0; c < chunks; ++c) {
        auto& [sum, sum_sq, mismatched, mismatched_weight] = partial[static_cast<std::size_t>(c)];
        for (std::int64_t q = c * kChunk; q < std::min(n, (c + 1) * kChunk); ++q) {
            Rng rng(seed, static_cast<std::uint64_t>(q));
            const Vec2 entry = cell.draw_entry(rng);
            const PathResult path = tracer.trace(wi, lambda_nm, entry, rng);
            const double w = path.event && path.event->wo.z() > 0.0 ? path.event->weight : 0.0;
            sum += w;
            sum_sq += w * w;
            if (path.medium_mismatches > 0) {
                mismatched += 1.0;
                mismatched_weight += w;
            }
        }
    }
    double sum = 0.0, sum_sq = 0.0, mismatched = 0.0, mismatched_weight = 0.0;
    for (const auto& [c_sum, c_sum_sq, c_mismatched, c_mismatched_weight] : partial) {
        sum += c_sum;
        sum_sq += c_sum_sq;
        mismatched += c_mismatched;
        mismatched_weight += c_mismatched_weight;
    }
    const double count = static_cast<double>(n);
    AlbedoEstimate e;
    e.albedo = sum / count;
    e.standard_error = std::sqrt(std::max(0.0, sum_sq / count - e.albedo * e.albedo) / count);
    e.mismatched_paths = mismatched / count;
    e.mismatched_albedo = mismatched_weight / count;
    return e;
}

}  // namespace plumage::sim
