// The wave-validity study (`study = "wave_validity"`, issue 16): where ray optics + thin film
// (geometric optics, GO) stops describing a barbule row and physical optics (PO, diffraction) is
// needed, as maps over the barbule width 2A against film thickness d, cross-section aspect b
// (curvature) and spacing H, the other parameters at the rock-dove values.
//
// Physics on the floor: sim/wave/compare/ray_optics_validity.h (PO's reflected part against GO's
// mirror rays on the same samples, lit test and stack, unpolarised, through the same detector
// window; relative L1 with the jitter ensemble's half-normal noise floor, total-power error, each
// level's wall and CPU time). This file reads, builds the rows, measures, compares and reports.
//
// Per map point (axis value v, width 2A): a row of `count` = max(min_count, ⌈min_length/(H A)⌉)
// barbule cross-sections (Huang's cell, barbule_row_2d) at spacing H·A, tilt μ, jittered per
// cell by σ_pos = jitter_position · H·A per coordinate and σ_rot = jitter_rotation, averaged
// over `realisations` rows; for each incidence the largest relative L1 over the wavelengths
// (stated in every output) with its floor, and the wavelength where it is largest.
//
// The 5 % boundary: for each incidence and axis value, the width above which every L1 of the
// sweep is <= the threshold, interpolated in log width between the last width above and the
// next below ("< smallest" when none is above, "> largest" when the largest is still above).
// Statistical verdict per point: "PO needed" when L1 − 2·floor > threshold, "GO suffices" when
// L1 + 2·floor <= threshold, else "undecided" (the floor is the L1 that noise alone would give).
//
// Full-wave check (optional, `[full_wave] reference = "<folder>"`, relative to the study file's
// folder; the Meep reference of tests/reference/barbule_2d, read by
// sim/wave/compare/full_wave_reference.h): per reference curve (shape, θ_i, λ; unpolarised (TE +
// TM)/2 where both polarisations exist) the map's metric (the same detector window, the same
// centres over the reflected half-space |θ_s| < 90°, relative L1) for GO vs Meep, PO vs Meep (PO's
// total part: Meep's σ is the scattered field, shadow-forming wave included) and PO vs GO (PO's
// reflected part, the map's own number), beside Meep's floor 2 × its 40/60 px/µm RMS difference
// (the larger of the polarisations; the 40 px/µm curves are not shipped, so not windowed) and
// the share of PO's shadow part in the window over the half-space (GO has none). The verdict
// says whether the map's PO − GO is a fair measure of ray optics' error (PO's own error against
// Meep well below it) or PO's error dominates.
//
// Spongy scenes (always; studies/wave_validity_spongy.h): each spongy-medium level (the sphere
// route, first Born, the strong-contrast forms) against the committed 3D full-wave reference,
// its cost measured in the run, and per structure the cheapest level within the tolerance.
//
// Outputs in <results>/<name>/: wave_validity.h5 (every number, units and descriptions,
// /provenance), wave_validity.csv, width_x_<axis>.png (via width_x_<axis>.h5, the figure's
// data), report.md. Study files: studies/wave_validity.toml (full, a few minutes),
// studies/wave_validity_quick.toml (seconds; the tests run it). Keys: studies/README.md.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "studies/wave_validity_spongy.h"

