// The masking study (`study = "masking"`): the analytic barb/barbule masking term of
// Padrón-Griffe et al. 2024 (analysis/models/padrongriffe2024_masking.h: which fraction of a vane's
// projected area a direction sees first as barb, as barbule, and as nothing) against Monte Carlo
// ray casting on the explicit 2D cross-section polygons of the same patch
// (geometry::build_patch_cross_section; analysis/models/cross_section_masking_mc.h) — the
// validation the paper reports ("validated against Monte Carlo simulations on explicit 2D
// geometry").
//
// For every named patch configuration of the study file and every in-plane view angle θ (from +z
// towards +y, in the y–z plane across the barbs): the analytic fractions, the Monte Carlo
// fractions from `rays` stratified rays over one period ± their standard error σ (binomial, an
// upper bound for stratified rays), the deviation z = (MC − analytic) / σ, and the deterministic
// bound of stratified sampling, (B + 2)/N + B·offset/(P |cos θ|) (B: pieces of the analytic
// partition of the period, offset: how far the tessellated polygons sit from the analytic shapes).
// Per configuration: the largest |MC − analytic|, the largest |z|, and per component the χ² = Σ z²
// over the angles with its degrees of freedom (the number of angles: each angle has its own rays)
// and p-value. The verdict "agrees" needs all of: the largest 2D |z| within the Šidák bound for
// all comparisons (2D and 3D) at family-wise significance 0.01; every 2D χ² p-value above the
// Šidák threshold of their family; every 2D difference within the stratified bound (the sharp
// test: σ is loose); every 3D difference within the Šidák bound's σ plus the model allowance
// (below). Because σ is an upper bound, 2D |z| and χ² are small by construction: a failure of them
// means disagreement, a pass alone would prove little. The 3D χ² include the model's systematic
// and are reported, not tested.
//
// Opaque cross-section. The 2D polygons are opaque, so the angle scan compares them with the term's
// cross-section without row transmittance (PadronGriffe2024Masking(params, kFibreThickness)
// .fractions(θ, {}): strips as thick as the fibre, T = 0): it checks the exact envelope algorithm.
//
// The 3D check (issue 20): for the fixed directions kMaskingCheckDirections (the normal, the y–z
// and x–z planes, off both, both hemispheres, polar angles up to 70°), the full term with
// see-through barbule rows, PadronGriffe2024Masking(params, kFibreThickness)(ω), against Monte
// Carlo first-hit ray casting with Embree on the explicit 3D patch (geometry::build_barbule_patch:
// barbs and separate barbule fibres with real gaps; sim/patch_masking_mc.h), four components
// (barb, distal barbule, proximal barbule, gap), binomial σ (an upper bound for its stratified
// rays), z, χ² over the directions per component (dof = directions) and p-values. The term
// takes each row as a strip of the fibre's full thickness with the infinite row's transmittance;
// the explicit rows are thinner between fibre centres, are crossed along their finite length when
// seen nearly edge-on, start a clearance away from the cortex, end short of meeting tips, and
// have fixed per-row phases along x (the term multiplies two rows' transmittances as if
// independent): sim::PatchMaskingMonteCarlo::strip_picture_allowance bounds what
// tests/sim/patch_masking_mc_test.cpp measured, and a 3D comparison passes when |MC − term| <=
// z_bound σ + allowance. The explicit patch builds barbules perpendicular to the barb only
// (barbule_rotation_deg = 90); a configuration with another rotation is refused.
//
// Outputs in <results>/<name>/ (replaced atomically; nothing is written on bad input):
// masking.h5, masking.csv (2D), masking_3d.csv (3D), masking.png, report.md. Study files:
// studies/masking.toml (full), studies/masking_quick.toml (seconds; the tests run it). Schema:
// studies/README.md.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "geometry/barb.h"
#include "sim/scatterer/scatterer.h"

