// Fitting the Filip 2024 feather BRDF (analysis/models/filip2024.h) to BRDF data by nonlinear least
// squares: Levenberg–Marquardt (analysis/fits/least_squares.h) with the analytic Jacobian, the
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
//
// Global stage. Least squares is local, and this model's χ² has several minima: φa picks one
// of the patch's directions as the highlight axis, and the mask (w, d_w), β and γ trade lobes
// against each other. f is linear in the 13 colours and α, so for any shape (φa, w, d_w, β, γ)
// their best values are one linear solve. The fit tries a fixed grid of 192 shapes
//     φa ∈ {−75°, −45°, −15°, 15°, 45°, 75°} (φa is periodic in π),
//     (w, d_w) ∈ Table 1's four masks {(0.95, 0.40), (0.85, 0.20), (0.80, 0.40), (0.80, 0.60)},
//     β ∈ {5, 12},  γ ∈ {0.25, 0.75, 1.5, 4}
// (a fixed parameter keeps its start), solves each shape's colours and α (clamped to their
// ranges), and runs Levenberg–Marquardt from the caller's start and from the global_starts grid
// points of lowest χ²; the lowest χ² wins (start_chi_squares lists every run's). Deterministic:
// the grid and its order are fixed. Tested: 20 random parameter sets over the range of Table 1's
// four presets, blind starts, 2 % noise (tests/analysis/fit_recovery_test.cpp).
//
// Bounds (active set). The logistic map reaches a bound only at infinity, so a parameter whose
// optimum is on its bound (γ = 0 in three presets) creeps towards it and stops short, and the
// fit leaves a start at the truth. After the best run, each parameter within 1 % of its range
// from a bound is held on the bound and the rest refitted; that is kept when χ² does not rise
// (the optimum is on the bound), and the parameter is reported at_bound (its σ: NaN).
//
// Equivalent minima. D(0) + D(π) = 1/2 for every pair, so at γ = 1 the retro term
// C_r E D(π) F = C_r E F / 2 − C_r E D(0) F is the γ = 0 retro term plus a near-specular one:
// (γ = 0, C_r, C_s) and (γ = 1, 2 C_r, C_s + 2 C_r) are the same BRDF on any data (the rooster's
// Table 1 values have an exact twin). Such minima are reported in `undetermined`.
//
// A fit's quality in words (χ²/dof far above 1, parameters on bounds, no convergence) is
// analysis/fits/fit_summary.h's fit_warnings.
#pragma once

#include <array>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "analysis/models/filip2024.h"

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
    // Levenberg–Marquardt runs from the best grid points of the global stage (header), besides
    // the one from the start; 0: a local fit from the start alone. 0..192.
    int global_starts = 4;
    int max_function_evaluations = 4000;  // per Levenberg–Marquardt run
    double relative_tolerance = 1e-10;    // on the sum of squares and on the parameters
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
    double chi_square = 0.0;          // Σ r_k² at the optimum
    double reduced_chi_square = 0.0;  // s²
    int observations = 0;
    int degrees_of_freedom = 0;  // observations − free parameters
    int local_fits = 0;          // Levenberg–Marquardt runs (global stage and active set)
    std::vector<double> start_chi_squares;  // χ² at the end of each run from a start, in order
    // Parameters that another run's optimum, within Δχ² ≤ 1 of this one, puts over 3σ away:
    // the data do not decide them (e.g. γ = 0 against γ = 1 below). Indices, ascending.
    std::vector<int> undetermined;
    // Of the best run (and of its refit with parameters held on bounds, if kept).
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