namespace plumage::studies {

struct WaveValidityPoint {
    double value = 0.0, width_um = 0.0;
    int count = 0;
    // Per incidence.
    std::vector<double> relative_l1, noise_floor, lambda_at_max_nm;
    std::vector<double> power_error, power_error_standard_error;  // at the L1's wavelength
    std::vector<std::string> verdict;
    double po_wall_s = 0.0, po_cpu_s = 0.0, go_wall_s = 0.0, go_cpu_s = 0.0;
};

struct WaveValidityMap {
    std::string axis;   // key: film_thickness_um, b, H
    std::string label;  // "film thickness d (µm)"
    std::vector<double> values;
    std::vector<WaveValidityPoint> points;  // value-major, then width
    // [incidence][value]: the 5 % boundary width (µm); 0 = below the smallest, +inf = above the
    // largest width of the sweep.
    std::vector<std::vector<double>> boundary_um;
    // [incidence][value]: where the boundary lies beyond the largest width, the width at which a
    // power law fitted to the L1 of the largest (up to 4) widths reaches the threshold (log–log
    // least squares; +inf when the L1 does not fall there); 0 when the boundary is inside.
    std::vector<std::vector<double>> extrapolated_um;
};

// One reference curve of the full-wave check (header), unpolarised where both exist.
struct WaveValidityFullWaveRow {
    std::string shape, polarisations;  // "single", "TE+TM"
    double theta_i_deg = 0.0, lambda_nm = 0.0;
    double width_um = 0.0;  // the shape's projected width at θ_i
    double go_vs_full_wave = 0.0, po_vs_full_wave = 0.0, po_vs_go = 0.0;  // relative L1
    double full_wave_floor = 0.0;  // 2 × Meep's 40/60 RMS relative difference
    double shadow_share = 0.0;     // Σ W_PO,shadow / Σ W_PO,total over the centres
};

// One scene of the map judged live by full wave (`[full_wave] live = true`; header above and
// studies/wave_validity_live.h): the endless periodic row of the scene's barbule (no jitter),
// its reflectance R(λ), all orders, unpolarised, by full wave on two grids, by physical optics
// and by ray optics + film.
struct WaveValidityLivePoint {
    std::string scene;        // the map points it stands for: "base" or "<axis> = <value>"
    std::string map_verdict;  // the map's PO − GO verdict there (its jittered rows)
    double width_um = 0.0, theta_i_deg = 0.0, period_um = 0.0;
    // "judged", "unconverged" (resolution error beyond the tolerance: no verdict),
    // "not afforded" (predicted beyond the budget left), "not a barbule" (the full-wave body
    // cannot be built: film and gap fill the cross-section), "refused" (a full-wave limit)
    std::string status, reason;
    double cell_runs = 0.0, fine_cells = 0.0;  // Σ cells over the runs; one fine run's grid
    double predicted_s = 0.0, seconds = 0.0, max_fit_index_error = 0.0;
    std::vector<double> lambda_nm, full_wave, full_wave_coarse, physical_optics, ray_optics;
    double band_full_wave = 0.0, resolution_error = 0.0;  // coarse band mean / fine's − 1
    double resolution_worst = 0.0;  // largest |R_coarse(λ)/R_fine(λ) − 1|: the per-λ floor
    double po_error = 0.0, go_error = 0.0;  // band mean / full wave's − 1
    double po_worst = 0.0, go_worst = 0.0;  // largest |R_level(λ)/R_FW(λ) − 1| over λ
    double po_worst_lambda_nm = 0.0, go_worst_lambda_nm = 0.0;
    // The GO–PO hybrid (sim/wave/surface/physical_optics_hybrid_2d.h) on the barbule with its
    // gap as separate curves: empty and hybrid_reason set when it refused the row.
    std::vector<double> hybrid;
    double hybrid_error = 0.0, hybrid_worst = 0.0, hybrid_worst_lambda_nm = 0.0;
    double hybrid_step_um = 0.0;  // its sampling step (λ/10 or the row's, halved where refused)
    std::string hybrid_reason;
    std::string level;  // judged: the cheapest level within the threshold, or "full wave"
};

struct WaveValidityResult {
    std::filesystem::path output_dir;
    std::vector<double> widths_um, wavelengths_nm, incidence_deg;
    std::vector<WaveValidityMap> maps;
    double threshold = 0.05;
    double max_noise_floor = 0.0;
    int po_needed = 0, go_suffices = 0, undecided = 0;
    double po_wall_s = 0.0, po_cpu_s = 0.0, go_wall_s = 0.0, go_cpu_s = 0.0;
    double wall_seconds = 0.0;
    std::vector<WaveValidityFullWaveRow> full_wave;  // empty without [full_wave]
    std::string full_wave_verdict;                   // the report's generated sentence(s)
    std::vector<WaveValidityLivePoint> live;         // empty unless [full_wave] live = true
    double live_seconds_per_cell_run = 0.0;          // the cost rate the budget used at the end
    std::string live_verdict;                        // the report's generated sentence(s)
    std::vector<SpongyScene> spongy;                 // spongy volumes' levels against 3D full wave
};

// InputError on any bad key or value (file:line:col), before anything is written.
WaveValidityResult run_wave_validity_study(const std::string& study_text,
                                           const std::filesystem::path& source_name,
                                           const std::filesystem::path& results_root,
                                           bool progress = true);
void check_wave_validity_study(const std::string& study_text,
                               const std::filesystem::path& source_name);

}  // namespace plumage::studies
