#include "sim/scatterer.h"

#include "common/error.h"

namespace plumage {

double Scatterer::eval(const Vec3d&, const Vec3d&, double, std::span<double>) const {
    throw InvariantError(
        name() +
        " cannot evaluate f(wi, wo): it is a Monte Carlo scatterer (check can_evaluate())");
}

std::optional<SpectralScatterEvent> Scatterer::sample_spectral(const Vec3d&,
                                                               std::span<const double>, const Vec2&,
                                                               Rng&, std::span<double>) const {
    throw InvariantError(
        name() + " cannot trace one path for several wavelengths (check can_share_paths())");
}

double Scatterer::pdf(const Vec3d&, const Vec3d&, double) const {
    throw InvariantError(name() + " has no sampling density (check can_evaluate())");
}

}  // namespace plumage
