#include "sim/mounted_scatterer.h"

#include <cmath>

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

void MountedScatterer::to_instrument(Vec3d& wo, Vec2& exit_position_um) const {
    wo = to_instrument(wo);
    const Vec3d exit = to_instrument(Vec3d(exit_position_um.x(), exit_position_um.y(), 0.0));
    exit_position_um = Vec2(exit.x(), exit.y());
}

std::optional<ScatterEvent> MountedScatterer::sample(const Vec3d& wi, double lambda_nm,
                                                     const Vec2& position_um, Rng& rng) const {
    const Vec3d p = to_sample(Vec3d(position_um.x(), position_um.y(), 0.0));
    auto event = inner_->sample(to_sample(wi), lambda_nm, Vec2(p.x(), p.y()), rng);
    if (event) to_instrument(event->wo, event->exit_position_um);
    return event;
}

std::optional<SpectralScatterEvent> MountedScatterer::sample_spectral(
    const Vec3d& wi, std::span<const double> lambdas_nm, const Vec2& position_um, Rng& rng,
    std::span<double> weights) const {
    const Vec3d p = to_sample(Vec3d(position_um.x(), position_um.y(), 0.0));
    auto event =
        inner_->sample_spectral(to_sample(wi), lambdas_nm, Vec2(p.x(), p.y()), rng, weights);
    if (event) to_instrument(event->wo, event->exit_position_um);
    return event;
}

double MountedScatterer::eval(const Vec3d& wi, const Vec3d& wo, double lambda_nm,
                              std::span<double> per_lobe) const {
    return inner_->eval(to_sample(wi), to_sample(wo), lambda_nm, per_lobe);
}

double MountedScatterer::pdf(const Vec3d& wi, const Vec3d& wo, double lambda_nm) const {
    return inner_->pdf(to_sample(wi), to_sample(wo), lambda_nm);
}

}  // namespace plumage
