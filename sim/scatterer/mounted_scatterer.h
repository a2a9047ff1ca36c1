// A sample mounted on the goniometer turned about its normal: the Scatterer of another
// Scatterer whose patch frame (sim/scatterer/scatterer.h: +x the barb axis) is rotated by an
// azimuth ψ about +z in the instrument's frame.
//
// Real captures place a feather at whatever azimuth it lies on the stage; Filip et al. 2024
// report its orientation only through the fitted anisotropy direction φa. A measurement of a
// mounted sample equals a measurement of the unmounted one with every direction (and the beam
// position) turned by −ψ:
//   f_mounted(ω_i, ω_o) = f(R(−ψ) ω_i, R(−ψ) ω_o),   R(α) the rotation by α about +z,
// and sampled directions and exit positions are turned back by +ψ. The rotation is exact in
// double precision up to round-off; no resampling, so the wrapped scatterer's statistics carry
// over unchanged (unbiased weights, same lobes).
//
// Shared paths and branches (sim/scatterer/scatterer.h) are forwarded the same way, and so are the
// instrument's detector cones of BranchOptions (instrument-frame axes, turned by −ψ like ω_i):
// a guide aimed at the unturned axes would stay unbiased but miss the detectors. The turned axes
// live on the stack for up to kStackAxes detectors (the 61 × 60 set has 60 per light
// direction), in a heap vector beyond: no allocation per quantum for the instruments' sets, and
// no scratch shared between calls, so mounts may nest (a mount of a mount).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "sim/scatterer/scatterer.h"

namespace plumage {

class MountedScatterer final : public Scatterer, public PathTracing {
public:
    // azimuth_rad: the angle from the instrument's +x to the sample's +x (barb axis), about
    // +z, counter-clockwise seen from above. InputError when not finite or `inner` is null.
    MountedScatterer(std::shared_ptr<const Scatterer> inner, double azimuth_rad);

    std::string name() const override { return inner_->name(); }
    const std::vector<std::string>& lobe_names() const override { return inner_->lobe_names(); }
    std::optional<ScatterEvent> sample(const Vec3d& wi, double lambda_nm, const Vec2& position_um,
                                       Rng& rng) const override;
    // Path tracing when the inner scatterer has it.
    const PathTracing* path_tracing() const override {
        return inner_->path_tracing() ? this : nullptr;
    }
    std::optional<SpectralScatterEvent> sample_spectral(const Vec3d& wi,
                                                        std::span<const double> lambdas_nm,
                                                        const Vec2& position_um, Rng& rng,
                                                        std::span<double> weights) const override;
    bool can_split_paths() const override { return inner_paths().can_split_paths(); }
    std::size_t sample_spectral_branches(const Vec3d& wi, std::span<const double> lambdas_nm,
                                         const Vec2& position_um, Rng& rng,
                                         const BranchOptions& options,
                                         std::span<SpectralScatterEvent> events,
                                         std::span<double> weights) const override;
    bool can_trace_adjoint() const override { return inner_paths().can_trace_adjoint(); }
    bool can_connect_lights() const override { return inner_paths().can_connect_lights(); }
    double depth_um() const override { return inner_paths().depth_um(); }
    // The lights turned by −ψ like ω_i; the connections' entry points turned back by +ψ.
    void trace_connected(const Vec3d& wo, std::span<const double> lambdas_nm,
                         const Vec2& position_um, Rng& rng, std::span<const Vec3d> lights,
                         LightConnectionSink& sink) const override;
    bool can_evaluate() const override { return inner_->can_evaluate(); }
    double eval(const Vec3d& wi, const Vec3d& wo, double lambda_nm,
                std::span<double> per_lobe = {}) const override;
    // The inner scatterer's lobes, apart when it evaluates them apart (the goniometer's
    // lobe-by-lobe cubature then refines a mounted model as it does the bare one).
    bool evaluates_lobes_apart() const override { return inner_->evaluates_lobes_apart(); }
    double eval_lobes(const Vec3d& wi, const Vec3d& wo, double lambda_nm, std::uint32_t wanted,
                      std::span<double> per_lobe) const override;
    double pdf(const Vec3d& wi, const Vec3d& wo, double lambda_nm) const override;

    // Detector axes turned on the stack up to this many (see above).
    static constexpr std::size_t kStackAxes = 128;

    double azimuth_rad() const { return azimuth_rad_; }
    const Scatterer& inner() const { return *inner_; }

private:
    // The inner scatterer's path tracing; InvariantError when it has none (path_tracing() then
    // says so, and no instrument calls the path methods).
    const PathTracing& inner_paths() const { return checked_path_tracing(*inner_); }
    Vec3d to_sample(const Vec3d& w) const;          // instrument → sample frame: R(−ψ)
    Vec3d to_instrument(const Vec3d& w) const;      // sample → instrument frame: R(+ψ)
    Vec2 to_sample(const Vec2& position_um) const;  // a beam position, R(−ψ)
    void to_instrument(Vec3d& wo, Vec2& exit_position_um) const;  // an event's, in place

    std::shared_ptr<const Scatterer> inner_;
    double azimuth_rad_;
    double cos_, sin_;
};

}  // namespace plumage
