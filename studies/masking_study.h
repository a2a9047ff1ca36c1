// The masking study (`study = "masking"`): the analytic barb/barbule masking term of
// Padrón-Griffe et al. 2024 (analysis/padrongriffe2024_masking.h: which fraction of a vane's
// projected area a direction sees first as barb, as barbule, and as nothing) against Monte Carlo
// ray casting on the explicit 2D cross-section polygons of the same patch
// (geometry::build_patch_cross_section; analysis/cross_section_masking_mc.h) — the validation the
// paper reports ("validated against Monte Carlo simulations on explicit 2D geometry").
//
// For every named patch configuration of the study file and every in-plane view angle θ (from +z
// towards +y, in the y–z plane across the barbs): the analytic fractions, the Monte Carlo
// fractions from `rays` stratified rays over one period ± their standard error σ (binomial, an
// upper bound for stratified rays), the deviation z = (MC − analytic) / σ, and the deterministic
// bound of stratified sampling, (B + 2)/N + B·offset/(P |cos θ|) (B: pieces of the analytic
// partition of the period, offset: how far the tessellated polygons sit from the analytic shapes).
// Per configuration: the largest |MC − analytic|, the largest |z|, and per component the χ² = Σ z²
// over the angles with its degrees of freedom (the number of angles: each angle has its own rays)
// and p-value. The verdict "agrees" needs all of: the largest |z| within the Šidák bound for all
// comparisons at family-wise significance 0.01; every χ² p-value above the Šidák threshold of
// their family; every difference within the stratified bound (the sharp test: σ is loose); the
// 3D check exact to 1e-12. Because σ is an upper bound, |z| and χ² are small by construction: a
// failure of them means disagreement, a pass alone would prove little.
//
// The 3D check: for a few fixed directions off the y–z plane (kMaskingCheckDirections),
// operator()(ω) against in_plane(atan2(ω_y, ω_z)) — equal by the extrusion assumption (the
// cross-section extruded along the barb axis x; analysis/padrongriffe2024_masking.h) — and the
// Monte Carlo on the 2D section at that projected angle.
//
// Outputs in <results>/<name>/ (replaced atomically; nothing is written on bad input):
// masking.h5, masking.csv, masking.png, report.md. Study files: studies/masking.toml (full),
// studies/masking_quick.toml (seconds; the tests run it). Schema: studies/README.md.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "geometry/barb.h"
#include "sim/scatterer.h"

namespace plumage::studies {

// Barb, barbule (distal + proximal), gap: the order of analysis::SeenFirst.
inline constexpr std::size_t kMaskingComponentCount = 3;
using MaskingTriple = std::array<double, kMaskingComponentCount>;

// The 3D check directions as (polar from +z, azimuth from +x) in degrees: off the y–z plane,
// both hemispheres, and away from the patch plane: their projected angles are 16°, 41°, 56°,
// −69°, −46° and, from below, 140° (41° from −z), where the Monte Carlo is cheap.
inline constexpr std::array<std::array<double, 2>, 6> kMaskingCheckDirections = {
    {{30.0, 30.0}, {45.0, 60.0}, {60.0, 120.0}, {70.0, 250.0}, {50.0, 300.0}, {130.0, 45.0}}};

struct MaskingDirectionCheck {
    Vec3d direction;                          // unit, patch frame
    double projected_angle_deg = 0;           // atan2(ω_y, ω_z)
    MaskingTriple model_3d{};                 // PadronGriffe2024Masking::operator()(ω)
    MaskingTriple in_plane{};                 // in_plane(projected angle)
    MaskingTriple mc{}, mc_standard_error{};  // Monte Carlo on the 2D section at that angle
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
    std::vector<MaskingDirectionCheck> directions;
    double max_extrusion_mismatch = 0.0;  // max |operator()(ω) − in_plane(projected)|
    double wall_seconds = 0.0;
};

struct MaskingStudyResult {
    std::filesystem::path output_dir;
    double wall_seconds = 0.0;
    std::uint64_t seed = 0;
    std::int64_t rays = 0;  // per angle (and per check direction) and configuration
    std::vector<double> angles_deg;
    std::vector<MaskingConfigurationResult> configurations;
    // configurations × (angles + check directions) × components.
    int comparisons = 0;
    double family_significance = 0.01;
    double z_bound = 0.0;                  // Šidák: |z| beyond this in any comparison rejects
    double chi_square_significance = 0.0;  // Šidák over configurations × components
    double max_abs_difference = 0.0;
    double max_abs_z = 0.0;  // over angles and check directions
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
