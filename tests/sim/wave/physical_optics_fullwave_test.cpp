// Physical optics (sim/wave/surface/physical_optics_2d.h) against the full-wave Meep reference of
// tests/reference/barbule_2d (project issue 16, acceptance item 2): every σ(θ_s) curve of
// far_field.csv (single, small, row3; TE/TM; 450/550/650 nm; θ_i 0° and 30° for single) against
// PO's σ on the same 0.5° grid for the contract's shapes. Compared: the back hemisphere
// (|θ_s − θ_i| <= 90°) in 10° bins, which average row3's 2.3–3.4° fringes (relative L1 of the
// bins, each bin with >= 1 % of the power, the back power), the forward shadow lobe
// (|θ_s − θ_i − 180°| <= 2λ/W) as one band, the scattering widths, and PO's reflected + Meep's
// absorbed power against the projected width W. The tolerances are max(physics, 2× Meep's
// 40→60 px/µm difference), each with its reason; the measured table is printed (and is the one
// in tests/reference/barbule_2d/README.md, "Against full wave"). PO uses optics::keratin()/
// melanin(), the contract's formulas; Meep's fitted media change PO by < 1 % (a test).
#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdio>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <tuple>
#include <vector>

#include <gtest/gtest.h>

#include "common/constants.h"
#include "sim/optics/material.h"
#include "sim/wave/compare/full_wave_reference.h"
#include "sim/wave/surface/geometric_optics_2d.h"
#include "sim/wave/surface/physical_optics_2d.h"
#include "sim/wave/surface/physical_optics_hybrid_2d.h"

