// Where geometric optics ends (issue 16): physical optics (physical_optics_2d.h) against
// geometric optics (geometric_optics_2d.h) for one 2D barbule row, read through the same
// detector window, with the noise floor of the row's jitter ensemble.
//
// Both levels share the approximation level (single bounce, the stack's r at the local angle,
// the same lit test, optionally the same outgoing visibility) and PO's reflected part is used (the
// shadow-forming wave is the missing unhindered light, not reflected light): their difference is
// diffraction alone. Unpolarised: (TE + TM)/2 of each, per realisation.
//
// Per incidence θ_i and wavelength λ:
//  - W_PO(θ), W_GO(θ): the ensemble means of the windowed readings (geometric_optics_2d.h:
//    `windowed`) at detector centres θ = −89°, −88°, …, 89° (output_step), the reflected
//    half-space; PO is sampled on a uniform grid of spacing δ = min(0.8 π/(k R_max), 0.25°)
//    (R_max: the largest |r'| of any realisation) covering the centres ± the window's support.
//    |U|² is band-limited to 2kR_max in θ, so the trapezoid rule integrates it against a smooth
//    window exactly once δ < 2π/(2kR_max + the window's own bandwidth); 0.8 leaves that room
//    for the Gaussian window (σ ≈ 2.9°: bandwidth ~ 4/σ ≈ 80 ≪ 2kR_max ≈ 600 for 20 µm rows).
//  - relative L1 = Σ_θ |W_PO − W_GO| / Σ_θ W_PO.
//  - its noise floor: the realisations are independent rows, so per centre the standard error
//    of the mean of the paired difference d_m = W_PO,m − W_GO,m over the M realisations is
//    s_θ = std_m(d_m)/√M, and a difference that is pure noise has mean |N(0, s_θ)| =
//    sqrt(2/π) s_θ: floor = sqrt(2/π) Σ_θ s_θ / Σ_θ W_PO (the house's half-normal form, as
//    analysis/metrics/compare.h's relative-L1 floor). A row without jitter is deterministic: floor
//    0.
//  - total reflected power into the half-space |θ_s| < 90°: P_PO = Σ σ_j δ over grid points
//    there, P_GO = Σ p over rays there; the error P_PO/P_GO − 1 with its standard error
//    std_m(P_PO,m − P_GO,m)/(√M P_GO).
// Aggregates: the largest L1 over wavelengths (per incidence and overall), reported with the
// floor of the same (θ_i, λ); the verdict compares that maximum with a threshold (5 %).
//
// Sampling step: min(λ/10, max_step_um); for a barbule row pass the arc's smallest radius of
// curvature (b²A at the tips; physical optics refuses a step above it, and small barbules have
// tips sharper than λ/10: barbule_row_min_radius_um). Both levels then treat a stack on
// a curve of radius below the film thickness or λ as planar: outside PO's validity too (its
// header), so a "PO needed" verdict for such barbules means that ray optics fails, not that PO
// holds.
//
// Cost: each level is timed on its own (wall and process CPU, common/cpu_time.h). The lit test
// and the stack amplitudes (prepare_far_field, TE and TM) are computed once and their time is
// charged to both levels, as either alone would pay it; then PO's far-field sums (both
// polarisations in one pass, far_field_pair) and GO's rays. With outgoing visibility each level
// runs on its own (PO: far_field_integral per polarisation; GO: its rays' ray casts). The
// sampling, placement and windowing they share are charged to neither.
#pragma once

#include <span>
#include <vector>

#include "sim/wave/surface/geometric_optics_2d.h"
#include "sim/wave/surface/physical_optics_2d.h"

namespace plumage::sim::wave {

struct RayOpticsValidityOptions {
    DetectorWindow window;                                // 5° box by default
    double output_step_rad = 1.0 * 0.017453292519943295;  // detector centres' spacing
    bool outgoing_visibility = false;                     // both levels alike
    double threshold = 0.05;                              // the verdict's relative L1
    double max_step_um = 0.0;                             // 0: λ/10; else min(λ/10, this)
};

// One incidence and wavelength, unpolarised.
struct LevelComparison2d {
    double theta_i_rad = 0.0, lambda_nm = 0.0;
    std::vector<double> po, go;            // W_PO, W_GO at the detector centres, µm/rad
    std::vector<double> difference_error;  // s_θ, µm/rad
    double relative_l1 = 0.0, relative_l1_noise_floor = 0.0;
    double po_power_um = 0.0, go_power_um = 0.0;
    double power_error = 0.0, power_error_standard_error = 0.0;
    double step_um = 0.0;     // the sampling step used
    int grid_angles = 0;      // PO's θ grid
    std::size_t samples = 0;  // surface samples of one realisation
};

struct RayOpticsValidity2d {
    std::vector<double> theta_out_rad;     // detector centres
    std::vector<LevelComparison2d> cases;  // incidence-major, then wavelength
    int realisations = 1;                  // M (1 for an unjittered row)
    // Largest L1 over all cases, and the floor of that case.
    double max_relative_l1 = 0.0, max_relative_l1_noise_floor = 0.0;
    double max_abs_power_error = 0.0;
    std::size_t worst_case = 0;
    double po_wall_s = 0.0, po_cpu_s = 0.0, go_wall_s = 0.0, go_cpu_s = 0.0;
    bool ray_optics_suffices = false;  // max_relative_l1 <= threshold
};

// InputError (naming the value) on an empty or non-finite list, or whatever the levels refuse.
RayOpticsValidity2d compare_ray_and_physical_optics(const Row2d& row,
                                                    std::span<const double> lambda_nm,
                                                    std::span<const double> theta_i_rad,
                                                    const RayOpticsValidityOptions& options = {});

// The largest L1 over wavelengths at one incidence (index into theta_i_rad) and its floor.
struct L1WithFloor {
    double relative_l1 = 0.0, noise_floor = 0.0, lambda_nm = 0.0;
};
L1WithFloor worst_over_wavelengths(const RayOpticsValidity2d& v, std::size_t incidence,
                                   std::size_t wavelengths);

// The row of barbule cross-sections (barbule_arc) of Huang's cell (geometry/barbule.h): semi-
// major A, aspect b, normal azimuths [φ0, φ1], film d over an air gap g over melanin, spacing
// H·A along +x, every cell tilted by μ.
Row2d barbule_row_2d(double semi_major_um, double b, double phi0, double phi1, double film_um,
                     double gap_um, double H, double mu, int count);
// The smallest radius of curvature of that arc over [φ0, φ1], µm.
double barbule_row_min_radius_um(double semi_major_um, double b, double phi0, double phi1);

}  // namespace plumage::sim::wave
