#include "sim/scatterer/period_cell_entry.h"

#include <fmt/format.h>

#include "common/error.h"

namespace plumage {

PeriodCellEntry::PeriodCellEntry(std::shared_ptr<const Scatterer> inner, double pitch_x_um,
                                 double period_y_um, double y0_um)
    : inner_(std::move(inner)), pitch_x_(pitch_x_um), period_y_(period_y_um), y0_(y0_um) {
    if (!inner_ || !(pitch_x_ > 0.0) || !(period_y_ > 0.0)) {
        throw InputError(
            fmt::format("period cell entry: pitch {} um and period {} um: expected a "
                        "scatterer and sides > 0",
                        pitch_x_um, period_y_um));
    }
}

std::optional<ScatterEvent> PeriodCellEntry::sample(const Vec3d& wi, double lambda_nm,
                                                    const Vec2& /*beam position*/, Rng& rng) const {
    return inner_->sample(wi, lambda_nm, draw_entry(rng), rng);
}

std::optional<SpectralScatterEvent> PeriodCellEntry::sample_spectral(
    const Vec3d& wi, std::span<const double> lambdas_nm, const Vec2& /*beam position*/, Rng& rng,
    std::span<double> weights) const {
    const Vec2 entry = draw_entry(rng);
    return inner_paths().sample_spectral(wi, lambdas_nm, entry, rng, weights);
}

std::size_t PeriodCellEntry::sample_spectral_branches(const Vec3d& wi,
                                                      std::span<const double> lambdas_nm,
                                                      const Vec2& /*beam position*/, Rng& rng,
                                                      const BranchOptions& options,
                                                      std::span<SpectralScatterEvent> events,
                                                      std::span<double> weights) const {
    const Vec2 entry = draw_entry(rng);
    return inner_paths().sample_spectral_branches(wi, lambdas_nm, entry, rng, options, events,
                                                  weights);
}

Vec2 PeriodCellEntry::draw_entry(Rng& rng) const {
    const double x = (rng.uniform() - 0.5) * pitch_x_;
    const double y = y0_ + (rng.uniform() - 0.5) * period_y_;
    return {x, y};
}

}  // namespace plumage
