// Fitting the parameters of Huang et al. 2022's barbule BSDF (analysis/models/huang2022.h) to a
// scatterogram (virtual_gonio/scatterometer.h) by nonlinear least squares: Levenberg–Marquardt
// (MINPACK's lmder, Eigen's unsupported NonLinearOptimization module)
// with a central finite-difference Jacobian.
//
// The prediction of a pixel is the quantity the scatterometer measures, the pixel's radiant
// intensity per unit incident power,
//   I_pixel = (1/Ω_pixel) ∫_pixel mean_{ω_i} [f(ω_i, ω_o) cos θ_o] dω_o,
// f = Huang2022Bsdf::eval (R + TRT; the T lobe leaves below the patch and is not imaged), Ω_pixel
// the record's solid_angle_sr; eval, not sampling, so the objective is deterministic.
//  - Illumination: beam (ω_i = beam_direction, exact); cone and hemisphere by a fixed product
//    quadrature of the scatterometer's illumination density (uniform over a disc of radius
//    sin(aperture/2), resp. 1, across the cone's axis, resp. the normal): Gauss–Legendre in the
//    disc's area fraction × midpoint in azimuth (illumination_nodes_*). The R lobe is narrow, so
//    a coarse quadrature of a broad illumination is a sum of separate bands: raise the node counts
//    until the prediction stops changing. Tested: a 2° cone against the beam (power within
//    0.1 %); broad cones and the hemisphere are not checked against measurements.
//  - Pixel cubature. The R lobe is a band 2·2θ_d wide (≈ 18°, 4 pixels of a 41-pixel image) with
//    hard edges (the NDF's θ_d box, the visibility ends of the arc), and inside it R is ~30 times
//    the TRT background: a pixel's value is not its centre's (25–73 % off at the band's edges
//    and corner, see the test), and a fixed n × n rule converges slowly (8 × 8 midpoints are
//    still up to 10 % off where an edge runs along the pixel rows). Instead, per residual
//    evaluation and illumination node:
//    (1) every pixel centre is evaluated at the first fitted wavelength, which also tells whether
//    R is non-zero there (its support is geometric, the same at every wavelength);
//    (2) a pixel whose centre differs in R-support from one of its 8 neighbours' (every support
//    edge lies between two such centres) is an edge pixel; the others are integrated by their
//    centre (error O(h² f''), well below the noise);
//    (3) an edge pixel: R's support at edge_lines × edge_lines nodes of its square (corners
//    included); lines along the direction with more support changes, each cut where the support
//    changes (located by edge_bisections bisection steps) into segments integrated by their
//    midpoint; composite Simpson across the lines, or, where the support also changes across them
//    (a corner of the band), the across range is cut too and each piece gets 2-point Gauss lines.
//    With 12 bisections an edge is placed to 1e-4 pixel, so the objective is continuous in the
//    parameters for all practical purposes (6 bisections left χ² steps of ~5 along the H–μ
//    valley, from the band's corners, where R is 12 times the pixel's mean).
//    Limitation: an R band narrower than a pixel can fall between pixel centres and be missed.
//
// The problem: minimise Σ_k r_k², r_k = (I_k(p) − data_k) / σ_k over the observations k =
// (pixel, wavelength) with signal: intensity > 0 and standard_error ≤ max_relative_error ×
// intensity (photon-counting errors are unreliable below ~16 counts), at the chosen wavelengths,
// on the pixels with (row + column) % pixel_stride == 0 (every row and column keeps pixels)
// whose square lies inside the disc (a rim pixel's value depends on the part of its square the
// disc covers, which its centre-Jacobian Ω does not describe). σ_k² = standard_error_k² +
// (relative_error_floor · data_k)²: the floor (default 1 %) stands for what the forward model
// does not reproduce exactly, so that a bright pixel's few-thousand counts do not outweigh the
// model's own accuracy. Pixels without signal are left out: a model lobe where the data have
// none is not penalised there (with the model's diffuse TRT nearly every pixel has signal).
//
// Parameters and bounds (the model's valid ranges), through maps u → p so that no step can leave
// them:
//   b ∈ [1e-3, 1], d_um ∈ [0, 50], θ_d ∈ (0, π/4], μ ∈ (−π/2, π/2): logistic onto the range;
//   H > 0: H = e^u;
//   φ0, φ1: through φ0 and the arc's width w = φ1 − φ0 ∈ (0, 2π] (logistic); with one of them
//   fixed, the other is the fixed one ± w.
// A starting value on a bound is moved 1e-9 of the range inside.
//
// Jacobian: central differences in u, step finite_difference_step (default 1e-3: 0.02–0.1 % of
// each parameter at the rock-dove values). Uncertainties: covariance_u = s² (J_uᵀ J_u)⁻¹ at the
// optimum, s² = Σ r_k² / (n − p) the reduced chi-square, mapped back by M = ∂p/∂u: covariance =
// M covariance_u Mᵀ. Usual linearisation: meaningless for a parameter at a bound (at_bound), not
// computed when J_uᵀ J_u is numerically singular (covariance_available = false).
//
// Identifiability. At the rock-dove parameters (H = 1.25 < the arc's width) each barbule's arc
// ends lie under its neighbours: φ0 and φ1 do not change the prediction at all (tested), so they
// must be fixed; free them only where the arcs' ends are seen (e.g. H = 2.5, φ1 = 1 rad, tested).
//
// Global stage. Levenberg–Marquardt is local: from 10 % off the rock-dove values it converged
// from each of three sign patterns tried, but 15 % off with H too high and μ too negative it
// ended in another minimum (H ≈ 2.5, reduced χ² ≈ 86), and in the seven-parameter geometry of
// the noiseless test 10 % off failed where 5 % off converges. The minima come from the film
// (thin-film orders: d and d ± λ/2n give similar colours) and from where the R band falls
// (μ, H). So before the local runs the fit evaluates χ² on a fixed grid of 75 points
//     d ∈ {0.3, 0.45, 0.6, 0.75, 0.9} µm × μ ∈ {−0.6, −0.3, 0, 0.3, 0.6} × H ∈ {1, 1.25, 1.5}
// (a fixed parameter keeps its start; b and θ_d keep theirs) and runs Levenberg–Marquardt from
// the caller's start and from the global_starts grid points of lowest χ²; the lowest χ² wins
// (start_chi_squares lists each run's). That alone recovered 16 of 20 random parameter sets
// (tests/analysis/fit_recovery_test.cpp); the other 4 ended in minima with χ²/dof 1.2–21 (H and
// μ far along their valley, or d one film order away), and a larger grid (294 points, b
// included) did no better: the R band's hard edges make χ² at a grid point a poor guide to its
// basin. So from the best optimum the fit then scans, the others held: d over 0.2–1.2 µm (21
// points), b over 0.1–0.6 (11), θ_d over 0.02–0.2 (10) and (H, μ) over [0.8, 2.6] × [−0.8, 0.8]
// together (90); a scanned point more than 1 below the optimum's χ² starts another local run,
// kept when it ends lower (at most three rounds). With it: 20 of 20. A fit that still ends in a
// local minimum has χ² above what the data's σ allow, which analysis/fits/fit_summary.h's
// fit_warnings reports.
//
// Defaults: all seven parameters free (b, phi0, phi1, H, d_um, theta_d, mu).
// Cost: one residual evaluation is ~ (disc pixels + used pixels × (wavelengths − 1) + edge
// pixels × ~40) × illumination nodes calls of eval (~30 µs each); a local run is ~10 Jacobians
// of 2 × (free parameters) evaluations; a whole fit is the grid's 75 evaluations, 1 +
// global_starts local runs, and per round of scans ~130 evaluations and one more local run
// (global_starts = 0: one local run, nothing else). Evaluations are parallel over pixels (OpenMP;
// the model's frame cache is per thread), and the result does not depend on the thread count.
#pragma once