namespace plumage::studies {

// Barb, barbule (distal + proximal), gap: the order of analysis::SeenFirst.
inline constexpr std::size_t kMaskingComponentCount = 3;
using MaskingTriple = std::array<double, kMaskingComponentCount>;
// Barb, distal barbule, proximal barbule, gap: the order of analysis::MaskingComponent.
inline constexpr std::size_t kPatchComponentCount = 4;
using PatchQuad = std::array<double, kPatchComponentCount>;

// The 3D check directions as (polar from +z, azimuth from +x) in degrees: the normal, the y–z
// plane (both signs of y), the x–z plane, off both planes, and from below (polar > 90°).
inline constexpr std::array<std::array<double, 2>, 10> kMaskingCheckDirections = {{{0.0, 0.0},
                                                                                   {35.0, 90.0},
                                                                                   {60.0, 270.0},
                                                                                   {45.0, 0.0},
                                                                                   {30.0, 30.0},
                                                                                   {60.0, 120.0},
                                                                                   {70.0, 250.0},
                                                                                   {50.0, 300.0},
                                                                                   {130.0, 45.0},
                                                                                   {160.0, 200.0}}};
struct MaskingDirectionCheck {
    Vec3d direction;                 // unit, patch frame
    double projected_angle_deg = 0;  // atan2(ω_y, ω_z): the cross-section's angle
    double transmittance_distal = 0, transmittance_proximal = 0;  // row_transmittance(ω)
    PatchQuad model{};                         // the term at ω (kFibreThickness)
    PatchQuad mc{}, mc_standard_error{}, z{};  // explicit 3D patch
    double allowance = 0;                      // the model allowance above
    std::int64_t rays = 0;
};

struct MaskingConfigurationResult {
    std::string name;
    geometry::BarbulePatchParams params;
    double period_um = 0.0;
    double geometric_offset_um = 0.0;  // analysis::cross_section_offset_um
    // Per angle of MaskingStudyResult::angles_deg.
    std::vector<MaskingTriple> analytic, mc, mc_standard_error, z;
    std::vector<double> stratified_bound;
    double max_abs_difference = 0.0;
    double max_abs_difference_angle_deg = 0.0;
    std::size_t max_abs_difference_component = 0;
    double max_abs_z = 0.0;
    MaskingTriple chi_square{}, chi_square_p_value{};
    int degrees_of_freedom = 0;
    int above_stratified_bound = 0;  // comparisons with |MC − analytic| above the bound
    double max_bound_ratio = 0.0;    // max |MC − analytic| / stratified bound (<= 1: within)
    // The 3D check on the explicit patch.
    std::vector<MaskingDirectionCheck> directions;
    double patch_window_x_um = 0.0, patch_window_y_um = 0.0;  // the Monte Carlo's window
    int patch_barbs = 0, patch_fibres_per_row = 0;            // the built patch
    double patch_root_clearance_um = 0.0;  // its barbules' roots' distance from the cortex
    double patch_max_abs_difference = 0.0;
    double patch_max_abs_z = 0.0;
    double patch_max_excess = 0.0;  // max (|MC − term| − z_bound σ) / allowance (<= 1: passes)
    double patch_max_allowance_ratio = 0.0;  // max |MC − term| / allowance
    int patch_beyond = 0;  // 3D comparisons with |MC − term| > z_bound σ + allowance
    PatchQuad patch_chi_square{}, patch_chi_square_p_value{};
    double patch_seconds = 0.0;
    double wall_seconds = 0.0;
};

struct MaskingStudyResult {
    std::filesystem::path output_dir;
    double wall_seconds = 0.0;
    std::uint64_t seed = 0;
    std::int64_t rays = 0;        // per angle and configuration (2D)
    std::int64_t patch_rays = 0;  // per 3D direction and configuration (explicit patch)
    std::vector<double> angles_deg;
    std::vector<MaskingConfigurationResult> configurations;
    // configurations × (angles × 3 + check directions × 4).
    int comparisons = 0;
    double family_significance = 0.01;
    double z_bound = 0.0;                  // Šidák: |z| beyond this in any comparison rejects
    double chi_square_significance = 0.0;  // Šidák over configurations × components
    double max_abs_difference = 0.0;
    double max_abs_z = 0.0;        // over the angles (2D)
    double patch_max_abs_z = 0.0;  // over the 3D directions
    double patch_max_abs_difference = 0.0;
    bool agrees = false;
    std::string verdict;  // one paragraph, as in report.md
};

// `study_text` is the TOML; `source_name` names it in errors (file:line:col). InputError on any
// bad key or value, before anything is written.
MaskingStudyResult run_masking_study(const std::string& study_text,
                                     const std::filesystem::path& source_name,
                                     const std::filesystem::path& results_root,
                                     bool progress = true);

// Reads and checks the study file as run_masking_study does, building and writing nothing.
void check_masking_study(const std::string& study_text, const std::filesystem::path& source_name);

}  // namespace plumage::studies
