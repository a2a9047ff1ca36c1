// Fitting the Filip 2024 feather BRDF (analysis/filip2024.h) to BRDF data by nonlinear least
// squares: Levenberg–Marquardt (analysis/least_squares.h) with the analytic Jacobian, the
// residuals and normal equations evaluated on every OpenMP thread and summed in a fixed order,
// so that a fit has the same bits for any thread count. Observations of the same direction pair
// (consecutive in `data`, as a spectral record lists them) share the channel-independent part of
// f and of its gradient.
//
// The problem: minimise Σ_k r_k², r_k = (f(ωi_k, ωo_k, channel_k; p) − value_k) / σ_k, with σ_k the
// observation's standard error when the data give them (all observations or none), else 1.
//
// Bounds: every parameter except φa is optimised through a logistic map onto its valid range
// (kFilip2024ParameterTable), p = min + (max − min) / (1 + e^−u), so no step can leave it. A
// starting value on a bound is moved 1e-9 of the range inside (the map reaches bounds only at
// infinity). φa is periodic (|H·U| does not change under φa → φa + π): it is optimised freely
// and reported in (−π/2, π/2].
//
// Uncertainties, from the Jacobian J of the r_k with respect to the free parameters (in their own
// units, not the logistic variables) at the optimum: covariance = s² (JᵀJ)⁻¹ with
// s² = Σ r_k² / (n − p), the reduced chi-square (≈ 1 when the σ_k are right and the model holds).
// This is the usual linearisation: it is meaningless for a parameter sitting on a bound
// (at_bound) and it is not computed when JᵀJ is numerically singular (covariance_available:
// e.g. brdf_scale freed together with all colours and α, which it multiplies).
//
// By default θmax (a property of the data: the largest captured elevation) and brdf_scale
// (the units) are held fixed; all 18 shape and colour parameters are fitted.
#pragma once

#include <array>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "analysis/filip2024.h"

namespace plumage::analysis {

struct BrdfObservation {
    Vec3d wi;  // unit, towards the light, wi.z > 0
    Vec3d wo;  // unit, towards the detector, wo.z > 0
    // Exactly one of the two: an RGB record (the paper's data) or a spectral one, which is
    // mapped to its channel by the bands of filip2024.h.
    std::optional<RgbChannel> channel;
    std::optional<double> lambda_nm;
    double value;                          // BRDF, 1/sr
    std::optional<double> standard_error;  // 1/sr, > 0
};

struct Filip2024FitOptions {
    // true: held at the starting value. Indexed by Filip2024ParameterIndex.
    std::array<bool, kFilip2024ParameterCount> fixed = [] {
        std::array<bool, kFilip2024ParameterCount> f{};
        f[kFilipThetaMax] = true;
        f[kFilipBrdfScale] = true;
        return f;
    }();
    int max_function_evaluations = 4000;
    double relative_tolerance = 1e-10;  // on the sum of squares and on the parameters
    // After every evaluation: the evaluations so far, χ² and the seconds since the fit started
    // (the command line prints progress from it); empty: silent.
    std::function<void(int evaluations, double chi_square, double elapsed_s)> progress;
};

struct Filip2024FitResult {
    Filip2024Parameters parameters;
    std::array<double, kFilip2024ParameterCount> values{};  // to_vector(parameters)
    // One standard error per parameter, same units; NaN for fixed ones and when the covariance
    // is not available.
    std::array<double, kFilip2024ParameterCount> standard_errors{};
    std::array<bool, kFilip2024ParameterCount> at_bound{};  // within 1e-6 of the range's edge
    std::vector<int> free_parameters;  // indices, in the order of covariance's rows
    Eigen::MatrixXd covariance;        // s² (JᵀJ)⁻¹ over free_parameters
    bool covariance_available = false;
    double residual_rms = 0.0;        // sqrt(mean (f − value)²), 1/sr, unweighted
    double reduced_chi_square = 0.0;  // s²
    int observations = 0;
    int degrees_of_freedom = 0;  // observations − free parameters
    int function_evaluations = 0;
    int jacobian_evaluations = 0;
    bool converged = false;
    std::string termination;  // the optimiser's stopping reason, in words
};

// Throws InputError for bad data (index and reason in the message), a start outside the valid
// ranges, or fewer observations than free parameters.
Filip2024FitResult fit_filip2024(std::span<const BrdfObservation> data,
                                 const Filip2024Parameters& start,
                                 const Filip2024FitOptions& options = {});

// f (1/sr) and its gradient with respect to every parameter of the table (table units; the
// gradient with respect to φa is taken where |H·U| is differentiable, i.e. H·U ≠ 0). Both
// directions above the patch.
double filip2024_value_and_gradient(const Filip2024Parameters& p, const Filip2024Geometry& g,
                                    RgbChannel channel,
                                    std::span<double, kFilip2024ParameterCount> gradient);

}  // namespace plumage::analysis
