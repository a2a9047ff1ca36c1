#include "analysis/models/lambertian.h"

#include <cmath>
#include <numbers>

#include <fmt/format.h>

#include "common/error.h"

namespace plumage::analysis {

LambertianScatterer::LambertianScatterer(double albedo) : albedo_(albedo) {
    if (!std::isfinite(albedo) || albedo < 0.0 || albedo > 1.0) {
        throw InputError(
            fmt::format("lambertian: albedo = {}: expected a value in [0, 1]", albedo));
    }
}

const std::vector<std::string>& LambertianScatterer::lobe_names() const {
    static const std::vector<std::string> names = {"diffuse"};
    return names;
}

std::optional<ScatterEvent> LambertianScatterer::sample(const Vec3d&, double,
                                                        const Vec2& position_um, Rng& rng) const {
    const double r = std::sqrt(rng.uniform()), phi = 2.0 * std::numbers::pi * rng.uniform();
    const Vec3d wo(r * std::cos(phi), r * std::sin(phi), std::sqrt(std::max(0.0, 1.0 - r * r)));
    return ScatterEvent{wo, albedo_, 0, position_um};
}

double LambertianScatterer::eval(const Vec3d& wi, const Vec3d& wo, double,
                                 std::span<double> per_lobe) const {
    const double f = wi.z() > 0.0 && wo.z() > 0.0 ? albedo_ / std::numbers::pi : 0.0;
    if (!per_lobe.empty()) per_lobe[0] = f;
    return f;
}

double LambertianScatterer::pdf(const Vec3d&, const Vec3d& wo, double) const {
    return wo.z() > 0.0 ? wo.z() / std::numbers::pi : 0.0;
}

}  // namespace plumage::analysis