#include <array>
#include <cstddef>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "analysis/models/huang2022.h"
#include "virtual_gonio/scatterometer.h"

namespace plumage::analysis {

enum Huang2022ParameterIndex : int {
    kHuangB = 0,
    kHuangPhi0,
    kHuangPhi1,
    kHuangH,
    kHuangD,
    kHuangThetaD,
    kHuangMu,
};
inline constexpr int kHuang2022ParameterCount = 7;
// Names as in Huang2022Params (and in HuangFitOptions::fixed), indexed by Huang2022ParameterIndex.
inline constexpr std::array<std::string_view, kHuang2022ParameterCount> kHuang2022ParameterNames =
    [] {
        std::array<std::string_view, kHuang2022ParameterCount> names{};
        for (int i = 0; i < kHuang2022ParameterCount; ++i)
            names[i] = kHuang2022ParameterTable[i].name;  // analysis/models/huang2022.h
        return names;
    }();
static_assert(kHuang2022ParameterTable.size() == kHuang2022ParameterCount);

std::array<double, kHuang2022ParameterCount> huang2022_values(const Huang2022Params& p);
Huang2022Params huang2022_params(const std::array<double, kHuang2022ParameterCount>& values);

// What a fit has done so far (HuangFitOptions::progress): after each residual evaluation, and
// from inside one (within_evaluation: between illumination directions and between pixels;
// evaluations then counts the finished ones and chi_square is 0).
struct HuangFitProgress {
    bool within_evaluation = false;
    std::size_t directions_done = 0;  // of the evaluation under way
    int evaluations = 0;              // residual evaluations so far, finite differences included
    int max_evaluations = 0;          // the fit stops at this many
    int free_parameters = 0;          // an iteration costs about 2 × this + 1 evaluations
    std::size_t observations = 0, pixels = 0, illumination_directions = 0;
    double elapsed_s = 0.0;   // wall time since the fit started
    double chi_square = 0.0;  // of the evaluation just made
};

struct HuangFitOptions {
    // Parameters held at their starting value, by name (kHuang2022ParameterNames); an unknown
    // name is an InputError naming it.
    std::vector<std::string> fixed;
    // Wavelengths fitted: empty = all of the record's; else each must be one of them (±1e-6 nm).
    std::vector<double> wavelengths_nm;
    // Pixel cubature (see the header's comment): support nodes and lines per side of an edge
    // pixel (odd, 3..15) and bisection steps locating R's support along a line (0..30).
    int edge_lines = 3;
    int edge_bisections = 12;
    int pixel_stride = 1;              // pixels with (row + column) % pixel_stride == 0, 1..64
    double max_relative_error = 0.25;  // signal: standard_error ≤ this × intensity, > 0
    // Also fit every pixel that is not signal but has a standard error > 0, zero and negative
    // intensities included (background-subtracted measurements, whose σ are known); σ² = se² +
    // (floor · max(intensity, 0))². Off for photon-counted records, whose σ below ~16 counts are
    // unreliable.
    bool every_pixel_with_sigma = false;
    // Levenberg–Marquardt runs from the best points of the global stage's grid (header), besides
    // the one from the start; 0: a local fit from the start alone. 0..75.
    int global_starts = 3;
    double relative_error_floor = 0.01;  // σ² = se² + (floor · data)², >= 0
    // Cone and hemisphere illumination: Gauss–Legendre nodes in the area fraction × azimuths.
    int illumination_nodes_radial = 3;
    int illumination_nodes_azimuthal = 8;
    double finite_difference_step = 1e-3;  // in the optimiser's variables u, (0, 1]
    int max_function_evaluations = 400;    // residual evaluations, finite differences included
    double relative_tolerance = 1e-5;      // on the sum of squares and on the parameters
    int threads = 0;                       // OpenMP threads; 0: OpenMP's default
    // Called after every residual evaluation and, from the calling thread, often inside one
    // (the command line prints progress by time and the expected cost); empty: silent. The fit
    // polls Ctrl-C (common/interrupt.h) between the illumination directions of every evaluation and
    // throws Interrupted.
    std::function<void(const HuangFitProgress&)> progress;
};

struct HuangFitResult {
    Huang2022Params parameters;
    std::array<double, kHuang2022ParameterCount> values{};  // huang2022_values(parameters)
    // One standard error per parameter, same units; NaN for fixed ones and when the covariance
    // is not available.
    std::array<double, kHuang2022ParameterCount> standard_errors{};
    std::array<bool, kHuang2022ParameterCount> at_bound{};  // within 1e-6 of the range's edge
    std::vector<int> free_parameters;  // indices, in the order of covariance's rows
    Eigen::MatrixXd covariance;        // over free_parameters, the parameters' units
    bool covariance_available = false;
    double residual_rms = 0.0;        // sqrt(mean (I − data)²), 1/sr, unweighted
    double chi_square = 0.0;          // Σ r_k² at the optimum
    double reduced_chi_square = 0.0;  // s²
    int observations = 0;             // (pixel, wavelength) pairs
    int pixels = 0;                   // pixels with at least one observation
    std::vector<double> wavelengths_nm;
    int degrees_of_freedom = 0;  // observations − free parameters
    int local_fits = 1;          // Levenberg–Marquardt runs (global stage: several starts)
    std::vector<double> start_chi_squares;  // χ² at the end of each run, in order of the starts
    int iterations = 0;                     // Levenberg–Marquardt iterations (one Jacobian each)
    // Residual evaluations of every run: finite differences and the covariance's Jacobian
    // included (the global stage's grid is not counted).
    int function_evaluations = 0;
    bool converged = false;
    std::string termination;  // the optimiser's stopping reason, in words
    double wall_time_s = 0.0;
};

// Throws InputError for bad data (empty, sizes that do not match the image and wavelengths,
// non-finite or negative values), an unknown fixed parameter, a wavelength not in the record,
// bad options, a start outside the valid ranges, or fewer observations than free parameters.
HuangFitResult fit_huang2022(const gonio::Scatterogram& data, const Huang2022Params& start,
                             const HuangFitOptions& options = {});

// Σ r_k², the sum that fit_huang2022 minimises, at the given parameters (the same observations,
// weights and cubature). Compare a fit's optimum with the truth's value in recovery tests.
double huang2022_fit_chi_square(const gonio::Scatterogram& data, const Huang2022Params& params,
                                const HuangFitOptions& options = {});

// The model's scatterogram under `config` (illumination, image size, wavelengths) by the fit's
// forward model (edge_lines, edge_bisections, illumination_nodes_*, threads of `options`; pixels
// across the rim are integrated as edge pixels): intensity and solid_angle_sr as
// measure_scatterogram fills them; standard errors 0, no lobes, no quanta.
gonio::Scatterogram huang2022_scatterogram(const Huang2022Params& params,
                                           const gonio::ScatterometerConfig& config,
                                           const HuangFitOptions& options = {});

}  // namespace plumage::analysis
