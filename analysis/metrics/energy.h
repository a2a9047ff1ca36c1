// Energy bookkeeping for any Scatterer that can evaluate f: the directional albedo
// a(ωi, λ) = ∫ f(ωi, ωo, λ) |cos θo| dωo over the whole sphere (reflection and transmission;
// discrete lobes such as an unhindered T lobe are not in f and not counted), by deterministic
// quadrature, and a check of a ≤ 1 over a set of incident directions and wavelengths.
//
// Quadrature: each hemisphere is split into cells uniform in cos θo (polar_cells) and φo
// (2 × polar_cells), with a 3 × 3 Gauss–Legendre rule per cell. Gauss nodes never sit on a cell
// edge, so an f that jumps at the patch plane (every BRDF) costs no accuracy there; kinks inside a
// cell (|H·U|, clamps) limit the error to O(h²). The error estimate is the change from half the
// resolution, |a(n) − a(n/2)|, which bounds an O(h²) error with a factor 3 to spare.
#pragma once

#include <span>
#include <vector>

#include "sim/scatterer/scatterer.h"

namespace plumage::analysis {

struct AlbedoEstimate {
    double value;           // a(ωi, λ), dimensionless
    double error_estimate;  // |a(n) − a(n/2)|
};

// Throws InvariantError when the scatterer cannot evaluate f (check can_evaluate()).
AlbedoEstimate directional_albedo(const Scatterer& scatterer, const Vec3d& wi, double lambda_nm,
                                  int polar_cells = 64);

struct EnergyCheck {
    double max_albedo = 0.0;      // largest a over the tested (ωi, λ)
    double error_estimate = 0.0;  // its quadrature error estimate
    Vec3d worst_wi = Vec3d::UnitZ();
    double worst_lambda_nm = 0.0;
    // The incident directions tested, and those where a > 1 beyond the quadrature error at any
    // of the wavelengths.
    int directions = 0, directions_above_one = 0;
    // a > 1 beyond the quadrature error: the scatterer creates energy at worst_wi.
    bool violates() const { return max_albedo - error_estimate > 1.0; }
};

// The largest directional albedo over every (ωi, λ) pair of the two lists; the pairs in parallel
// (OpenMP), the same result for any thread count.
EnergyCheck check_energy(const Scatterer& scatterer, std::span<const Vec3d> incident,
                         std::span<const double> lambdas_nm, int polar_cells = 64);

// Incident directions on a polar × azimuth grid of the upper hemisphere: polar angles
// 0, step, ... ≤ max_polar_rad, azimuths 0, step, ... < 2π (one direction at the pole).
std::vector<Vec3d> hemisphere_grid(double polar_step_rad, double max_polar_rad,
                                   double azimuth_step_rad);

}  // namespace plumage::analysis
