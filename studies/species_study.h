// The species study: the four feathers of Filip, Maile and Vávra 2024 (macaw parrot, Cochin
// cock "rooster", greater flamingo, white stork) built as explicit barb + barbule patches,
// measured by the same virtual instruments as the paper's SIGHTTEX Q capture, and the paper's
// analytic BRDF fitted to each simulated BRDF.
//
// Per species (a [species.<name>] table; <name> one of the paper's four, which selects its
// Table 1 column):
//  - geometry: geometry/barb.h's patch (barb cross-section with optional medulla, elliptical
//    barbules rising out of the vane), optionally stacked in several vane layers (overlapping
//    feathers; the flamingo's "two layers of barbules"), mounted on the stage at an azimuth;
//  - materials: keratin, optionally with a pigment absorption band (carotenoids), barbules
//    with a melanin core under a keratin cortex film (glossy, possibly iridescent), a medulla
//    that is white (a diffuse surface of constant albedo) or spongy: spongy keratin given by
//    its structure only (channel length scale Λ, keratin fraction f, the generated volume's
//    box and voxel), whose first-Born scattering tables at every traced wavelength
//    (studies/spongy_medium.h) fill the medulla as a scattering medium, optionally around a
//    melanin core (sim/scene.h SpongyMedulla); its colour is computed, and the study file
//    refuses colour keys for it;
//  - measurements: the BRDF on the paper's 61 × 60 set (photon estimator, per wavelength),
//    the in-plane sweep (view 45° in the plane across the barbs, light −81°…81°), the virtual
//    BTF on the same set (an image of the patch per pair; the 12 geometries of Fig. 9 shown:
//    light and view at 30°, light azimuth in 30° steps), and the directional albedo at normal
//    incidence;
//  - the fit: Filip's model (analysis/fits/filip2024_fit.h) fitted to the simulated 61 × 60 BRDF,
//    starting from the species' Table 1 column; fitted parameters with standard errors beside
//    Table 1; fingerprints of simulation | fit | Table 1;
//  - checks: reciprocity of the simulated BRDF over the pairs the set holds both ways
//    (χ² against the Monte Carlo errors) and energy (albedo ≤ 1).
// Across species: the in-plane luminance L*(light angle) as in Filip Fig. 6a.
//
// Outputs in <results>/<name>/ (replaced atomically): report.md, species.h5 (fits, albedo,
// in-plane L*), fits.csv, in_plane_luminance.csv/.png, per species <species>/brdf.h5,
// fit.h5, fingerprints.png, btf.png, btf.h5, and beside the two PNGs fingerprints.exr and
// btf.exr (their spectra, OpenEXR: virtual_gonio/RECORD.md).
//
// Study file: studies/species.toml (full) and studies/species_quick.toml (tests); keys in
// studies/README.md.
#pragma once

#include <array>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "analysis/metrics/energy.h"
#include "analysis/metrics/verdict.h"
#include "analysis/models/filip2024.h"
#include "sim/scene.h"
#include "studies/study.h"

