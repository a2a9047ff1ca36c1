// Which level of physics a study measures with (`[level]`), and whether full wave says it may.
//
// The instruments (goniometer, scatterometer, BTF camera) measure any Scatterer: the ray-traced
// patch (ray optics + thin film) and the 2.5D physical-optics level (sim/wave/
// physical_optics_25d.h, a row of the study's barbule cross-sections extruded along the
// barbules). A study asks for:
//  - measure = "auto": the cheapest level that full wave certifies for the study's own barbule
//    row within `tolerance` (a row certificate: the endless periodic row's band-mean reflectance
//    R by full wave against ray optics and physical optics,
//    sim/wave/compare/levels_against_full_wave.h); physical optics when the certificate puts ray
//    optics beyond the tolerance and physical optics within it;
//  - measure = "ray optics": ray optics + thin film, whatever full wave says;
//  - measure = "physical optics": physical optics as well, whatever full wave says.
// A study that measures at physical optics measures what that level can (the rock-dove study: its
// Filip BRDF) at both levels and reports them side by side; its other measurements stay ray
// optics'. "full wave" is refused when the file is read: no instrument measures with it (the
// wave_validity study compares it with the other levels).
//
// The decision (decide_level):
//  - certified and ray optics within the tolerance: measured with ray optics (or, asked, with
//    physical optics as well), no warning unless the level asked is beyond the tolerance;
//  - certified, ray optics beyond the tolerance and physical optics within it: "auto" and
//    "physical optics" measure with physical optics as well; a warning that the measurements
//    left at ray optics carry its error; "ray optics" warns that every measurement does;
//  - certified and both beyond the tolerance (the row needs full wave): a warning naming the
//    level needed and the measured level's error, under every choice;
//  - no certificate (no full-wave reference for this row and none affordable, or one whose two
//    grids differ by more than `convergence`): measured with ray optics (or, asked, physical
//    optics as well), a warning that its error is unknown under "auto", a note otherwise (the
//    user chose the level).
//
// Parameter table:
//  | key                      | unit | range                                  | default |
//  |--------------------------|------|----------------------------------------|---------|
//  | measure                  | —    | auto, ray optics, physical optics      | auto    |
//  | tolerance                | 1    | (0, 1)                                 | 0.05    |
//  | full_wave_budget_minutes | min  | >= 0                                   | 0       |
#pragma once

#include <string>
#include <vector>

#include "sim/wave/compare/levels_against_full_wave.h"

namespace plumage::studies {

class ParameterTable;

inline constexpr const char* kRayOptics = "ray optics + thin film";
inline constexpr const char* kPhysicalOptics = "physical optics";

struct LevelSettings {
    std::string measure = "auto";  // "auto", "ray optics" or "physical optics"
    double tolerance = 0.05;
    double full_wave_budget_minutes = 0.0;  // a row certificate computed live within this
    double convergence = 0.02;              // the largest resolution error of a certificate
};

// InputError (file:line:column, with the allowed values) for an unknown level or one no
// instrument measures with (full wave).
LevelSettings read_level(ParameterTable t);

// Full wave's verdict on the study's row, or why there is none.
struct LevelCertificate {
    bool present = false;
    std::string source;  // where the full-wave reference came from; or why there is none
    sim::wave::RowVerdict2d verdict;
};

// A row certificate computed here: the endless row of barbules (Huang's cell of semi-major axis
// a_um, b, film d over gap g; spacing H·a, tilt μ) by full wave (sim/fullwave/row_reference.h)
// at the study's wavelengths, the grid the larger of 45 px/µm and the λ/(10 n) rule, decay
// 1e-5, when its predicted time fits the budget; else no reflectance and the reason.
struct LiveRowReference {
    std::vector<sim::wave::RowReflectanceFullWave> reflectance;
    std::string source, why_none;
};
struct RowScene {
    double a_um = 0.0, b = 0.0, film_um = 0.0, gap_um = 0.0, H = 0.0, mu = 0.0, theta_i = 0.0;
};
class StudyProgress;
LiveRowReference live_row_reference(const RowScene& scene, const std::vector<double>& lambdas_nm,
                                    const LevelSettings& settings, const StudyProgress& clock);

struct LevelDecision {
    std::string needed;  // the cheapest certified level, or "" without a certificate
    // kRayOptics, or kPhysicalOptics when physical optics measures as well (then `physical_optics`)
    std::string measured_with = kRayOptics;
    bool physical_optics = false;
    std::string warning;  // empty: nothing to warn of
    std::string summary;  // one paragraph for the report's opening
};

LevelDecision decide_level(const LevelSettings& settings, const LevelCertificate& certificate);

}  // namespace plumage::studies
