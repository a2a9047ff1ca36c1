#include "sim/scatterer/scatterer.h"

#include "common/error.h"

namespace plumage {

double Scatterer::eval(const Vec3d&, const Vec3d&, double, std::span<double>) const {
    throw InvariantError(
        name() +
        " cannot evaluate f(wi, wo): it is a Monte Carlo scatterer (check can_evaluate())");
}

double Scatterer::eval_lobes(const Vec3d& wi, const Vec3d& wo, double lambda_nm,
                             std::uint32_t wanted, std::span<double> per_lobe) const {
    eval(wi, wo, lambda_nm, per_lobe);
    double sum = 0.0;
    for (std::size_t k = 0; k < per_lobe.size(); ++k)
        if ((wanted >> k) & 1u) sum += per_lobe[k];
    return sum;
}

std::size_t PathTracing::sample_spectral_branches(
    const Vec3d& wi, std::span<const double> lambdas_nm, const Vec2& position_um, Rng& rng,
    const BranchOptions&, std::span<SpectralScatterEvent> events, std::span<double> weights) const {
    const std::size_t n = lambdas_nm.size();
    PLUMAGE_CHECK(!events.empty() && weights.size() >= n,
                  "sample_spectral_branches: room for one branch at least");
    const auto event = sample_spectral(wi, lambdas_nm, position_um, rng, weights.first(n));
    if (!event) return 0;
    events[0] = *event;
    return 1;
}

void PathTracing::trace_connected(const Vec3d&, std::span<const double>, const Vec2&, Rng&,
                                  std::span<const Vec3d>, LightConnectionSink&) const {
    throw InvariantError("this scatterer cannot connect to lights (check can_connect_lights())");
}

const PathTracing& checked_path_tracing(const Scatterer& scatterer) {
    const PathTracing* paths = scatterer.path_tracing();
    if (paths == nullptr) {
        throw InvariantError(scatterer.name() +
                             " traces no paths: no shared wavelengths, branches or detector-side "
                             "walks (check path_tracing())");
    }
    return *paths;
}

double Scatterer::pdf(const Vec3d&, const Vec3d&, double) const {
    throw InvariantError(name() + " has no sampling density (check can_evaluate())");
}

}  // namespace plumage