namespace plumage::studies {

struct SpeciesOutcome {
    std::string species;
    double mount_deg = 0.0;
    // The fit (analysis/fits/filip2024_fit.h), table order of kFilip2024ParameterTable.
    std::array<double, analysis::kFilip2024ParameterCount> fitted{}, fitted_error{}, table1{};
    double reduced_chi_square = 0.0;
    double fit_relative_rms = 0.0;     // RMS(f_fit − f_sim) / mean f_sim over the 61 × 60 set
    double table1_relative_rms = 0.0;  // the same for the Table 1 parameters
    double fit_relative_l1 = 0.0;  // Σ|f_fit − f_sim| / Σ f_sim: robust to a few sharp peaks
    double table1_relative_l1 = 0.0;
    // The simulated BRDF against the fitted model and against Table 1's, from the simulation's
    // Monte Carlo noise alone over its signal cells (analysis/metrics/verdict.h; the report's
    // opening).
    analysis::AgreementVerdict fit_verdict, table1_verdict;
    // Each model's directional albedo at 21 directions θ_i ≤ 75° (analysis/metrics/energy.h):
    // Filip's published parameters need not conserve energy (the flamingo's and stork's do not).
    analysis::EnergyCheck fit_energy, table1_energy;
    std::array<bool, analysis::kFilip2024ParameterCount>
        at_bound{};  // fitted value on its range's edge
    bool fit_converged = false;
    double fit_start_phi_a_deg = 0.0;  // the φa start (of four) whose fit was best
    // Angle (0–90°) between the fitted axis U(φa) and the patch's barb axis and barbules.
    double fit_axis_from_barbs_deg = 0.0, fit_axis_from_barbules_deg = 0.0;
    // Channel means (R, G, B) of the simulated BRDF over the 61 × 60 set, 1/sr.
    std::array<double, 3> mean_brdf_rgb{};
    // Directional albedo at normal incidence, per wavelength, with its standard error.
    std::vector<double> albedo, albedo_error;
    // Paths at normal incidence that met a surface from a side they did not travel in (sim/
    // tracer.h's medium mismatches), as a fraction of all paths and of the incident power
    // they carry out (wavelength average).
    double mismatched_paths = 0.0, mismatched_albedo = 0.0;
    // Reciprocity: χ² of f(i, o) − f(o, i) over σ, its degrees of freedom, and the largest |z|.
    double reciprocity_chi_square = 0.0;
    int reciprocity_dof = 0;
    double reciprocity_max_z = 0.0;
    // In-plane L* (D65, reflectance factor π f) per light angle, simulation and fit.
    std::vector<double> in_plane_lstar, in_plane_lstar_error, in_plane_fit_lstar;
    // Light angle (deg) of the in-plane peak of L*.
    double in_plane_peak_deg = 0.0;
    double brdf_seconds = 0.0;  // wall time of the 61 × 60 measurement
    double btf_seconds = 0.0;   // wall time of the BTF
    int btf_passes = 0;         // the detector estimator's passes (BtfConfig's stop rule)
    // Median σ/f over the lit pixels of Fig. 9's tiles (gonio::median_lit_pixel_error), and
    // the same per tile in Fig. 9's order (light azimuth 0°, 30°, …, 330°; infinity where a
    // tile has no lit pixel).
    double btf_median_pixel_error = 0.0;
    std::vector<double> btf_tile_pixel_errors;
    // π f at the mirror pair (light 30° at 180°, view 30° at 0°) per wavelength: the spectrum
    // the avian-vision section compares across species.
    std::vector<double> mirror_reflectance, mirror_reflectance_error;
};

struct SpeciesResult {
    std::filesystem::path output_dir;
    double wall_seconds = 0.0;
    std::vector<double> wavelengths_nm;
    std::vector<double> in_plane_angles_deg;  // signed light angle, −81 … 81
    std::vector<SpeciesOutcome> species;
};

SpeciesResult run_species_study(const std::string& study_text,
                                const std::filesystem::path& source_name,
                                const std::filesystem::path& results_root, bool progress = true,
                                const RunLimits& limits = {});

// Reads and checks the study file as run_species_study does, building and writing nothing.
void check_species_study(const std::string& study_text, const std::filesystem::path& source_name);

// One species' scene as run_species_study builds it (the same seeds), for tests and
// diagnostics: its patch with all layers, and the period cell the goniometer and the albedo
// light (sim/scatterer/period_cell_entry.h: cell_x_um × cell_y_um centred on (0, cell_y0_um)). A
// spongy medulla's medium is computed at the study's traced wavelengths plus `extra_wavelengths_nm`
// (the voxel limit checked over all of them). InputError as run_species_study, or when
// species.run does not list `species`.
struct SpeciesScene {
    sim::SceneDescription scene;
    double cell_x_um = 0.0, cell_y_um = 0.0, cell_y0_um = 0.0;
    double barb_width_um = 0.0;
    std::vector<double> wavelengths_nm;                          // where a spongy medium has tables
    std::shared_ptr<const sim::ScatteringMedium> spongy_medium;  // null: white medulla
};
SpeciesScene build_species_scene(const std::string& study_text,
                                 const std::filesystem::path& source_name,
                                 const std::string& species,
                                 const std::vector<double>& extra_wavelengths_nm = {});

}  // namespace plumage::studies
