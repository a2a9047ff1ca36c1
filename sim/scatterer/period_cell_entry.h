// A periodic sample under a wide, uniform beam: light enters uniformly over one period cell.
//
// A patch of barbs is periodic, with period P across the barbs (y) and the barbule pitch p
// along them (x). The BRDF of a beam much wider than P is the average over entry points in one
// period cell, so the light enters uniformly in the central cell instead of within a finite
// beam: a beam a few periods wide covers 1.3 or 1.7 periods depending on the light's elevation
// (its footprint stretches by 1/cos θi), and that partial coverage makes the measured BRDF of a
// striped sample depend on the geometry of the footprint — not reciprocal, not the sample's.
// Exit points stay where the light leaves (every exit is collected by the detector's cone).
// Directions are not touched: the wrapper goes inside MountedScatterer, in the sample's own
// frame. The beam position passed to sample() is ignored.
// Shared paths and branches (sim/scatterer/scatterer.h) are forwarded when the inner scatterer has
// them, each quantum's entry drawn exactly as in sample(): two uniforms from its stream, then the
// inner scatterer on the same stream.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "sim/scatterer/scatterer.h"

namespace plumage {

class PeriodCellEntry final : public Scatterer, public PathTracing {
public:
    // pitch_x_um, period_y_um > 0: the cell's sides; y0_um: its centre across the barbs.
    PeriodCellEntry(std::shared_ptr<const Scatterer> inner, double pitch_x_um, double period_y_um,
                    double y0_um);
    std::string name() const override { return inner_->name(); }
    const std::vector<std::string>& lobe_names() const override { return inner_->lobe_names(); }
    std::optional<ScatterEvent> sample(const Vec3d& wi, double lambda_nm,
                                       const Vec2& /*beam position*/, Rng& rng) const override;
    // Path tracing when the inner scatterer has it.
    const PathTracing* path_tracing() const override {
        return inner_->path_tracing() ? this : nullptr;
    }
    std::optional<SpectralScatterEvent> sample_spectral(const Vec3d& wi,
                                                        std::span<const double> lambdas_nm,
                                                        const Vec2& /*beam position*/, Rng& rng,
                                                        std::span<double> weights) const override;
    bool can_split_paths() const override { return inner_paths().can_split_paths(); }
    std::size_t sample_spectral_branches(const Vec3d& wi, std::span<const double> lambdas_nm,
                                         const Vec2& /*beam position*/, Rng& rng,
                                         const BranchOptions& options,
                                         std::span<SpectralScatterEvent> events,
                                         std::span<double> weights) const override;
    // An entry point uniform over the cell (two uniforms from rng).
    Vec2 draw_entry(Rng& rng) const;

private:
    // The inner scatterer's path tracing; InvariantError when it has none (path_tracing() then
    // says so, and no instrument calls the path methods).
    const PathTracing& inner_paths() const { return checked_path_tracing(*inner_); }
    std::shared_ptr<const Scatterer> inner_;
    double pitch_x_, period_y_, y0_;
};

}  // namespace plumage
