#include "sim/scatterer/mounted_scatterer.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include "common/error.h"

namespace plumage {

MountedScatterer::MountedScatterer(std::shared_ptr<const Scatterer> inner, double azimuth_rad)
    : inner_(std::move(inner)), azimuth_rad_(azimuth_rad) {
    if (!inner_) throw InputError("MountedScatterer: no scatterer to mount");
    if (!std::isfinite(azimuth_rad)) {
        throw InputError("MountedScatterer: mount azimuth must be finite (rad)");
    }
    cos_ = std::cos(azimuth_rad);
    sin_ = std::sin(azimuth_rad);
}

Vec3d MountedScatterer::to_sample(const Vec3d& w) const {
    return {cos_ * w.x() + sin_ * w.y(), -sin_ * w.x() + cos_ * w.y(), w.z()};
}

Vec3d MountedScatterer::to_instrument(const Vec3d& w) const {
    return {cos_ * w.x() - sin_ * w.y(), sin_ * w.x() + cos_ * w.y(), w.z()};
}

Vec2 MountedScatterer::to_sample(const Vec2& position_um) const {
    const Vec3d p = to_sample(Vec3d(position_um.x(), position_um.y(), 0.0));
    return {p.x(), p.y()};
}

void MountedScatterer::to_instrument(Vec3d& wo, Vec2& exit_position_um) const {
    wo = to_instrument(wo);
    const Vec3d exit = to_instrument(Vec3d(exit_position_um.x(), exit_position_um.y(), 0.0));
    exit_position_um = Vec2(exit.x(), exit.y());
}

std::optional<ScatterEvent> MountedScatterer::sample(const Vec3d& wi, double lambda_nm,
                                                     const Vec2& position_um, Rng& rng) const {
    auto event = inner_->sample(to_sample(wi), lambda_nm, to_sample(position_um), rng);
    if (event) to_instrument(event->wo, event->exit_position_um);
    return event;
}

std::optional<SpectralScatterEvent> MountedScatterer::sample_spectral(
    const Vec3d& wi, std::span<const double> lambdas_nm, const Vec2& position_um, Rng& rng,
    std::span<double> weights) const {
    auto event = inner_paths().sample_spectral(to_sample(wi), lambdas_nm, to_sample(position_um),
                                               rng, weights);
    if (event) to_instrument(event->wo, event->exit_position_um);
    return event;
}

namespace {

// Directions turned into the sample's frame (the instrument's detector axes or lights): on the
// stack for the instruments' sets, on the heap beyond (sim/scatterer/mounted_scatterer.h); each
// call its own, so nested mounts do not share.
class TurnedDirections {
public:
    template <class Turn>
    TurnedDirections(std::span<const Vec3d> directions, Turn turn)
        : turned_(on_stack_.data(), std::min(directions.size(), MountedScatterer::kStackAxes)) {
        if (directions.size() > MountedScatterer::kStackAxes) {
            on_heap_.resize(directions.size());
            turned_ = on_heap_;
        }
        for (std::size_t a = 0; a < directions.size(); ++a) turned_[a] = turn(directions[a]);
    }
    std::span<const Vec3d> span() const { return turned_; }

private:
    std::array<Vec3d, MountedScatterer::kStackAxes> on_stack_;
    std::vector<Vec3d> on_heap_;
    std::span<Vec3d> turned_;
};

}  // namespace

std::size_t MountedScatterer::sample_spectral_branches(const Vec3d& wi,
                                                       std::span<const double> lambdas_nm,
                                                       const Vec2& position_um, Rng& rng,
                                                       const BranchOptions& options,
                                                       std::span<SpectralScatterEvent> events,
                                                       std::span<double> weights) const {
    const TurnedDirections turned(options.detector_axes,
                                  [this](const Vec3d& a) { return to_sample(a); });
    BranchOptions inner_options = options;
    inner_options.detector_axes = turned.span();
    const std::size_t count = inner_paths().sample_spectral_branches(
        to_sample(wi), lambdas_nm, to_sample(position_um), rng, inner_options, events, weights);
    for (std::size_t b = 0; b < count; ++b) to_instrument(events[b].wo, events[b].exit_position_um);
    return count;
}

namespace {

// The inner scatterer's connections with their entry points turned back to the instrument.
class TurnedSink final : public LightConnectionSink {
public:
    TurnedSink(LightConnectionSink& outer, double cos, double sin)
        : outer_(outer), cos_(cos), sin_(sin) {}
    bool accepts(std::size_t light, const Vec2& entry_position_um) const override {
        return outer_.accepts(light, turn(entry_position_um));
    }
    void connect(const LightConnection& c) override {
        LightConnection turned = c;
        turned.entry_position_um = turn(c.entry_position_um);
        outer_.connect(turned);
    }

private:
    Vec2 turn(const Vec2& p) const {
        return {cos_ * p.x() - sin_ * p.y(), sin_ * p.x() + cos_ * p.y()};
    }

    LightConnectionSink& outer_;
    double cos_, sin_;
};

}  // namespace

void MountedScatterer::trace_connected(const Vec3d& wo, std::span<const double> lambdas_nm,
                                       const Vec2& position_um, Rng& rng,
                                       std::span<const Vec3d> lights,
                                       LightConnectionSink& sink) const {
    // The lights in the sample's frame, as the detector axes of sample_spectral_branches().
    const TurnedDirections turned(lights, [this](const Vec3d& l) { return to_sample(l); });
    TurnedSink turned_sink(sink, cos_, sin_);
    inner_paths().trace_connected(to_sample(wo), lambdas_nm, to_sample(position_um), rng,
                                  turned.span(), turned_sink);
}

double MountedScatterer::eval(const Vec3d& wi, const Vec3d& wo, double lambda_nm,
                              std::span<double> per_lobe) const {
    return inner_->eval(to_sample(wi), to_sample(wo), lambda_nm, per_lobe);
}

double MountedScatterer::eval_lobes(const Vec3d& wi, const Vec3d& wo, double lambda_nm,
                                    std::uint32_t wanted, std::span<double> per_lobe) const {
    return inner_->eval_lobes(to_sample(wi), to_sample(wo), lambda_nm, wanted, per_lobe);
}

double MountedScatterer::pdf(const Vec3d& wi, const Vec3d& wo, double lambda_nm) const {
    return inner_->pdf(to_sample(wi), to_sample(wo), lambda_nm);
}

}  // namespace plumage