namespace plumage::sim::wave {
namespace {

namespace fs = std::filesystem;

fs::path reference_dir() { return fs::path(PLUMAGE_SOURCE_DIR) / "tests/reference/barbule_2d"; }

// far_field.csv's grid: θ_s = −179.5° + 0.5° m, m = 0 … 719 (full_wave_reference.h).
constexpr int kAngles = 720;
constexpr double kStepDeg = 0.5;
double grid_deg(int m) { return -179.5 + kStepDeg * m; }

using Key = FullWaveKey;  // case, pol, θ_i (°), λ (nm)

std::map<Key, std::vector<double>> read_far_field() {
    std::map<Key, std::vector<double>> out;
    for (const auto& [key, curve] : read_full_wave_reference(reference_dir()).far_field)
        out[key] = curve.sigma_um_per_rad;
    return out;
}

// totals.csv: the box's scattering and absorption widths at one resolution.
std::map<Key, std::pair<double, double>> read_totals(int resolution) {
    const ReferenceCsv t = read_reference_csv(reference_dir() / "totals.csv");
    std::map<Key, std::pair<double, double>> out;
    for (std::size_t r = 0; r < t.rows.size(); ++r)
        if (t.integer(r, "resolution") == resolution)
            out[t.key(r)] = {t.number(r, "scattering_width_um"),
                             t.number(r, "absorption_width_um")};
    return out;
}

struct Convergence {
    double max_rel = 0.0, rms_rel = 0.0, sca_rel = 0.0;
};
std::map<Key, Convergence> read_convergence() {
    std::map<Key, Convergence> out;
    for (const auto& [key, c] : read_full_wave_reference(reference_dir()).convergence)
        out[key] = {c.sigma_max_rel_diff, c.sigma_rms_rel_diff, c.scattering_width_rel_diff};
    return out;
}

// materials.csv: the fitted media Meep ran with (n_keratin, n + ik melanin) per wavelength.
std::map<int, std::pair<double, std::complex<double>>> read_fitted_media() {
    const ReferenceCsv t = read_reference_csv(reference_dir() / "materials.csv");
    std::map<int, std::pair<double, std::complex<double>>> out;
    for (std::size_t r = 0; r < t.rows.size(); ++r)
        out[t.integer(r, "lambda_nm")] = {
            t.number(r, "n_keratin_fitted"),
            {t.number(r, "n_melanin_fitted"), t.number(r, "k_melanin_fitted")}};
    return out;
}

// σ on the grid for the given part; with visibility the reflected part drops the light a
// neighbour blocks (header), and total = |U_refl + U_shadow|² (one realisation, no jitter).
std::vector<double> po_sigma(const Row2d& row, const Incidence2d& inc, FarFieldPart part,
                             bool visibility = false) {
    std::vector<double> theta(kAngles);
    for (int m = 0; m < kAngles; ++m) theta[m] = grid_deg(m) * kDeg;
    if (!visibility) {
        PhysicalOpticsOptions o;
        o.part = part;
        return scattering_width(row, inc, theta, o);
    }
    const SampledCrossSection2d placed =
        place_row(row, sample_cross_section(row.cell, 1e-4 * inc.lambda_nm), 0);
    PhysicalOpticsOptions refl;
    refl.part = FarFieldPart::reflected;
    refl.outgoing_visibility = true;
    std::vector<std::complex<double>> u = far_field_integral(row.cell, placed, inc, theta, refl);
    if (part == FarFieldPart::total) {
        PhysicalOpticsOptions shadow;
        shadow.part = FarFieldPart::shadow;
        const auto us = far_field_integral(row.cell, placed, inc, theta, shadow);
        for (int m = 0; m < kAngles; ++m) u[m] += us[m];
    }
    const double k = 2.0 * kPi / (1e-3 * inc.lambda_nm);
    std::vector<double> sigma(kAngles);
    for (int m = 0; m < kAngles; ++m) sigma[m] = k / (8.0 * kPi) * std::norm(u[m]);
    return sigma;
}

// Angle from a direction, wrapped to (−180°, 180°].
double wrap_deg(double a) {
    while (a > 180.0) a -= 360.0;
    while (a <= -180.0) a += 360.0;
    return a;
}

// ∫σ dθ over |angle from centre| in [lo, hi) (°), the band's edge samples weighted ½ (the
// trapezoid rule on the 0.5° grid; adjacent bands then share an edge sample evenly).
double band(const std::vector<double>& sigma, double centre_deg, double lo, double hi) {
    double sum = 0.0;
    for (int m = 0; m < kAngles; ++m) {
        const double a = wrap_deg(grid_deg(m) - centre_deg);
        if (a < lo - 1e-9 || a > hi + 1e-9) continue;
        const bool edge = std::abs(a - lo) < 1e-9 || std::abs(a - hi) < 1e-9;
        sum += (edge ? 0.5 : 1.0) * sigma[m];
    }
    return sum * kStepDeg * kDeg;
}

double circle_sum(const std::vector<double>& sigma) {
    double s = 0.0;
    for (double v : sigma) s += v;
    return s * kStepDeg * kDeg;
}

// Everything measured for one far_field.csv curve. "Back" is the hemisphere centred on the
// backscatter direction θ_i (|θ_s − θ_i| <= 90°), the forward lobe is centred on θ_i + 180°.
struct Residual {
    Key key;
    double width = 0.0;              // projected width W, µm
    double l1 = 0.0;                 // back hemisphere, 10° bins: Σ|P_PO − P_Meep| / Σ P_Meep
    double l1_central = 0.0;         // the same over the 12 bins within 60° of θ_i
    double l1_visibility = -1.0;     // row3: l1 with outgoing visibility (header), else −1
    double reflected_ratio = 0.0;    // ∫_back σ_PO / ∫_back σ_Meep
    double worst_band = 0.0;         // largest |P_PO/P_Meep − 1| over bins >= 1 % of back
    double worst_band_centre = 0.0;  // its centre, ° from θ_i
    double worst_band_share = 0.0;   // its share of Meep's back power
    double worst_main_band = 0.0;    // the same over bins >= 5 %
    double lobe_ratio = 0.0;         // forward lobe |θ − θ_f| <= 2λ/W, PO/Meep
    double sca_po = 0.0, sca_meep = 0.0;   // PO ∫σ over the circle; Meep's box width
    double abs_meep = 0.0, refl_po = 0.0;  // Meep's absorption; PO reflected part, circle
    double shadow_po = 0.0;      // PO's shadow part over the circle: W (the extinction paradox)
    double fitted_change = 0.0;  // max |Δ| of the back bins' P_PO with the fitted media, rel.
    double l1_go = 0.0;          // ray optics (geometric_optics_2d.h): back L1 against Meep
    double reflected_ratio_go = 0.0;  // ∫_back GO / ∫_back σ_Meep
    // Physical optics through interfaces (physical_optics_hybrid_2d.h): the melanin core is a
    // body that may transmit, not the stack's opaque substrate.
    double l1_hybrid = 0.0, reflected_ratio_hybrid = 0.0, sca_hybrid = 0.0;
    Convergence resolution;  // Meep 40 vs 60 px/µm
};

std::vector<double> back_bins(const std::vector<double>& sigma, double theta_i_deg) {
    std::vector<double> p(18);
    for (int b = 0; b < 18; ++b) p[b] = band(sigma, theta_i_deg, -90.0 + 10 * b, -80.0 + 10 * b);
    return p;
}

// Ray optics' powers (each ray at its mirror angle) in the same 10° back bins; a ray on a bin
// edge is split between the two bins, as band() splits a grid point.
std::vector<double> go_back_bins(const std::vector<GeometricRay2d>& rays, double theta_i_deg) {
    std::vector<double> p(18);
    for (const GeometricRay2d& ray : rays) {
        const double a = wrap_deg(ray.theta_s_rad / kDeg - theta_i_deg) + 90.0;
        if (a < 0.0 || a > 180.0) continue;
        const int b = std::min(17, static_cast<int>(a / 10.0));
        p[b] += ray.power_um;
    }
    return p;
}

double relative_l1(const std::vector<double>& po, const std::vector<double>& meep, int from,
                   int to) {
    double diff = 0.0, sum = 0.0;
    for (int b = from; b < to; ++b) {
        diff += std::abs(po[b] - meep[b]);
        sum += meep[b];
    }
    return diff / sum;
}

Residual measure(const Key& key, const std::vector<double>& sigma_meep,
                 const std::pair<double, double>& totals, const Convergence& resolution,
                 const std::pair<double, std::complex<double>>& fitted) {
    const auto& [name, pol_name, theta_i_deg, lambda] = key;
    const Row2d row = full_wave_row(name);  // optics::keratin()/melanin(): the formulas
    const double ti = theta_i_deg * kDeg;
    const Incidence2d inc{static_cast<double>(lambda), ti,
                          pol_name == "TE" ? Polarisation2d::te : Polarisation2d::tm};
    const std::vector<double> po = po_sigma(row, inc, FarFieldPart::total);
    Residual r;
    r.key = key;
    r.resolution = resolution;
    r.width = full_wave_projected_width(name, ti);
    const std::vector<double> pm = back_bins(sigma_meep, theta_i_deg);
    const std::vector<double> pp = back_bins(po, theta_i_deg);
    r.l1 = relative_l1(pp, pm, 0, 18);
    r.l1_central = relative_l1(pp, pm, 3, 15);
    double back_meep = 0.0, back_po = 0.0;
    for (int b = 0; b < 18; ++b) {
        back_meep += pm[b];
        back_po += pp[b];
    }
    r.reflected_ratio = back_po / back_meep;
    for (int b = 0; b < 18; ++b) {
        const double e = std::abs(pp[b] / pm[b] - 1.0), share = pm[b] / back_meep;
        if (share >= 0.01 && e > std::abs(r.worst_band)) {
            r.worst_band = pp[b] / pm[b] - 1.0;
            r.worst_band_centre = -85.0 + 10 * b;
            r.worst_band_share = share;
        }
        if (share >= 0.05) r.worst_main_band = std::max(r.worst_main_band, e);
    }
    const double lobe = 2.0 * (1e-3 * lambda) / r.width / kDeg;
    r.lobe_ratio = band(po, theta_i_deg + 180.0, -lobe, lobe) /
                   band(sigma_meep, theta_i_deg + 180.0, -lobe, lobe);
    r.sca_po = circle_sum(po);
    r.sca_meep = totals.first;
    r.abs_meep = totals.second;
    r.refl_po = circle_sum(po_sigma(row, inc, FarFieldPart::reflected));
    r.shadow_po = circle_sum(po_sigma(row, inc, FarFieldPart::shadow));
    Row2d fit = row;
    fit.cell.curves[0].stack.films[0].material =
        std::make_shared<optics::ConstantMaterial>("keratin, Meep's fit", fitted.first);
    fit.cell.curves[0].stack.substrate =
        std::make_shared<optics::ConstantMaterial>("melanin, Meep's fit", fitted.second);
    const std::vector<double> pf = back_bins(po_sigma(fit, inc, FarFieldPart::total), theta_i_deg);
    for (int b = 0; b < 18; ++b)
        if (pm[b] >= 0.01 * back_meep)
            r.fitted_change = std::max(r.fitted_change, std::abs(pf[b] / pp[b] - 1.0));
    const std::vector<double> pg = go_back_bins(geometric_rays(row, inc), theta_i_deg);
    r.l1_go = relative_l1(pg, pm, 0, 18);
    double back_go = 0.0;
    for (double v : pg) back_go += v;
    r.reflected_ratio_go = back_go / back_meep;
    std::vector<double> theta(kAngles);
    for (int m = 0; m < kAngles; ++m) theta[m] = grid_deg(m) * kDeg;
    const HybridFarField2d hybrid = hybrid_far_field(row_cross_section(row), inc, theta);
    const std::vector<double> ph = back_bins(hybrid.sigma_um_per_rad, theta_i_deg);
    r.l1_hybrid = relative_l1(ph, pm, 0, 18);
    double back_hybrid = 0.0;
    for (double v : ph) back_hybrid += v;
    r.reflected_ratio_hybrid = back_hybrid / back_meep;
    r.sca_hybrid = hybrid.scattering_width_um;
    if (name == "row3")
        r.l1_visibility = relative_l1(
            back_bins(po_sigma(row, inc, FarFieldPart::total, true), theta_i_deg), pm, 0, 18);
    return r;
}

std::string fmt_visibility(double v) {
    char buffer[32];
    std::snprintf(buffer, sizeof buffer, " (vis. %.3f)", v);
    return buffer;
}

// All 24 curves, computed once for the tests below (≈ 2 s).
const std::vector<Residual>& residuals() {
    static const std::vector<Residual> all = [] {
        const auto meep = read_far_field();
        const auto totals = read_totals(60);
        const auto conv = read_convergence();
        const auto fitted = read_fitted_media();
        EXPECT_EQ(meep.size(), 24u);
        std::vector<Residual> out;
        for (const auto& [key, sigma] : meep) {
            EXPECT_EQ(sigma.size(), static_cast<std::size_t>(kAngles));
            if (sigma.size() != static_cast<std::size_t>(kAngles)) continue;
            out.push_back(
                measure(key, sigma, totals.at(key), conv.at(key), fitted.at(key.lambda_nm)));
        }
        std::printf(
            "| case | pol | θi | λ | back L1 | L1 ≤60° | refl. PO/Meep | worst band (centre, "
            "share) | worst ≥ 5 %% band | fwd lobe PO/Meep | C_sca PO/Meep | Meep C_ext/2W | (PO "
            "refl "
            "+ Meep abs)/W | Meep 40/60 rms / max |\n");
        for (const Residual& r : out) {
            const auto& [name, pol, ti, lambda] = r.key;
            std::printf(
                "| %s | %s | %d | %d | %.3f%s | %.3f | %.3f | %+.0f %% (%+.0f°, %.1f %%) | %.0f %% "
                "| "
                "%.3f | %.3f | %.3f | %.3f | %.3f / %.3f |\n",
                name.c_str(), pol.c_str(), ti, lambda, r.l1,
                r.l1_visibility >= 0 ? fmt_visibility(r.l1_visibility).c_str() : "", r.l1_central,
                r.reflected_ratio, 100 * r.worst_band, r.worst_band_centre,
                100 * r.worst_band_share, 100 * r.worst_main_band, r.lobe_ratio,
                r.sca_po / r.sca_meep, (r.sca_meep + r.abs_meep) / (2 * r.width),
                (r.refl_po + r.abs_meep) / r.width, r.resolution.rms_rel, r.resolution.max_rel);
        }
        return out;
    }();
    return all;
}

// An XML-safe property name: single_TE_0_450_<what>.
std::string property(const Residual& r, const char* what) {
    const auto& [name, pol, ti, lambda] = r.key;
    return name + "_" + pol + "_" + std::to_string(ti) + "_" + std::to_string(lambda) + "_" + what;
}

std::string label(const Residual& r) {
    const auto& [name, pol, ti, lambda] = r.key;
    char buffer[64];
    std::snprintf(buffer, sizeof buffer, "%s %s θi=%d° λ=%d nm", name.c_str(), pol.c_str(), ti,
                  lambda);
    return buffer;
}

// Meep's own error at 60 px/µm: its staircase convergence is first-order-ish (README), so the
// 60 px/µm error is about 40/(60 − 40) = 2× the 40→60 difference; that is the floor of every
// tolerance below.
double floor_rms(const Residual& r) { return 2.0 * r.resolution.rms_rel; }
double floor_max(const Residual& r) { return 2.0 * r.resolution.max_rel; }

TEST(PhysicalOpticsFullWave, SingleShellLobesWithinEdgeDiffractionAndMeepResolution) {
    for (const Residual& r : residuals()) {
        if (r.key.shape != "single") continue;
        const std::string at = label(r);
        RecordProperty(property(r, "back_l1"), std::to_string(r.l1));
        // Back hemisphere: the specular lobe comes from the top, kρ = 120–180 (ρ = 12.8 µm),
        // where Kirchhoff errs by O(1/kρ) < 1 %; the flanks near the tips (ρ = 1.1 µm, kρ =
        // 11–15) carry a few % of the power with O(1/kρ) ≈ 7–10 % error: 8 % in L1.
        const double l1_tol = std::max(0.08, floor_rms(r));
        EXPECT_LT(r.l1, l1_tol) << at
                                << ": back-hemisphere L1 of 10° bins; tolerance max(8 % "
                                   "edge diffraction at the tips, 2× Meep 40/60 RMS)";
        // The reflected power is the stack's R at the stationary points, exact in PO; what
        // is left is the same tip correction on a few % of the power: 5 %.
        EXPECT_NEAR(r.reflected_ratio, 1.0, std::max(0.05, floor_rms(r)))
            << at
            << ": back-hemisphere power PO/Meep; tolerance max(5 % tip diffraction, 2× "
               "Meep 40/60 RMS)";
        // Bands with >= 5 % of the back power lie within 60° of the specular direction, fed
        // by kρ >= 30: 15 % per 10° band, or Meep's doubled worst-point difference.
        EXPECT_LT(r.worst_main_band, std::max(0.15, floor_max(r)))
            << at << ": worst 10° band with >= 5 % of the back power";
        // Bands with 1–5 %: grazing exits fed by the tips and the shadow boundary's creeping
        // waves (Fock region, (kρ)^(−1/3) ≈ 0.4–0.45 at ρ = 1.1 µm: O(1) relative errors on
        // small powers); bounded at 70 %, reported.
        EXPECT_LT(std::abs(r.worst_band), 0.7)
            << at << ": worst 10° band with >= 1 % of the back power, " << r.worst_band_share * 100
            << " % at " << r.worst_band_centre << "° from θi";
        // Forward (shadow) lobe: Kirchhoff's shadow is the Fraunhofer pattern of the geometric
        // width W (σ peak W²/λ); the true extinction exceeds 2W by the tips' edge (Fock)
        // term, Meep: up to +2.8 % of 2W, squared in the lobe's peak: 8 %.
        EXPECT_NEAR(r.lobe_ratio, 1.0, std::max(0.08, floor_rms(r)))
            << at
            << ": forward lobe (±2λ/W) PO/Meep; tolerance max(8 % edge extinction, 2× "
               "Meep 40/60 RMS)";
        // Totals: PO's scattering width is W (shadow) + reflected power, its extinction
        // exactly 2W (the extinction paradox); Meep's has the edge excess on top (up to 2.8 %
        // of 2W, ≈ 5 % of C_sca) plus its own C_sca error (2× <= 1.4 %): 8 %.
        EXPECT_NEAR(r.sca_po / r.sca_meep, 1.0, 0.08)
            << at << ": scattering width PO ∫σ/Meep box; tolerance 8 % (edge extinction)";
    }
}

// row3: three singles 0.4 µm apart. Within 60° of θi the exits clear the neighbours, and
// 10° bins average the 2.3–3.4° fringes: there it is held to the single's tolerance.
// Beyond 60° the light is blocked by, or reflected again off, the neighbours, which PO
// (outgoing visibility off by default) counts as free: the full L1 is bounded at 25 % and
// reported with and without outgoing visibility.
TEST(PhysicalOpticsFullWave, RowMatchesWithin60DegreesWhereNeighboursDoNotBlock) {
    for (const Residual& r : residuals()) {
        if (r.key.shape != "row3") continue;
        const std::string at = label(r);
        RecordProperty(property(r, "back_l1"), std::to_string(r.l1));
        RecordProperty(property(r, "back_l1_visibility"), std::to_string(r.l1_visibility));
        EXPECT_LT(r.l1_central, std::max(0.08, floor_rms(r)))
            << at
            << ": L1 of the 10° bins within 60° of θi; tolerance max(8 % tip "
               "diffraction, 2× Meep 40/60 RMS)";
        EXPECT_LT(r.l1, 0.25) << at
                              << ": back-hemisphere L1; tolerance 25 %: grazing exits "
                                 "blocked or re-reflected by the neighbours";
        EXPECT_LT(r.l1_visibility, 0.25) << at << ": the same with outgoing visibility";
        // The single's 5 % plus the grazing bins' overcount (1–2 % of the power each, counted
        // up to 3.5× by PO, which lets the blocked flank light out): 8 %.
        EXPECT_NEAR(r.reflected_ratio, 1.0, std::max(0.08, floor_rms(r)))
            << at
            << ": back-hemisphere power PO/Meep; tolerance max(5 % tip diffraction + 3 % "
               "blocked grazing light PO counts, 2× Meep 40/60 RMS)";
        EXPECT_NEAR(r.lobe_ratio, 1.0, std::max(0.08, floor_rms(r)))
            << at << ": forward lobe PO/Meep; tolerance max(8 % edge extinction, 2× Meep RMS)";
        EXPECT_NEAR(r.sca_po / r.sca_meep, 1.0, 0.08)
            << at
            << ": scattering width PO/Meep; tolerance 8 % (edge extinction, up to 4.2 % of "
               "2W in Meep's row)";
    }
}

// Issue 36, acceptance 2: physical optics through interfaces (physical_optics_hybrid_2d.h) on the
// earlier cases, where the melanin core follows the film. Its core is a body that transmits
// (1.6–3.2 µm of melanin: a few per cent at 650 nm) instead of the stack's opaque substrate; the
// rest is the same Kirchhoff integral, so on the single shell and the row of three (inside
// physical optics' validity) it must be as good as the opaque level: the back L1 and the
// back-hemisphere power within Meep's own resolution error (2× its 40/60 RMS) of the opaque
// level's, or better.
TEST(PhysicalOpticsFullWave, LightThroughTheCoreIsNoWorseOnTheEarlierCases) {
    std::printf(
        "| case | pol | θi | λ | back L1 opaque / through | back power opaque / through | "
        "C_sca opaque / through (Meep = 1) |\n");
    for (const Residual& r : residuals()) {
        const auto& [name, pol, ti, lambda] = r.key;
        std::printf("| %s | %s | %d | %d | %.3f / %.3f | %.3f / %.3f | %.3f / %.3f |\n",
                    name.c_str(), pol.c_str(), ti, lambda, r.l1, r.l1_hybrid, r.reflected_ratio,
                    r.reflected_ratio_hybrid, r.sca_po / r.sca_meep, r.sca_hybrid / r.sca_meep);
        if (name == "small") continue;  // outside physical optics (the test below)
        const std::string at = label(r);
        EXPECT_LE(r.l1_hybrid, r.l1 + floor_rms(r)) << at;
        EXPECT_LE(std::abs(r.reflected_ratio_hybrid - 1.0),
                  std::abs(r.reflected_ratio - 1.0) + floor_rms(r))
            << at;
    }
}

// "small" (outer 2.6 × 1.4 µm, 4–6 λ around, tips ρ = 0.46 µm, kρ = 4.4–6.4) is outside
// PO's validity: the test asserts that the failure is large, and larger than the single's
// for the same polarisation and wavelength, and reports it (the validity map's point).
TEST(PhysicalOpticsFullWave, SmallShellIsOutsidePhysicalOptics) {
    std::map<std::tuple<std::string, int>, double> single_l1;
    for (const Residual& r : residuals())
        if (r.key.shape == "single" && r.key.theta_i_deg == 0)
            single_l1[{r.key.polarisation, r.key.lambda_nm}] = r.l1;
    for (const Residual& r : residuals()) {
        if (r.key.shape != "small") continue;
        const std::string at = label(r);
        RecordProperty(property(r, "back_l1"), std::to_string(r.l1));
        RecordProperty(property(r, "reflected_ratio"), std::to_string(r.reflected_ratio));
        RecordProperty(property(r, "scattering_ratio"), std::to_string(r.sca_po / r.sca_meep));
        const double single = single_l1.at({r.key.polarisation, r.key.lambda_nm});
        // Meep's own error here is up to 2 × 14 % RMS (450 nm); PO's must exceed it and the
        // single's several times over to count as PO's failure rather than Meep's.
        EXPECT_GT(r.l1, std::max(0.4, floor_rms(r)))
            << at << ": PO's back-hemisphere L1 for a 2λ-wide shell";
        EXPECT_GT(r.l1, 5.0 * single) << at << ": against the single's " << single;
    }
}

// The media: PO uses optics::keratin()/melanin() (the contract's formulas); Meep ran fitted
// Lorentzians, |Δn|, |Δk| <= 7e-4 at these wavelengths (materials.csv). Swapping them into
// PO moves every back band (>= 1 % of the power) by < 1 %, far below the residuals above.
// The other level of physics against the same reference: ray optics + thin film (each lit
// element's |r|² cos θ ds at its mirror angle, single bounce, geometric_optics_2d.h) has no
// diffraction, so it should miss Meep by more than physical optics does, most on the small
// shell. What ray optics costs is what the wave-validity study maps (studies/README.md).
TEST(PhysicalOpticsFullWave, RayOpticsMissesMoreThanPhysicalOptics) {
    std::printf(
        "| case | pol | θi | λ | back L1 ray optics | back L1 physical optics | "
        "reflected power ray/Meep |\n");
    double single_go = 0.0, single_po = 0.0, small_go = 1e300;
    for (const Residual& r : residuals()) {
        const auto& [name, pol, ti, lambda] = r.key;
        std::printf("| %s | %s | %d | %d | %.3f | %.3f | %.3f |\n", name.c_str(), pol.c_str(), ti,
                    lambda, r.l1_go, r.l1, r.reflected_ratio_go);
        RecordProperty(property(r, "l1_ray_optics"), std::to_string(r.l1_go));
        if (name == "single") {
            single_go = std::max(single_go, r.l1_go);
            single_po = std::max(single_po, r.l1);
        }
        if (name == "small") small_go = std::min(small_go, r.l1_go);
        // Within Meep's own error, ray optics may tie physical optics; it must not beat it by
        // more than that, or diffraction would be making physical optics worse.
        EXPECT_GE(r.l1_go, r.l1 - floor_rms(r)) << label(r);
    }
    EXPECT_GT(single_go, single_po) << "the 10 µm shell: ray optics should miss by more";
    EXPECT_GT(small_go, 0.4) << "the 2.6 µm shell diffracts: ray optics cannot hold there";
}

TEST(PhysicalOpticsFullWave, MeepsFittedMediaChangeLittle) {
    for (const Residual& r : residuals()) {
        RecordProperty(property(r, "fitted_media_change"), std::to_string(r.fitted_change));
        EXPECT_LT(r.fitted_change, 0.01) << label(r);
    }
}

// Energy: for an opaque body what the lit side does not reflect is absorbed, so PO's
// reflected power + Meep's absorption ≈ W. Meep's extinction exceeds 2W by the edge term
// (up to +4.2 %), partly absorbed at the tips, so the sum may exceed W by a few %: [0.98, 1.08].
TEST(PhysicalOpticsFullWave, ReflectedPlusAbsorbedIsTheProjectedWidth) {
    for (const Residual& r : residuals()) {
        if (r.key.shape == "small") continue;  // outside PO, reported in the table
        const double ratio = (r.refl_po + r.abs_meep) / r.width;
        RecordProperty(property(r, "reflected_plus_absorbed_over_w"), std::to_string(ratio));
        EXPECT_GT(ratio, 0.98) << label(r);
        EXPECT_LT(ratio, 1.08) << label(r);
    }
}

// What PO predicts for the scattering width (the extinction paradox): its shadow part
// radiates the projected width W (measured 0.995–0.997 W for single and row3; the rest is
// O(1/kW) ≈ 1 %, kW = 100–150: 1 %), so C_sca = W + reflected power, less that and the two
// parts' interference where the flanks' grazing reflection overlaps the shadow lobe
// (measured −1.0 to −2.2 % in all: 3 %). Meep's C_sca is then compared in the tests above.
TEST(PhysicalOpticsFullWave, PhysicalOpticsScatteringWidthIsWPlusReflected) {
    for (const Residual& r : residuals()) {
        if (r.key.shape == "small") continue;  // kW = 25–36: reported only
        RecordProperty(property(r, "shadow_over_w"), std::to_string(r.shadow_po / r.width));
        EXPECT_NEAR(r.shadow_po / r.width, 1.0, 0.01) << label(r) << ": PO shadow part / W";
        EXPECT_NEAR(r.sca_po / (r.width + r.refl_po), 1.0, 0.03)
            << label(r) << ": PO C_sca / (W + reflected)";
    }
}
}  // namespace
}  // namespace plumage::sim::wave
