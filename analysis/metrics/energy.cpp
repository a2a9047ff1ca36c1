#include "analysis/metrics/energy.h"

#include <array>
#include <cmath>
#include <numbers>
#include <vector>

#include <fmt/format.h>

#include "common/constants.h"
#include "common/error.h"

namespace plumage::analysis {
namespace {

// 3-point Gauss–Legendre on [−1, 1].
constexpr std::array<double, 3> kGaussNodes = {-0.7745966692414834, 0.0, 0.7745966692414834};
constexpr std::array<double, 3> kGaussWeights = {5.0 / 9.0, 8.0 / 9.0, 5.0 / 9.0};

// Quadrature nodes over both hemispheres: direction and weight, the weight including |cos θo|.
struct SphereNodes {
    std::vector<Vec3d> directions;
    std::vector<double> weights;
};

SphereNodes sphere_nodes(int polar_cells) {
    SphereNodes nodes;
    const int azimuth_cells = 2 * polar_cells;
    const double dz = 1.0 / polar_cells;
    const double dphi = kTwoPi / azimuth_cells;
    for (double sign : {1.0, -1.0}) {
        for (int iz = 0; iz < polar_cells; ++iz) {
            for (int gz = 0; gz < 3; ++gz) {
                const double mu = (iz + 0.5 + 0.5 * kGaussNodes[gz]) * dz;
                const double sin_theta = std::sqrt(std::max(0.0, 1.0 - mu * mu));
                for (int ip = 0; ip < azimuth_cells; ++ip) {
                    for (int gp = 0; gp < 3; ++gp) {
                        const double phi = (ip + 0.5 + 0.5 * kGaussNodes[gp]) * dphi;
                        nodes.directions.emplace_back(sin_theta * std::cos(phi),
                                                      sin_theta * std::sin(phi), sign * mu);
                        nodes.weights.push_back(0.25 * dz * dphi * kGaussWeights[gz] *
                                                kGaussWeights[gp] * mu);
                    }
                }
            }
        }
    }
    return nodes;
}

double integrate(const Scatterer& scatterer, const Vec3d& wi, double lambda_nm,
                 const SphereNodes& nodes) {
    double sum = 0.0;
    for (std::size_t k = 0; k < nodes.directions.size(); ++k) {
        sum += nodes.weights[k] * scatterer.eval(wi, nodes.directions[k], lambda_nm);
    }
    return sum;
}

// The albedo at two resolutions (fine, and half of it for the error estimate).
struct AlbedoQuadrature {
    SphereNodes fine, coarse;

    explicit AlbedoQuadrature(int polar_cells)
        : fine(sphere_nodes(polar_cells)), coarse(sphere_nodes(polar_cells / 2)) {}

    AlbedoEstimate operator()(const Scatterer& scatterer, const Vec3d& wi, double lambda) const {
        const double a = integrate(scatterer, wi, lambda, fine);
        return {a, std::abs(a - integrate(scatterer, wi, lambda, coarse))};
    }
};

void require_evaluable(const Scatterer& scatterer, int polar_cells) {
    if (polar_cells < 2) {
        throw InputError(
            fmt::format("albedo quadrature: polar_cells = {}: expected >= 2", polar_cells));
    }
    if (!scatterer.can_evaluate()) {
        throw InvariantError(scatterer.name() + " cannot evaluate f: no quadrature albedo");
    }
}

}  // namespace

AlbedoEstimate directional_albedo(const Scatterer& scatterer, const Vec3d& wi, double lambda_nm,
                                  int polar_cells) {
    require_evaluable(scatterer, polar_cells);
    return AlbedoQuadrature(polar_cells)(scatterer, wi, lambda_nm);
}

EnergyCheck check_energy(const Scatterer& scatterer, std::span<const Vec3d> incident,
                         std::span<const double> lambdas_nm, int polar_cells) {
    require_evaluable(scatterer, polar_cells);
    const AlbedoQuadrature quadrature(polar_cells);
    const std::size_t nl = lambdas_nm.size(), n = incident.size() * nl;
    std::vector<AlbedoEstimate> albedo(n, {0.0, 0.0});
#pragma omp parallel for schedule(dynamic, 1)
    for (std::size_t k = 0; k < n; ++k)
        albedo[k] = quadrature(scatterer, incident[k / nl], lambdas_nm[k % nl]);
    EnergyCheck check;
    check.directions = static_cast<int>(incident.size());
    for (std::size_t d = 0; d < incident.size(); ++d) {
        bool above = false;
        for (std::size_t l = 0; l < nl; ++l) {
            const AlbedoEstimate& a = albedo[d * nl + l];
            above = above || a.value - a.error_estimate > 1.0;
            if ((d == 0 && l == 0) || a.value > check.max_albedo) {
                check.max_albedo = a.value;
                check.error_estimate = a.error_estimate;
                check.worst_wi = incident[d];
                check.worst_lambda_nm = lambdas_nm[l];
            }
        }
        check.directions_above_one += above ? 1 : 0;
    }
    return check;
}

std::vector<Vec3d> hemisphere_grid(double polar_step_rad, double max_polar_rad,
                                   double azimuth_step_rad) {
    if (!(polar_step_rad > 0.0) || !(azimuth_step_rad > 0.0) || !(max_polar_rad >= 0.0) ||
        !(max_polar_rad < std::numbers::pi / 2)) {
        throw InputError(fmt::format(
            "hemisphere_grid: steps {} and {} rad, max polar {} rad: expected positive steps and "
            "a max polar angle in [0, π/2)",
            polar_step_rad, azimuth_step_rad, max_polar_rad));
    }
    std::vector<Vec3d> directions{Vec3d::UnitZ()};
    for (int i = 1; i * polar_step_rad <= max_polar_rad * (1.0 + 1e-12); ++i) {
        const double theta = i * polar_step_rad;
        for (int j = 0; j * azimuth_step_rad < kTwoPi * (1.0 - 1e-12); ++j) {
            const double phi = j * azimuth_step_rad;
            directions.emplace_back(std::sin(theta) * std::cos(phi),
                                    std::sin(theta) * std::sin(phi), std::cos(theta));
        }
    }
    return directions;
}

}  // namespace plumage::analysis
