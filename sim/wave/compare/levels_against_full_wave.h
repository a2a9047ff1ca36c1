// The cheaper 2D levels judged by full wave: physical optics (physical_optics_2d.h, its total
// field: reflection, shadow and edge diffraction) and ray optics + thin film
// (geometric_optics_2d.h) against a full-wave σ(θ_s) of the same cross-section (the suite's
// Meep level, sim/fullwave, or a committed reference of it), read through the same detector
// window. The full-wave curves enter as numbers: this floor does not run Meep.
//
// Per wavelength, unpolarised ((TE + TM)/2 of each level), at detector centres θ = −89°, …, 89°
// (1° apart, the back half-space for θ_i = 0; ray_optics_validity.h's centres):
//  - W_FW, W_PO, W_GO through the window (geometric_optics_2d.h `windowed`); FW and PO sampled
//    on the full-wave grid (uniform, 0.5° in the references), GO's rays as deltas;
//  - relative L1 of a level = Σ_θ |W_level − W_FW| / Σ_θ W_FW, and its power error
//    Σ_θ W_level / Σ_θ W_FW − 1;
//  - the full-wave level's own resolution error, the same L1 and power error between its coarse
//    and fine grids: a level's error below that is not resolved by the reference.
// The verdict: the cheapest level whose L1 over every wavelength is within the threshold (5 %),
// otherwise "full wave"; the reference's own resolution L1 is stated beside it (a level's error
// below that is not resolved by the reference).
//
// What the levels compared here leave out (state it with any verdict): PO and GO sample only
// the arc they are given, with a planar stack under each point; the full-wave body is closed
// (fullwave::barbule_row) and carries the gap and the melanin in 2D; neither cheaper level lets
// light through the film into the gap but via the stack's r.
#pragma once

#include <array>
#include <span>
#include <string>
#include <vector>

#include "sim/wave/surface/geometric_optics_2d.h"
#include "sim/wave/surface/physical_optics_2d.h"

namespace plumage::sim::wave {

// One wavelength's full-wave σ(θ_s), µm/rad, on a uniform increasing θ grid (rad): TE and TM at
// the fine and the coarse resolution.
struct FullWaveCurves2d {
    double lambda_nm = 0.0, theta_i_rad = 0.0;
    double coarse_px_per_um = 0.0, fine_px_per_um = 0.0;
    std::vector<double> theta_s_rad;
    std::array<std::vector<double>, 2> fine, coarse;  // [TE, TM]
};

struct LevelError2d {
    double relative_l1 = 0.0, power_error = 0.0;
};

struct LevelsAgainstFullWave2d {
    double lambda_nm = 0.0;
    LevelError2d physical_optics, ray_optics, full_wave_resolution;
};

struct FullWaveVerdict2d {
    std::vector<LevelsAgainstFullWave2d> wavelengths;
    double threshold = 0.05;
    // largest over wavelengths, and where
    double worst_po_l1 = 0.0, worst_go_l1 = 0.0, worst_resolution_l1 = 0.0;
    double worst_po_lambda_nm = 0.0, worst_go_lambda_nm = 0.0;
    std::string level;  // "ray optics + thin film", "physical optics" or "full wave"
};

// InputError when a curve is empty, not uniform, or its sizes disagree. `step_um`: the PO/GO
// sampling step's upper bound below λ/10 (a barbule's smallest radius of curvature); 0: λ/10.
FullWaveVerdict2d judge_against_full_wave(const Row2d& row,
                                          std::span<const FullWaveCurves2d> curves,
                                          const DetectorWindow& window = {},
                                          double threshold = 0.05, double step_um = 0.0);

// A periodic row judged by full wave through its reflectance R(λ): the fraction of the incident
// power that the row sends back into the upper half-space, all diffraction orders together
// (fullwave::full_wave_row), unpolarised. A periodic row's light leaves in discrete orders, so
// the reflectance, not a windowed pattern, is what the levels share.
//  - The cheaper levels' R of an endless row from two finite rows of the same cell: the reflected
//    power (widths, µm; ray_optics_validity.h's P_PO and P_GO) of N2 = 12 and N1 = 4 barbules,
//    R = (P(N2) − P(N1)) / ((N2 − N1) Λ cos θ_i): what the end barbules add (they are lit
//    without a neighbour's shadow) cancels in the difference, exactly for ray optics and up to
//    the ends' coherent diffraction for physical optics.
//  - Band means: the trapezoid rule over the reference's wavelengths, divided by the band.
//  - Error of a level: its band mean over full wave's, minus 1; the reference's own resolution
//    error is its coarse band mean over the fine one, minus 1 (a level's error below that is
//    not resolved).
// The verdict: the cheapest level within the threshold, otherwise "full wave".
//  - Optionally the GO–PO hybrid too (physical_optics_hybrid_2d.h), on rows of `hybrid_cell`
//    (the barbule with its gap as separate curves: barbule_with_gap, fullwave::barbule_row's
//    body), its reflected power ∫ σ dθ over the upper half-space (a midpoint rule at the step
//    ray_optics_validity.h's physical optics uses, 0.8π/(k r_max) and at most 0.25°), the ends
//    cancelled the same way. In cost it comes after physical optics.
struct RowReflectanceFullWave {
    double lambda_nm = 0.0;
    std::array<double, 2> fine{}, coarse{};  // R, [TE, TM]
};

struct RowVerdict2d {
    std::vector<double> lambda_nm;
    // unpolarised R per wavelength
    std::vector<double> full_wave, full_wave_coarse, physical_optics, ray_optics;
    std::vector<double> hybrid;  // the GO–PO hybrid's R; empty when it was not asked
    double band_full_wave = 0.0, band_full_wave_coarse = 0.0;
    double band_physical_optics = 0.0, band_ray_optics = 0.0, band_hybrid = 0.0;
    double po_error = 0.0, go_error = 0.0, resolution_error = 0.0;
    double hybrid_error = 0.0;  // 0 when not asked
    double threshold = 0.05;
    std::string level;
};

// `row`: the cell, spacing and tilt (its count is ignored); θ_i the reference's. InputError on an
// empty or unsorted reference. `hybrid_cell`: judge the GO–PO hybrid on rows of it too (its
// sampling step is min(step_um, λ/10)); nullptr: not.
RowVerdict2d judge_row_against_full_wave(const Row2d& row, double theta_i_rad,
                                         std::span<const RowReflectanceFullWave> reference,
                                         double threshold = 0.05, double step_um = 0.0,
                                         const CrossSection2d* hybrid_cell = nullptr);

// The GO–PO hybrid added to a verdict of that judge (its R, band mean, error, and the level
// re-chosen), on rows of `hybrid_cell` at sampling step min(step_um, λ/10). InputError (nothing
// changed) where the hybrid refuses the row, e.g. curves closer than the step.
void add_hybrid(RowVerdict2d& v, const Row2d& row, double theta_i_rad,
                const CrossSection2d& hybrid_cell, double step_um);

// The judge's rule: ray optics + thin film, physical optics, the GO–PO hybrid (where computed),
// the first within v.threshold in that order (of cost), else "full wave".
std::string cheapest_row_level(const RowVerdict2d& v);

}  // namespace plumage::sim::wave
