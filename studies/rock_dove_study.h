// The rock-dove study (the main job): explicit rock-dove barbules, traced, against
// Huang et al. 2022's analytic model, measured by the same virtual instruments.
//
//  1. Scatterograms under a narrow beam, a 16° cone and hemispheric light, simulation
//     and model side by side with a difference image and per-lobe relative errors.
//  2. The 61 × 60 Filip BRDF of both, BRDF fingerprints, the per-lobe error table with
//     the worst cells, and the in-plane sweep as curves with error bars. When [level] chooses
//     physical optics (studies/level_choice.h), the same BRDF of the 2.5D physical-optics level
//     (sim/wave/surface/physical_optics_25d.h) on the study's barbule row, against the model and
//     beside the ray-traced one, and its beam scatterogram beside the ray-traced and model's.
//  3. Where the assumptions of the model hold exactly (R lobe only, cells short enough
//     that Eq. 7 is exact), simulation against model in standard errors.
//  4. Where and why the model departs: interreflection (the "multi" lobe), light passing
//     between barbules (T), the curved film of real-length cells (Eq. 7's coupling), each
//     measured (studies/rock_dove_departures.h): the grazing specular pairs run again with one
//     thing changed at a time, and TRT against the exit law of a Lambertian layer.
//  5. Error against run time: estimated and true error of the R lobe against wall time.
//  6. Error and time per measurement: each record's own error estimate, wall and CPU time.
//
// Everything goes to <results>/<name>/ (replaced atomically) with report.md on top.
// Study file keys: see studies/rock_dove.toml (the default study, embedded in the binary)
// and studies/rock_dove_quick.toml (seconds; used by the tests); studies/rock_dove_po_quick.toml
// adds the physical-optics BRDF.
#pragma once

#include <array>
#include <filesystem>
#include <string>
#include <vector>

#include "analysis/metrics/verdict.h"
#include "studies/rock_dove_departures.h"
#include "studies/study.h"

namespace plumage::studies {

// One measurement's verdict against the model (the report's opening table).
struct MeasurementVerdict {
    std::string measurement;
    analysis::AgreementVerdict verdict;
};

struct RockDoveResult {
    std::filesystem::path output_dir;
    double wall_seconds = 0.0;
    // Power-weighted relative L1 difference of the scatterograms (simulation vs model),
    // per illumination mode: beam, cone, hemisphere.
    std::vector<double> scatterogram_relative_l1;
    // R lobe where the model's assumptions hold: largest |sim − model| / σ over the
    // validation cells with signal, and the number of such cells.
    double validation_max_sigma = 0.0;
    int validation_cells = 0;
    double brdf_relative_l1 = 0.0;  // total BRDF, simulation against model
    // ΔE00 of the model's colours on the study's wavelengths against 1 nm, largest over pairs.
    double colour_quadrature_max_delta_e00 = 0.0;
    // Avian vision (UVS, VS): median RNL ΔS (JND) over BRDF pairs with signal, simulation
    // against model, and the median ΔS the standard errors alone give.
    std::array<double, 2> avian_median_delta_s{}, avian_median_noise_floor{};
    double fit_reduced_chi_square = 0.0;      // Huang fitted to a simulated beam scatterogram
    double simulated_multi_share = 0.0;       // of the reflected power, hemispheric light
    double simulated_t = 0.0, model_t = 0.0;  // T lobe at the beam's incidence
    double eq7_edge_coupling = 0.0;           // r_θ(1 − cos θ_d)/(b² A) of the simulated cells
    // The hemisphere scatterograms' median per-pixel relative standard error
    // (gonio::median_relative_standard_error, cells above 1 % of the peak).
    double hemisphere_median_sigma_simulation = 0.0, hemisphere_median_sigma_model = 0.0;
    // Level of physics (sim/wave/compare/ray_optics_validity.h) on the study's barbule row in 2D:
    // PO vs GO relative L1 (largest over the study's wavelengths) with its noise floor, the
    // total-power error, whether ray optics + thin film suffices (L1 <= 5 %), and the wall time.
    double level_relative_l1 = 0.0, level_noise_floor = 0.0, level_power_error = 0.0;
    bool level_ray_optics_suffices = false;
    double level_relative_l1_gap_closed = 0.0;  // the same row, keratin directly on melanin
    // Judged by full wave (one barbule with its gap; empty level: the reference does not apply)
    std::string level_full_wave;
    double level_full_wave_po_l1 = 0.0, level_full_wave_go_l1 = 0.0;
    double level_full_wave_resolution_l1 = 0.0, level_full_wave_back_power_diff = 0.0;
    // The same barbules as an endless row judged by full wave (band-mean reflectance; empty
    // level: the row reference does not apply): R, its grid difference, each level's error.
    // Which level measured ([level], studies/level_choice.h): ray optics + thin film, or physical
    // optics when it measured the BRDF as well; the level full wave says the row needs (""
    // uncertified); the warning.
    std::string level_measured_with, level_needed, level_warning;
    // Simulation against model, per measurement, from Monte Carlo noise alone
    // (analysis/metrics/verdict.h).
    std::vector<MeasurementVerdict> verdicts;
    // The BRDF at the physical-optics level (2.5D), when [level] chose it: its relative L1
    // against the model (and that L1's noise floor) and against the ray-traced BRDF, its
    // estimated relative RMS Monte Carlo error and its wall time.
    bool physical_optics_measured = false;
    double physical_optics_brdf_relative_l1 = 0.0,
           physical_optics_brdf_relative_l1_noise_floor = 0.0;
    double physical_optics_against_ray_optics_l1 = 0.0;
    double physical_optics_brdf_error = 0.0, physical_optics_brdf_seconds = 0.0;
    // Its beam scatterogram (the ray-traced beam scatterogram's instrument): relative L1 against
    // the model's, that L1's noise floor, its median per-pixel σ and its wall time.
    double physical_optics_scatterogram_relative_l1 = 0.0,
           physical_optics_scatterogram_relative_l1_noise_floor = 0.0;
    double physical_optics_scatterogram_error = 0.0, physical_optics_scatterogram_seconds = 0.0;
    std::string row_full_wave_level;
    double row_full_wave_reflectance = 0.0, row_full_wave_resolution_error = 0.0;
    double row_physical_optics_error = 0.0, row_ray_optics_error = 0.0;
    double level_seconds = 0.0;
    // Where and why the model departs, measured (studies/rock_dove_departures.h).
    Departures departures;
};

// `study_text` is the TOML; `source_name` names it in errors (a path or "<default>").
RockDoveResult run_rock_dove_study(const std::string& study_text,
                                   const std::filesystem::path& source_name,
                                   const std::filesystem::path& results_root, bool progress = true,
                                   const RunLimits& limits = {});

// Reads and checks the study file as run_rock_dove_study does, building and writing nothing.
void check_rock_dove_study(const std::string& study_text, const std::filesystem::path& source_name);

}  // namespace plumage::studies
