// Which level of physics a study measures with (`[level]`), and whether full wave says it may.
//
// The instruments (goniometer, scatterometer, BTF camera) measure with ray optics + thin film,
// the only level they have. A study asks for:
//  - measure = "auto": the cheapest level that full wave certifies for the study's own barbule
//    row within `tolerance` (a row certificate: the endless periodic row's band-mean reflectance
//    R by full wave against ray optics and physical optics, sim/wave/levels_against_full_wave.h);
//  - measure = "ray optics": ray optics + thin film, whatever full wave says.
// "physical optics" and "full wave" are refused when the file is read: no instrument measures
// with them (the wave-validity study compares those levels).
//
// The decision (decide_level):
//  - certified and ray optics within the tolerance: measured with ray optics, no warning;
//  - certified and ray optics beyond it: the scene needs physical optics or full wave; the
//    measurement is still ray optics' (the only level the instruments have), with a warning
//    naming the level needed and ray optics' measured error, under "auto" and "ray optics" alike;
//  - no certificate (no full-wave reference for this row and none affordable, or one whose two
//    grids differ by more than `convergence`): measured with ray optics, a warning that its error
//    is unknown under "auto", a note under "ray optics" (the user chose it).
//
// Parameter table:
//  | key                      | unit | range        | default |
//  |--------------------------|------|--------------|---------|
//  | measure                  | —    | auto, ray optics | auto |
//  | tolerance                | 1    | (0, 1)       | 0.05    |
//  | full_wave_budget_minutes | min  | >= 0         | 0       |
#pragma once

#include <string>
#include <vector>

#include "sim/wave/levels_against_full_wave.h"

namespace plumage::studies {

class ParameterTable;

inline constexpr const char* kRayOptics = "ray optics + thin film";

struct LevelSettings {
    std::string measure = "auto";  // "auto" or "ray optics"
    double tolerance = 0.05;
    double full_wave_budget_minutes = 0.0;  // a row certificate computed live within this
    double convergence = 0.02;              // the largest resolution error of a certificate
};

// InputError (file:line:column) for a level no instrument measures with.
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
    std::string measured_with = kRayOptics;
    std::string warning;  // empty: nothing to warn of
    std::string summary;  // one paragraph for the report's opening
};

LevelDecision decide_level(const LevelSettings& settings, const LevelCertificate& certificate);

}  // namespace plumage::studies
