// The ablation study: one parameter of Huang et al. 2022's barbule model at a time, swept
// around the rock-dove values, with the explicit patch (traced) and the analytic model
// measured by the same imaging scatterometer under the same beam.
//
// Parameters swept (each alone, the others at the study's [geometry] values):
//   b, phi0, phi1, H, d (the film thickness), theta_d, mu.
// Per value: the beam scatterograms of the simulation and of the model and the model's
// error, the power-weighted relative L1 with the simulation as reference,
//   e = Σ |I_model − I_sim| Ω / Σ I_sim Ω   (over pixels and wavelengths),
// beside the noise floor of that number (the e a perfect model would show against this
// many quanta, Σ σ_sim √(2/π) Ω / Σ I_sim Ω). Values the geometry or the model rejects
// (barbules that would interpenetrate, a melanin layer deeper than the arc's smallest
// radius of curvature, ...) are skipped and listed in the report with the reason.
//
// Outputs in <results>/<name>/ (replaced atomically): report.md (summary table, then per
// parameter the error plot, the contact sheet and a table), per parameter
// <parameter>/contact_sheet.png (rows: values; columns: simulation | model),
// <parameter>/error.png, the single images (each with its spectra as OpenEXR beside it, same
// stem: virtual_gonio/exr_image.h), errors.csv (every value) and ablation.h5.
//
// Study file (`study = "ablation"`): [geometry.*], [spectrum] and the beam keys of
// [scatterometer] as in the rock-dove study, plus
//   [sweep]       values (per parameter, default 5; 0 leaves a parameter out)
//   [sweep.<p>]   from, to, values   for p in b, phi0_deg, phi1_deg, H,
//                                    film_thickness_um, theta_d_deg, mu_deg
// Examples: studies/ablation.toml (full), studies/ablation_quick.toml (seconds, tests).
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "studies/study.h"

namespace plumage::studies {

struct AblationPoint {
    std::string parameter;  // study-file key: "b", "phi0_deg", ..., "mu_deg"
    double value = 0.0;     // in the study file's unit (degrees for angles, µm for d)
    bool is_base = false;   // the [geometry] value (the rock dove's unless changed)
    bool skipped = false;
    std::string reason;  // why it was skipped
    // Model error, simulation as reference: Σ|I_model − I_sim|Ω / Σ I_sim Ω.
    double relative_l1 = 0.0;
    // The same difference over the model's power (the rock-dove study's normalisation).
    double relative_l1_model_reference = 0.0;
    double noise_floor = 0.0;  // expected relative_l1 of a perfect model (simulation noise)
    double simulated_reflected = 0.0, model_reflected = 0.0;      // fraction of the beam's power
    double simulated_transmitted = 0.0, model_transmitted = 0.0;  // leaving below the patch
};

struct AblationResult {
    std::filesystem::path output_dir;
    double wall_seconds = 0.0;
    std::vector<AblationPoint> points;  // in sweep order: parameter by parameter, values ascending
    int skipped = 0;
    // The point at the base values (the same measurement serves every parameter); null
    // when no sweep contains the base value.
    const AblationPoint* base() const;
};

// `study_text` is the TOML; `source_name` names it in errors.
// `limits` override the study file's time budget and target error of every scatterogram.
AblationResult run_ablation_study(const std::string& study_text,
                                  const std::filesystem::path& source_name,
                                  const std::filesystem::path& results_root, bool progress = true,
                                  const RunLimits& limits = {});

// Reads and checks the study file as run_ablation_study does, building and writing nothing.
void check_ablation_study(const std::string& study_text, const std::filesystem::path& source_name);

}  // namespace plumage::studies
