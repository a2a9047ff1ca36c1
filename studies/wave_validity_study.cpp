#include "studies/wave_validity_study.h"

#include <omp.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <complex>
#include <fstream>
#include <limits>
#include <map>
#include <span>
#include <sstream>
#include <tuple>

#include <fmt/format.h>

#include "common/constants.h"
#include "common/cpu_time.h"
#include "common/error.h"
#include "common/relative_l1.h"
#include "common/seed.h"
#include "common/version.h"
#include "geometry/barbule.h"
#include "sim/fullwave/full_wave_2d.h"
#include "sim/optics/material.h"
#include "sim/wave/compare/full_wave_reference.h"
#include "sim/wave/compare/ray_optics_validity.h"
#include "studies/plots.h"
#include "studies/sections.h"
#include "studies/staged_directory.h"
#include "studies/study.h"
#include "studies/study_context.h"
#include "studies/study_file.h"
#include "studies/study_progress.h"
#include "studies/wave_validity_live.h"
#include "virtual_gonio/record/hdf5_file.h"
#include "virtual_gonio/record_provenance.h"

namespace plumage::studies {
namespace {

namespace fs = std::filesystem;
namespace wave = sim::wave;

// ---- Read. -------------------------------------------------------------------------------------

struct Barbule {  // Huang 2022's rock-dove cell and row (geometry/barbule.h defaults)
    double b = 0.25, phi0 = -0.37, phi1 = 2.64, d = 0.59, g = 0.3, H = 1.25, mu = -0.35;
};

struct Axis {
    std::string key, label;
    std::vector<double> values;
    // file:line:col of the sweep key: a value's failure is found only when its point is built.
    std::string location;
};

struct Settings {
    std::string name;
    std::uint64_t seed = kDefaultSeed;  // the user's, for provenance
    std::uint64_t row_jitter_seed = 0;  // ctx.stream("wave_validity/row_jitter"): every cell's
    Barbule base;
    double min_length_um = 40.0;
    int min_count = 4;
    double jitter_position = 0.1;  // × H·A
    double jitter_rotation = 3.0 * kDeg;
    int realisations = 8;
    std::vector<double> widths_um;
    std::vector<Axis> axes;
    std::vector<double> wavelengths_nm;
    std::vector<double> incidence_deg;
    wave::RayOpticsValidityOptions options;
    std::string full_wave_key;          // as written; empty: no full-wave check
    wave::FullWaveReference full_wave;  // read before any work starts
    LiveFullWaveSettings live;          // [full_wave] live: full wave computed in the run
};

Barbule read_barbule(ParameterTable t) {
    Barbule b;
    b.b = t.number("b", b.b, between(1e-3, 1.0), "cross-section aspect: semi-minor / semi-major");
    b.phi0 = t.angle_deg("phi0_deg", b.phi0, between(-360.0, 360.0),
                         "first normal azimuth of the arc, deg from +z towards +x");
    b.phi1 = t.angle_deg("phi1_deg", b.phi1, between(-360.0, 360.0),
                         "last normal azimuth of the arc, deg");
    if (!(b.phi0 < b.phi1 && b.phi1 <= b.phi0 + 2.0 * kPi))
        throw InputError(
            fmt::format("{}: barbule.phi1_deg = {:.4g}: expected phi0_deg < phi1_deg "
                        "<= phi0_deg + 360 (phi0_deg = {:.4g})",
                        t.location("phi1_deg"), b.phi1 / kDeg, b.phi0 / kDeg));
    b.d = read_film_thickness_um(t, "film_thickness_um", b.d, "keratin film thickness d");
    b.g = t.number("melanin_depth_um", b.g, between(0.0, 5.0),
                   "air gap between the film and the melanin, µm");
    b.H = t.number("H", b.H, {0.0, 100.0, true, false},
                   "barbule spacing, in units of the semi-major axis A");
    b.mu = t.angle_deg("mu_deg", b.mu, {-90.0, 90.0, true, true}, "tilt of every barbule, deg");
    return b;
}

void read_row(ParameterTable row, Settings& s) {
    s.min_length_um = row.number("min_length_um", s.min_length_um, {0.0, 1000.0, true, false},
                                 "a row holds at least this length of barbules, µm");
    s.min_count = static_cast<int>(
        row.integer("min_count", s.min_count, 1, 1000, "a row holds at least this many barbules"));
    s.jitter_position = row.number("jitter_position", s.jitter_position, between(0.0, 1.0),
                                   "σ of each barbule's displacement per coordinate, in units of "
                                   "the spacing H·A");
    s.jitter_rotation = row.angle_deg("jitter_rotation_deg", s.jitter_rotation, between(0.0, 30.0),
                                      "σ of each barbule's rotation, deg");
    s.realisations = static_cast<int>(row.integer("realisations", s.realisations, 1, 1000,
                                                  "jittered rows averaged (the ensemble)"));
}

void read_sweep(ParameterTable sweep, Settings& s) {
    const Range width_range{0.0, 200.0, true, false};
    s.widths_um = sweep.numbers("widths_um", {0.5, 1, 2, 3, 5, 8, 12, 20}, width_range, 2, 64,
                                "barbule widths 2A, µm, increasing");
    for (std::size_t i = 1; i < s.widths_um.size(); ++i)
        if (!(s.widths_um[i] > s.widths_um[i - 1]))
            throw InputError(
                fmt::format("{}: sweep.widths_um: expected increasing widths ({} "
                            "then {})",
                            sweep.location("widths_um"), s.widths_um[i - 1], s.widths_um[i]));
    s.axes.push_back({"film_thickness_um", "film thickness d (µm)",
                      sweep.numbers("film_thickness_um", {0.2, 0.3, 0.4, 0.5, 0.59},
                                    between(0.0, 5.0), 1, 64, "film thicknesses d of the map, µm"),
                      sweep.location("film_thickness_um")});
    s.axes.push_back({"b", "cross-section aspect b (1 = circle)",
                      sweep.numbers("b", {0.15, 0.25, 0.4, 0.6, 1.0}, between(1e-3, 1.0), 1, 64,
                                    "aspects b of the map (curvature)"),
                      sweep.location("b")});
    s.axes.push_back({"H", "spacing H (units of A)",
                      sweep.numbers("H", {1.1, 1.25, 1.5, 2.0, 3.0}, {0.0, 100.0, true, false}, 1,
                                    64, "spacings H of the map, units of A"),
                      sweep.location("H")});
}

void read_detector(ParameterTable detector, Settings& s) {
    s.options.window.half_angle_rad =
        detector.angle_deg("half_angle_deg", 5.0 * kDeg, {0.0, 45.0, true, false},
                           "detector window half-angle (the goniometer's cone), deg");
    const std::string kernel =
        detector.string("kernel", "gaussian", {"gaussian", "box"},
                        "window shape in θ_s (gaussian: the box's variance)");
    s.options.window.kernel =
        kernel == "box" ? wave::WindowKernel::box : wave::WindowKernel::gaussian;
    s.options.output_step_rad =
        detector.angle_deg("step_deg", 1.0 * kDeg, {0.01, 10.0, false, false},
                           "spacing of the detector centres over the reflected half-space, deg; "
                           "at least 0.01 (17 800 centres over ±89°)");
    s.options.threshold = detector.number("threshold", 0.05, {0.0, 1.0, true, false},
                                          "relative L1 up to which ray optics suffices");
    s.options.outgoing_visibility = detector.boolean(
        "outgoing_visibility", false,
        "both levels drop reflected light that a neighbour blocks (slower: ~100× PO's cost)");
}

void read_live(ParameterTable& t, Settings& s) {
    LiveFullWaveSettings& l = s.live;
    l.on = t.boolean("live", false,
                     "full wave computed in the run for each scene of the maps, within the budget");
    l.resolution_px_per_um =
        t.number("resolution_px_per_um", l.resolution_px_per_um, between(10.0, 200.0),
                 "the live full wave's coarse grid in px/µm (the fine one is 1.5 times finer; "
                 "at least λ/(10 n) of the shortest wavelength)");
    l.decay = t.number("decay", l.decay, {1e-12, 1e-2, true, false},
                       "the live full wave's stop rule: the field's decay from its peak");
    l.budget_minutes = t.number("budget_minutes", l.budget_minutes, non_negative(),
                                "the wall time the live full wave may take, in minutes");
    l.tolerance = t.number("tolerance", l.tolerance, {0.0, 1.0, true, true},
                           "the largest resolution error of a live full-wave reference that "
                           "judges a scene (a fraction)");
    if (!l.on) return;
    // The grid against the λ/(10 n) rule of keratin and melanin (full wave's own check, on two
    // bodies large enough that their thickness does not bind), before any work.
    namespace fw = sim::fullwave;
    fw::CrossSection2d materials;
    materials.bodies.push_back({fw::ellipse({-2.0, 0.0}, 1.0, 1.0), optics::keratin()});
    materials.bodies.push_back({fw::ellipse({2.0, 0.0}, 1.0, 1.0), optics::melanin()});
    const double needed = fw::minimum_resolution_px_per_um(materials, s.wavelengths_nm);
    if (l.resolution_px_per_um < needed)
        throw InputError(fmt::format(
            "{}: full_wave.resolution_px_per_um = {:g}: expected at least {:.4g} px/µm, the "
            "λ/(10 n) rule of keratin and melanin at {:g} nm (full wave's limit)",
            t.location("resolution_px_per_um"), l.resolution_px_per_um, needed,
            s.wavelengths_nm.front()));
}

void read_full_wave(ParameterTable full_wave, const fs::path& source, Settings& s) {
    read_live(full_wave, s);
    s.full_wave_key = full_wave.string(
        "reference", "", {},
        "folder of the full-wave (Meep) reference, far_field.csv and convergence.csv, relative "
        "to the study file's folder");
    if (!s.full_wave_key.empty()) {
        const fs::path folder = source.parent_path() / s.full_wave_key;
        try {
            if (!fs::is_directory(folder))
                throw InputError(fmt::format("{}: expected a folder", folder.string()));
            s.full_wave = wave::read_full_wave_reference(folder);
        } catch (const InputError& e) {
            throw InputError(
                fmt::format("{}: full_wave.reference = \"{}\" (relative to the study "
                            "file's folder): {}",
                            full_wave.location("reference"), s.full_wave_key, e.what()));
        }
    }
}

void check_row_samples(const Settings& s, const std::string& where);

Settings read_settings(StudyContext& ctx) {
    const fs::path& source = ctx.source();
    ParameterTable root = ctx.root();
    Settings s;
    s.name = read_study_name(root, source);
    root.string("study", "wave_validity", {"wave_validity"}, "which study this file describes");
    s.seed = ctx.seed();
    s.row_jitter_seed = ctx.stream("wave_validity/row_jitter");
    s.base = read_barbule(root.table("barbule"));

    read_row(root.table("row"), s);
    read_sweep(root.table("sweep"), s);
    ParameterTable spectrum = root.table("spectrum");
    s.wavelengths_nm = read_wavelengths(spectrum, WavelengthRule{});
    ParameterTable illumination = root.table("illumination");
    s.incidence_deg = illumination.numbers("incidence_deg", {0.0, 30.0}, between(-80.0, 80.0), 1, 8,
                                           "in-plane incidence angles θ_i, deg from +z");

    read_detector(root.table("detector"), s);
    read_full_wave(root.table("full_wave"), source, s);
    root.reject_unused();
    check_row_samples(s, root.table("sweep").location());
    return s;
}

// ---- Build and measure. ------------------------------------------------------------------------

Barbule with_axis(Barbule b, const std::string& axis, double v) {
    if (axis == "film_thickness_um") b.d = v;
    if (axis == "b") b.b = v;
    if (axis == "H") b.H = v;
    return b;
}

int row_count(const Settings& s, const Barbule& b, double a) {
    return std::max(s.min_count, static_cast<int>(std::ceil(s.min_length_um / (b.H * a) - 1e-9)));
}

// The most surface samples one row may have. Physical optics samples every barbule's arc at
// 0.95 of its smallest radius of curvature (b²A at the tips; measure_point) or λ/10, whichever is
// finer, and its shadowing test is quadratic in the samples: the quick map with b = 0.05 (26 000
// samples in its 2 µm row) took 23 s, so 100 000 take about 6 minutes, while b = 0.01 (655 000)
// would take hours and b = 0.001 (6.5 × 10⁷) never ends.
constexpr double kMaxRowSamples = 100000.0;

// A row's surface samples: barbules × arc length / step.
double row_samples(const Settings& s, const Barbule& b, double width_um) {
    const double a = 0.5 * width_um;
    const double step = std::min(0.95 * wave::barbule_row_min_radius_um(a, b.b, b.phi0, b.phi1),
                                 0.1 * s.wavelengths_nm.front() * 1e-3);
    constexpr int kPieces = 256;  // the arc's length by the midpoint rule, to well under 1 %
    double length = 0.0;
    const double dphi = (b.phi1 - b.phi0) / kPieces;
    for (int k = 0; k < kPieces; ++k) {
        const double phi = b.phi0 + (k + 0.5) * dphi;
        length += std::hypot(a * std::sin(phi), b.b * a * std::cos(phi)) * dphi;
    }
    return row_count(s, b, a) * length / step;
}

// Every map point's row within kMaxRowSamples, refused at read time naming the worst one.
void check_row_samples(const Settings& s, const std::string& where) {
    double worst = 0.0, worst_width = 0.0;
    Barbule worst_barbule;
    for (const Axis& axis : s.axes) {
        for (double v : axis.values) {
            const Barbule b = with_axis(s.base, axis.key, v);
            for (double width : s.widths_um) {
                const double samples = row_samples(s, b, width);
                if (samples > worst) worst = samples, worst_width = width, worst_barbule = b;
            }
        }
    }
    if (worst > kMaxRowSamples) {
        throw InputError(fmt::format(
            "{}: the row of b = {}, H = {} at width {} µm needs about {:.3g} surface samples "
            "(step: 0.95 of the tips' radius of curvature b²A, or λ/10); at most {:.0f} (the "
            "shadowing test is quadratic in them: 26 000 took 23 s): raise b or narrow the widths",
            where, worst_barbule.b, worst_barbule.H, worst_width, worst, kMaxRowSamples));
    }
}

wave::Row2d build_row(const Settings& s, const Barbule& b, double a) {
    wave::Row2d row =
        wave::barbule_row_2d(a, b.b, b.phi0, b.phi1, b.d, b.g, b.H, b.mu, row_count(s, b, a));
    row.jitter_position_um = s.jitter_position * b.H * a;
    row.jitter_rotation_rad = s.jitter_rotation;
    row.realisations = s.realisations;
    // One root for every cell (common/seed.h): the cells share their jitter realisations (common
    // random numbers), so a difference between cells is their size's, not the draw's.
    row.seed = s.row_jitter_seed;
    return row;
}

std::string verdict_of(double l1, double floor, double threshold) {
    if (l1 - 2.0 * floor > threshold) return "PO needed";
    if (l1 + 2.0 * floor <= threshold) return "GO suffices";
    return "undecided";
}

WaveValidityPoint measure_point(const Settings& s, const Barbule& b, double value, double width) {
    const double a = 0.5 * width;
    const wave::Row2d row = build_row(s, b, a);
    wave::RayOpticsValidityOptions options = s.options;
    options.max_step_um = 0.95 * wave::barbule_row_min_radius_um(a, b.b, b.phi0, b.phi1);
    std::vector<double> incidence;
    for (double t : s.incidence_deg) incidence.push_back(t * kDeg);
    const wave::RayOpticsValidity2d v =
        wave::compare_ray_and_physical_optics(row, s.wavelengths_nm, incidence, options);
    WaveValidityPoint p;
    p.value = value;
    p.width_um = width;
    p.count = row.count;
    const std::size_t n_l = s.wavelengths_nm.size();
    for (std::size_t i = 0; i < incidence.size(); ++i) {
        const wave::L1WithFloor w = wave::worst_over_wavelengths(v, i, n_l);
        p.relative_l1.push_back(w.relative_l1);
        p.noise_floor.push_back(w.noise_floor);
        p.lambda_at_max_nm.push_back(w.lambda_nm);
        double e = 0.0, se = 0.0;
        for (std::size_t l = 0; l < n_l; ++l) {
            const wave::LevelComparison2d& c = v.cases[i * n_l + l];
            if (std::abs(c.power_error) >= std::abs(e))
                e = c.power_error, se = c.power_error_standard_error;
        }
        p.power_error.push_back(e);
        p.power_error_standard_error.push_back(se);
        p.verdict.push_back(verdict_of(w.relative_l1, w.noise_floor, s.options.threshold));
    }
    p.po_wall_s = v.po_wall_s;
    p.po_cpu_s = v.po_cpu_s;
    p.go_wall_s = v.go_wall_s;
    p.go_cpu_s = v.go_cpu_s;
    return p;
}

// The width above which every L1 at this (incidence, value) is <= threshold (header).
double boundary_width(const WaveValidityMap& m, std::size_t value, std::size_t incidence,
                      std::size_t n_w, double threshold) {
    int last_above = -1;
    for (std::size_t w = 0; w < n_w; ++w)
        if (m.points[value * n_w + w].relative_l1[incidence] > threshold)
            last_above = static_cast<int>(w);
    if (last_above < 0) return 0.0;
    if (last_above == static_cast<int>(n_w) - 1) return std::numeric_limits<double>::infinity();
    const WaveValidityPoint& hi = m.points[value * n_w + last_above];
    const WaveValidityPoint& lo = m.points[value * n_w + last_above + 1];
    const double e0 = std::log(hi.relative_l1[incidence]), e1 = std::log(lo.relative_l1[incidence]);
    const double f = (std::log(threshold) - e0) / (e1 - e0);
    return std::exp(std::log(hi.width_um) + f * (std::log(lo.width_um) - std::log(hi.width_um)));
}

// Beyond the sweep: a power law L1 ∝ W^s fitted (log–log least squares) to the largest widths.
double extrapolated_width(const WaveValidityMap& m, std::size_t value, std::size_t incidence,
                          std::size_t n_w, double threshold) {
    const std::size_t first = n_w > 4 ? n_w - 4 : 0;
    if (n_w - first < 2) return std::numeric_limits<double>::infinity();
    double mx = 0.0, my = 0.0, sxy = 0.0, sxx = 0.0;
    const double n = static_cast<double>(n_w - first);
    for (std::size_t w = first; w < n_w; ++w) {
        mx += std::log(m.points[value * n_w + w].width_um) / n;
        my += std::log(m.points[value * n_w + w].relative_l1[incidence]) / n;
    }
    for (std::size_t w = first; w < n_w; ++w) {
        const double x = std::log(m.points[value * n_w + w].width_um) - mx;
        sxy += x * (std::log(m.points[value * n_w + w].relative_l1[incidence]) - my);
        sxx += x * x;
    }
    const double slope = sxy / sxx;
    if (!(slope < 0.0)) return std::numeric_limits<double>::infinity();
    return std::exp(mx + (std::log(threshold) - my) / slope);
}

std::string width_text(double w, const std::vector<double>& widths) {
    if (w == 0.0) return fmt::format("< {:g} µm", widths.front());
    if (std::isinf(w)) return fmt::format("> {:g} µm", widths.back());
    return fmt::format("{:.2g} µm", w);
}

// ---- Full-wave check. --------------------------------------------------------------------------

// The map's detector centres (ray_optics_validity.cpp): −89° … 89° every output step.
std::vector<double> detector_centres(const wave::RayOpticsValidityOptions& o) {
    std::vector<double> out;
    for (double t = -89.0 * kDeg; t <= 89.0 * kDeg + 1e-9; t += o.output_step_rad) out.push_back(t);
    return out;
}

// Σ|a − b| / Σ b over the centres.
double relative_l1(const std::vector<double>& a, const std::vector<double>& b) {
    RelativeL1 l1;
    for (std::size_t i = 0; i < a.size(); ++i) l1.add(a[i], b[i]);
    return l1.value();
}

double sum_of(const std::vector<double>& v) {
    double s = 0.0;
    for (double x : v) s += x;
    return s;
}

// One reference curve group (shape, θ_i, λ; its polarisations in keys) through the map's window at
// the centres (support: the window's reach beyond a centre).
WaveValidityFullWaveRow full_wave_row_check(const Settings& s, const std::string& shape,
                                            int theta_i_deg, int lambda,
                                            const std::vector<wave::FullWaveKey>& keys,
                                            const std::vector<double>& centres, double support) {
    const wave::DetectorWindow& window = s.options.window;
    throw_if_interrupted(fmt::format("full-wave check, {} at {} nm", shape, lambda));
    const wave::FullWaveShape fs_shape = wave::full_wave_shape(shape);
    const wave::Row2d row = wave::full_wave_row(shape);
    const double ti = theta_i_deg * kDeg, k = 2.0 * kPi / (1e-3 * lambda);
    // PO's grid as the map's: δ = min(0.8π/(k R_max), 0.25°) over the centres ± support.
    const double r_max =
        0.5 * (fs_shape.count - 1) * fs_shape.spacing_um + fs_shape.a_x_um + fs_shape.shell_um;
    const double delta = std::min(0.8 * kPi / (k * r_max), 0.25 * kDeg);
    const double lo = centres.front() - support - delta, hi = centres.back() + support + delta;
    const int n_grid = static_cast<int>(std::ceil((hi - lo) / delta)) + 1;
    std::vector<double> grid(static_cast<std::size_t>(n_grid));
    for (int j = 0; j < n_grid; ++j) grid[j] = lo + (hi - lo) * j / (n_grid - 1.0);
    const double n_pol = static_cast<double>(keys.size());
    std::vector<double> meep(centres.size(), 0.0), go(centres.size(), 0.0);
    std::vector<double> total(grid.size(), 0.0), reflected(grid.size(), 0.0),
        shadow(grid.size(), 0.0);
    WaveValidityFullWaveRow r;
    r.shape = shape;
    r.theta_i_deg = theta_i_deg;
    r.lambda_nm = lambda;
    r.width_um = wave::full_wave_projected_width(shape, ti);
    // One sampling (λ/10, as scattering_width) and lit test serve every part and
    // polarisation: the reflected kernels of the polarisations in pairs, the shadow kernel
    // (r-free, the same for TE and TM) once; total = |U_reflected + U_shadow|².
    const wave::SampledCrossSection2d placed =
        wave::place_row(row, wave::sample_cross_section(row.cell, 1e-4 * lambda), 0);
    std::vector<wave::FarFieldKernel2d> kernels;
    for (const wave::FullWaveKey& key : keys) {
        r.polarisations += (r.polarisations.empty() ? "" : "+") + key.polarisation;
        const wave::FullWaveCurve& curve = s.full_wave.far_field.at(key);
        const std::vector<double> w =
            wave::windowed(curve.theta_s_rad, curve.sigma_um_per_rad, window, centres);
        for (std::size_t i = 0; i < centres.size(); ++i) meep[i] += w[i] / n_pol;
        r.full_wave_floor =
            std::max(r.full_wave_floor, 2.0 * s.full_wave.convergence.at(key).sigma_rms_rel_diff);
        const wave::Incidence2d inc{
            static_cast<double>(lambda), ti,
            key.polarisation == "TM" ? wave::Polarisation2d::tm : wave::Polarisation2d::te};
        kernels.push_back(
            wave::prepare_far_field(row.cell, placed, inc, wave::FarFieldPart::reflected));
        const std::vector<double> g =
            wave::windowed(wave::geometric_rays(kernels.back(), placed), window, centres);
        for (std::size_t i = 0; i < centres.size(); ++i) go[i] += g[i] / n_pol;
    }
    const wave::FarFieldKernel2d shadow_kernel = wave::prepare_far_field(
        row.cell, placed, {static_cast<double>(lambda), ti}, wave::FarFieldPart::shadow);
    std::vector<std::complex<double>> u_shadow, u_first, u_second;
    wave::far_field_pair(shadow_kernel, kernels.front(), grid, u_shadow, u_first);
    std::vector<std::vector<std::complex<double>>> u_reflected = {u_first};
    if (kernels.size() > 1) {
        wave::far_field_pair(kernels[1], kernels[1], grid, u_second, u_first);
        u_reflected.push_back(u_second);
    }
    const double to_sigma = kernels.front().k / (8.0 * kPi);
    for (std::size_t j = 0; j < grid.size(); ++j) {
        shadow[j] = to_sigma * std::norm(u_shadow[j]);
        for (const auto& u : u_reflected) {
            reflected[j] += to_sigma * std::norm(u[j]) / n_pol;
            total[j] += to_sigma * std::norm(u[j] + u_shadow[j]) / n_pol;
        }
    }
    const std::vector<double> po_total = wave::windowed(grid, total, window, centres);
    const std::vector<double> po_reflected = wave::windowed(grid, reflected, window, centres);
    const std::vector<double> po_shadow = wave::windowed(grid, shadow, window, centres);
    r.go_vs_full_wave = relative_l1(go, meep);
    r.po_vs_full_wave = relative_l1(po_total, meep);
    r.po_vs_go = relative_l1(go, po_reflected);  // the map's Σ|W_PO − W_GO| / Σ W_PO
    r.shadow_share = sum_of(po_shadow) / sum_of(po_total);
    return r;
}

// Every reference curve (shape, θ_i, λ), unpolarised over the polarisations it has, through the
// map's window at the map's centres: GO vs Meep, PO (total) vs Meep, PO (reflected) vs GO.
std::vector<WaveValidityFullWaveRow> full_wave_check(const Settings& s) {
    using Group = std::tuple<std::string, int, int>;
    std::map<Group, std::vector<wave::FullWaveKey>> groups;
    for (const auto& [key, curve] : s.full_wave.far_field)
        groups[{key.shape, key.theta_i_deg, key.lambda_nm}].push_back(key);
    const std::vector<double> centres = detector_centres(s.options);
    const wave::DetectorWindow& window = s.options.window;
    const double support = window.kernel == wave::WindowKernel::box
                               ? window.half_angle_rad
                               : 4.0 * window.half_angle_rad / std::sqrt(3.0);
    std::vector<WaveValidityFullWaveRow> out;
    for (const auto& [group, keys] : groups) {
        const auto& [shape, theta_i_deg, lambda] = group;
        out.push_back(full_wave_row_check(s, shape, theta_i_deg, lambda, keys, centres, support));
    }
    return out;
}

// How far the map's PO − GO (d) measures ray optics' error against full wave, from PO's own
// error against full wave (p) and Meep's floor (f): "fair" when max(p, f) <= d/2 (then ray
// optics' error is d to within half of it), "PO dominates" when p >= d (ray optics' error is then
// mostly what PO misses too), else "rough".
std::string reading_of(const WaveValidityFullWaveRow& r) {
    if (std::max(r.po_vs_full_wave, r.full_wave_floor) <= 0.5 * r.po_vs_go) return "fair";
    if (r.po_vs_full_wave >= r.po_vs_go) return "PO dominates";
    return "rough";
}

struct Span {
    double lo = std::numeric_limits<double>::infinity(), hi = 0.0;
    void add(double v) { lo = std::min(lo, v), hi = std::max(hi, v); }
    std::string percent() const { return fmt::format("{:.1f}–{:.1f} %", 100.0 * lo, 100.0 * hi); }
};

struct ShapeSummary {
    double width = 0.0;  // one cell's, at normal incidence
    Span go, po, po_go, floor;
    int curves = 0, fair = 0, rough = 0, dominated = 0;
    int within = 0, within_beyond_floor = 0, beyond = 0;  // ray optics vs the threshold
};

std::map<std::string, ShapeSummary> summarise(const std::vector<WaveValidityFullWaveRow>& rows,
                                              double threshold) {
    std::map<std::string, ShapeSummary> out;
    for (const WaveValidityFullWaveRow& r : rows) {
        ShapeSummary& m = out[r.shape];
        m.width = std::max(m.width, r.width_um / wave::full_wave_shape(r.shape).count);
        m.go.add(r.go_vs_full_wave);
        m.po.add(r.po_vs_full_wave);
        m.po_go.add(r.po_vs_go);
        m.floor.add(r.full_wave_floor);
        ++m.curves;
        const std::string reading = reading_of(r);
        m.fair += reading == "fair";
        m.rough += reading == "rough";
        m.dominated += reading == "PO dominates";
        m.within += r.go_vs_full_wave <= threshold;
        m.within_beyond_floor += r.go_vs_full_wave + r.full_wave_floor <= threshold;
        m.beyond += r.go_vs_full_wave - r.full_wave_floor > threshold;
    }
    return out;
}

// The map's PO − GO at the sweep width nearest (in log) to w: its span over every map point of
// that width and every incidence.
Span map_at_width(const WaveValidityResult& r, double w, double& width) {
    std::size_t best = 0;
    for (std::size_t i = 1; i < r.widths_um.size(); ++i)
        if (std::abs(std::log(r.widths_um[i] / w)) < std::abs(std::log(r.widths_um[best] / w)))
            best = i;
    width = r.widths_um[best];
    Span out;
    const std::size_t n_w = r.widths_um.size();
    for (const WaveValidityMap& m : r.maps)
        for (std::size_t v = 0; v < m.values.size(); ++v)
            for (double l1 : m.points[v * n_w + best].relative_l1) out.add(l1);
    return out;
}

// The generated verdict (report, HDF5 attribute): per shape, how well PO − GO measures ray
// optics' error, how the map's number at that width compares, and the map's headline checked on
// the 10 µm shells.
std::string full_wave_verdict(const WaveValidityResult& r) {
    const auto shapes = summarise(r.full_wave, r.threshold);
    std::ostringstream out;
    for (const auto& [shape, m] : shapes) {
        double width = 0.0;
        const Span map = map_at_width(r, m.width, width);
        const char* against = map.lo > m.go.hi   ? "above"
                              : map.hi < m.go.lo ? "below"
                                                 : "overlapping";
        out << fmt::format(
            "- **{}** ({:.3g} µm wide{}): ray optics against full wave {}, physical optics "
            "against full wave {}, PO − GO {} (Meep's floor {}). PO − GO is a fair measure of "
            "ray optics' error on {} of {} curves, a rough one on {}, and PO's own error "
            "dominates on {}{}. The map's PO − GO at the nearest width ({:g} µm, barbule arcs) "
            "is {}: {} ray optics' error against full wave here.\n",
            shape, m.width, shape == "row3" ? " each, three in a row" : "", m.go.percent(),
            m.po.percent(), m.po_go.percent(), m.floor.percent(), m.fair, m.curves, m.rough,
            m.dominated,
            m.dominated * 2 > m.curves
                ? " (ray optics and physical optics miss full wave alike: what PO − GO leaves "
                  "out, both lack)"
                : "",
            width, map.percent(), against);
    }
    out << "\n";
    for (const char* shape : {"single", "row3"}) {
        const auto found = shapes.find(shape);
        if (found == shapes.end()) continue;
        const ShapeSummary& m = found->second;
        const std::string call =
            m.beyond > 0 ? fmt::format(
                               "borne out: beyond the threshold and Meep's floor on {} of "
                               "{} curves",
                               m.beyond, m.curves)
            : m.within == m.curves
                ? fmt::format(
                      "not borne out: ray optics is within the threshold on all {} "
                      "curves (on {} of them by more than Meep's floor), so the map's excess at "
                      "these widths is its barbule arcs' own, not a closed shell's",
                      m.curves, m.within_beyond_floor)
                : fmt::format(
                      "undecided within Meep's floor ({} of {} curves within the "
                      "threshold)",
                      m.within, m.curves);
        out << fmt::format(
            "The map's headline (ray optics off by more than {:g} % for rows up to {:g} µm), "
            "checked on **{}**: ray optics against full wave {}; {}{}.\n\n",
            100.0 * r.threshold, r.widths_um.back(), shape, m.go.percent(), call,
            m.beyond > 0 && m.dominated * 2 > m.curves
                ? "; but physical optics misses full wave by as much, so the cause is not the "
                  "diffraction the map measures (PO − GO) but what both levels lack"
                : "");
    }
    return out.str();
}

// ---- Outputs. ----------------------------------------------------------------------------------

std::vector<double> gather(const WaveValidityMap& m, std::size_t n_inc,
                           const std::vector<double> WaveValidityPoint::*member) {
    // [incidence][value][width]
    std::vector<double> out;
    const std::size_t n = m.points.size();
    for (std::size_t i = 0; i < n_inc; ++i)
        for (std::size_t k = 0; k < n; ++k) out.push_back((m.points[k].*member)[i]);
    return out;
}

void write_map(record::Hdf5Writer& h5, const std::string& g, const WaveValidityMap& m,
               const WaveValidityResult& r) {
    const std::uint64_t n_inc = r.incidence_deg.size(), n_v = m.values.size(),
                        n_w = r.widths_um.size();
    using P = WaveValidityPoint;
    h5.write(g + "/values", std::span<const double>(m.values), {n_v},
             {{"units", m.axis == "film_thickness_um" ? "µm" : "1"},
              {"description", "the map's second axis: " + m.label}});
    auto per_point = [&](const std::string& name, auto member, const std::string& units,
                         const std::string& description) {
        h5.write(g + "/" + name, std::span<const double>(gather(m, n_inc, member)),
                 {n_inc, n_v, n_w},
                 {{"units", units}, {"description", description + ", [incidence][value][width]"}});
    };
    per_point("relative_l1", &P::relative_l1, "1",
              "PO vs GO relative L1 Σ|W_PO − W_GO| / Σ W_PO over the detector centres, the "
              "largest over the wavelengths");
    per_point("relative_l1_noise_floor", &P::noise_floor, "1",
              "that L1's noise floor sqrt(2/π) Σ s_θ / Σ W_PO (s_θ: standard error of the "
              "ensemble mean of W_PO − W_GO)");
    per_point("wavelength_at_max_nm", &P::lambda_at_max_nm, "nm",
              "the wavelength of the largest L1");
    per_point("power_error", &P::power_error, "1",
              "P_PO / P_GO − 1 of the power into the reflected half-space, the largest in "
              "magnitude over the wavelengths");
    per_point("power_error_standard_error", &P::power_error_standard_error, "1",
              "its standard error over the ensemble");
    auto per_cell = [&](const std::string& name, double P::*member, const std::string& d) {
        std::vector<double> v;
        for (const P& p : m.points) v.push_back(p.*member);
        h5.write(g + "/" + name, std::span<const double>(v), {n_v, n_w},
                 {{"units", "s"},
                  {"description", d + ", all wavelengths, incidences, "
                                      "polarisations and realisations"}});
    };
    per_cell("po_wall_s", &P::po_wall_s, "wall time of physical optics");
    per_cell("po_cpu_s", &P::po_cpu_s, "process CPU time of physical optics");
    per_cell("go_wall_s", &P::go_wall_s, "wall time of geometric optics");
    per_cell("go_cpu_s", &P::go_cpu_s, "process CPU time of geometric optics");
    std::vector<double> count;
    for (const P& p : m.points) count.push_back(p.count);
    h5.write(g + "/barbules_per_row", std::span<const double>(count), {n_v, n_w},
             {{"units", "1"}, {"description", "barbules in each row"}});
    std::vector<double> boundary;
    for (const auto& row : m.boundary_um) boundary.insert(boundary.end(), row.begin(), row.end());
    h5.write(g + "/boundary_width_um", std::span<const double>(boundary), {n_inc, n_v},
             {{"units", "µm"},
              {"description",
               "the width above which every L1 is <= the threshold, log-interpolated; 0: below "
               "the smallest width, inf: above the largest, [incidence][value]"}});
    std::vector<double> extrapolated;
    for (const auto& row : m.extrapolated_um)
        extrapolated.insert(extrapolated.end(), row.begin(), row.end());
    h5.write(g + "/extrapolated_boundary_um", std::span<const double>(extrapolated), {n_inc, n_v},
             {{"units", "µm"},
              {"description",
               "where the boundary lies beyond the largest width: the width at which a power law "
               "fitted (log-log least squares) to the L1 of the largest 4 widths reaches the "
               "threshold; inf when it does not fall; 0 when the boundary is inside the sweep, "
               "[incidence][value]"}});
    h5.set_attribute(g, "axis", m.axis);
    h5.set_attribute(g, "axis_label", m.label);
}

void write_common(record::Hdf5Writer& h5, const WaveValidityResult& r, const Settings& s) {
    h5.write(
        "widths_um", std::span<const double>(r.widths_um), {r.widths_um.size()},
        {{"units", "µm"}, {"description", "barbule width 2A (the cross-section's major axis)"}});
    h5.write("incidence_deg", std::span<const double>(r.incidence_deg), {r.incidence_deg.size()},
             {{"units", "deg"}, {"description", "in-plane incidence θ_i from +z towards +x"}});
    h5.write("wavelengths_nm", std::span<const double>(r.wavelengths_nm), {r.wavelengths_nm.size()},
             {{"units", "nm"}, {"description", "wavelengths (vacuum); unpolarised (TE + TM)/2"}});
    h5.set_attribute("/", "threshold", r.threshold);
    h5.set_attribute("/", "window_half_angle_deg", s.options.window.half_angle_rad / kDeg);
    h5.set_attribute("/", "window_kernel",
                     s.options.window.kernel == wave::WindowKernel::box
                         ? "box"
                         : "gaussian (the box's variance, σ = half-angle/√3)");
    h5.set_attribute("/", "max_noise_floor", r.max_noise_floor);
}

void write_full_wave(record::Hdf5Writer& h5, const WaveValidityResult& r, const Settings& s) {
    const std::uint64_t n = r.full_wave.size();
    using F = WaveValidityFullWaveRow;
    auto column = [&](const std::string& name, double F::*member, const std::string& units,
                      const std::string& description) {
        std::vector<double> v;
        for (const F& row : r.full_wave) v.push_back(row.*member);
        h5.write("full_wave/" + name, std::span<const double>(v), {n},
                 {{"units", units}, {"description", description + ", [curve]"}});
    };
    column("theta_i_deg", &F::theta_i_deg, "deg", "incidence θ_i of the reference curve");
    column("lambda_nm", &F::lambda_nm, "nm", "wavelength of the reference curve");
    column("projected_width_um", &F::width_um, "µm", "the shape's projected width at θ_i");
    const std::string metric =
        "relative L1 through the map's detector window at the map's centres over |θ_s| < 90°, "
        "unpolarised over the curve's polarisations: ";
    column("go_vs_full_wave", &F::go_vs_full_wave, "1",
           metric + "Σ|W_GO − W_Meep| / Σ W_Meep (Meep's σ is the scattered field)");
    column("po_vs_full_wave", &F::po_vs_full_wave, "1",
           metric + "Σ|W_PO,total − W_Meep| / Σ W_Meep (PO's reflected + shadow parts)");
    column("po_vs_go", &F::po_vs_go, "1",
           metric + "Σ|W_PO,reflected − W_GO| / Σ W_PO,reflected (the map's number)");
    column("full_wave_floor", &F::full_wave_floor, "1",
           "Meep's own error: 2 × its 40 vs 60 px/µm RMS relative difference of σ (pointwise, "
           "where σ > 1 % of its peak; the larger polarisation; not windowed)");
    column("shadow_share", &F::shadow_share, "1",
           "Σ W_PO,shadow / Σ W_PO,total over the centres: what GO lacks (it has no shadow part)");
    std::string shapes, pols;
    for (const F& row : r.full_wave) {
        shapes += (shapes.empty() ? "" : ",") + row.shape;
        pols += (pols.empty() ? "" : ",") + row.polarisations;
    }
    h5.set_attribute("full_wave", "shapes", shapes);
    h5.set_attribute("full_wave", "polarisations", pols);
    h5.set_attribute("full_wave", "reference", s.full_wave_key);
    h5.set_attribute("full_wave", "verdict", r.full_wave_verdict);
}

void write_record(const fs::path& path, const WaveValidityResult& r, const Settings& s,
                  const std::string& text, double cpu_s) {
    record::Hdf5Writer h5(path);
    write_common(h5, r, s);
    for (const WaveValidityMap& m : r.maps) write_map(h5, "maps/" + m.axis, m, r);
    if (!r.full_wave.empty()) write_full_wave(h5, r, s);
    if (s.live.on) write_live(h5, r, s.live);
    write_spongy(h5, r.spongy);
    h5.set_attribute("/", "description",
                     "Physical optics (reflected part) against geometric optics (mirror rays) "
                     "for 2D barbule rows: sim/wave/compare/ray_optics_validity.h");
    h5.set_attribute("/", "outgoing_visibility", s.options.outgoing_visibility ? "on" : "off");
    h5.set_attribute("/", "realisations", static_cast<double>(s.realisations));
    gonio::write_provenance(h5, {"physical_optics_2d vs geometric_optics_2d", s.seed,
                                 omp_get_max_threads(), r.wall_seconds, cpu_s, text});
    h5.commit();
}

// One figure's data: the map alone (studies/plots.py build_wave_validity_map).
void write_figure(const fs::path& path, const WaveValidityMap& m, const WaveValidityResult& r,
                  const Settings& s) {
    record::Hdf5Writer h5(path);
    write_common(h5, r, s);
    write_map(h5, "map", m, r);
    h5.set_attribute("/", "title",
                     fmt::format("PO vs GO: relative L1 (largest over {}–{} nm), width × {}",
                                 r.wavelengths_nm.front(), r.wavelengths_nm.back(), m.label));
    h5.commit();
}

void write_csv(const fs::path& path, const WaveValidityResult& r) {
    std::ofstream csv(path);
    csv << "axis,value,width_um,barbules,theta_i_deg,relative_l1_max_over_wavelengths,"
           "noise_floor,wavelength_at_max_nm,power_error,power_error_standard_error,verdict,"
           "po_wall_s,po_cpu_s,go_wall_s,go_cpu_s\n";
    for (const WaveValidityMap& m : r.maps)
        for (const WaveValidityPoint& p : m.points)
            for (std::size_t i = 0; i < r.incidence_deg.size(); ++i)
                csv << fmt::format(
                    "{},{:.6g},{:.6g},{},{:g},{:.6g},{:.6g},{:g},{:.6g},{:.6g},{},"
                    "{:.4g},{:.4g},{:.4g},{:.4g}\n",
                    m.axis, p.value, p.width_um, p.count, r.incidence_deg[i], p.relative_l1[i],
                    p.noise_floor[i], p.lambda_at_max_nm[i], p.power_error[i],
                    p.power_error_standard_error[i], p.verdict[i], p.po_wall_s, p.po_cpu_s,
                    p.go_wall_s, p.go_cpu_s);
    if (!csv) throw IoError(fmt::format("cannot write {}", path.string()));
}

void write_full_wave_csv(const fs::path& path, const WaveValidityResult& r) {
    std::ofstream csv(path);
    csv << "shape,polarisations,theta_i_deg,lambda_nm,projected_width_um,go_vs_full_wave,"
           "po_vs_full_wave,po_vs_go,full_wave_floor,shadow_share\n";
    for (const WaveValidityFullWaveRow& f : r.full_wave)
        csv << fmt::format("{},{},{:g},{:g},{:.6g},{:.6g},{:.6g},{:.6g},{:.6g},{:.6g}\n", f.shape,
                           f.polarisations, f.theta_i_deg, f.lambda_nm, f.width_um,
                           f.go_vs_full_wave, f.po_vs_full_wave, f.po_vs_go, f.full_wave_floor,
                           f.shadow_share);
    if (!csv) throw IoError(fmt::format("cannot write {}", path.string()));
}

std::string full_wave_section(const WaveValidityResult& r, const Settings& s) {
    std::ostringstream md;
    md << "## Against full wave\n\n"
       << fmt::format(
              "The Meep reference `{}` (tests/reference/barbule_2d/README.md: keratin-coated "
              "melanin ellipses, \"single\" 10.6 × 4.6 µm, \"small\" 2.6 × 1.4 µm, \"row3\" three "
              "singles 11 µm apart; σ(θ_s) at 60 px/µm), read through **the map's metric**: the "
              "same window, the same centres over |θ_s| < 90°, relative L1, unpolarised (TE + "
              "TM)/2. GO vs Meep and PO vs Meep are Σ|W − W_Meep| / Σ W_Meep; Meep's σ is the "
              "scattered field, so PO enters with its total part (reflected + shadow) and GO, "
              "which has no shadow part, with its rays alone; *shadow* is the shadow part's "
              "share of PO's windowed total over the half-space (what GO misses by "
              "construction). PO vs GO is the map's own number (PO's reflected part). Meep's "
              "floor is 2 × its 40 vs 60 px/µm RMS relative difference of σ (pointwise where σ > "
              "1 % of its peak, the larger polarisation): the pointwise form, as the 40 px/µm "
              "curves are not shipped; windowing averages pointwise errors, so it is the "
              "conservative one. The shells are not the map's barbule arcs (closed, no air gap, "
              "no jitter): widths are comparable, shapes only roughly.{}\n\n",
              s.full_wave_key,
              s.options.outgoing_visibility
                  ? " The map runs with outgoing visibility; this check runs without it (PO's "
                    "total part has none), so its PO vs GO is not the map's number there."
                  : "");
    md << "| shape | pol. | θ_i (°) | λ (nm) | width (µm) | GO vs Meep | PO vs Meep | PO vs GO | "
          "Meep floor | shadow | PO − GO as GO's error "
          "|\n|---|---|---|---|---|---|---|---|---|---|---|\n";
    for (const WaveValidityFullWaveRow& f : r.full_wave)
        md << fmt::format(
            "| {} | {} | {:g} | {:g} | {:.3g} | {:.1f} % | {:.1f} % | {:.1f} % | {:.1f} % | {:.2f} "
            "% | {} |\n",
            f.shape, f.polarisations, f.theta_i_deg, f.lambda_nm, f.width_um,
            100.0 * f.go_vs_full_wave, 100.0 * f.po_vs_full_wave, 100.0 * f.po_vs_go,
            100.0 * f.full_wave_floor, 100.0 * f.shadow_share, reading_of(f));
    md << "\n**Verdict.** Per curve, PO − GO is a *fair* measure of ray optics' error when PO's "
          "own error against full wave and Meep's floor are both at most half of it (ray optics' "
          "error is then PO − GO to within half), *PO dominates* when PO vs Meep >= PO − GO, "
          "else *rough*; per shape the spans over its curves:\n\n"
       << r.full_wave_verdict << "\n";
    return md.str();
}

std::string boundary_table(const WaveValidityResult& r) {
    std::ostringstream md;
    md << "| map axis | value |";
    for (double t : r.incidence_deg) md << fmt::format(" 5 % boundary at θ_i = {:g}° |", t);
    md << "\n|---|---|";
    for (std::size_t i = 0; i < r.incidence_deg.size(); ++i) md << "---|";
    md << "\n";
    for (const WaveValidityMap& m : r.maps)
        for (std::size_t v = 0; v < m.values.size(); ++v) {
            md << fmt::format("| {} | {:g} |", m.label, m.values[v]);
            for (std::size_t i = 0; i < r.incidence_deg.size(); ++i) {
                md << " " << width_text(m.boundary_um[i][v], r.widths_um);
                const double e = m.extrapolated_um[i][v];
                if (e > 0.0)
                    md << (std::isinf(e)
                               ? std::string(" (L1 not falling)")
                               : fmt::format(" (extrapolated ≈ {:.{}f} µm)", e, e < 10.0 ? 1 : 0));
                md << " |";
            }
            md << "\n";
        }
    return md.str();
}

std::string cost_table(const WaveValidityResult& r) {
    // Per width, summed over the maps' points of that width.
    std::ostringstream md;
    md << "| width 2A (µm) | barbules per row (base) | PO wall (s) | PO CPU (s) | GO wall (s) | GO "
          "CPU (s) | PO/GO wall |\n|---|---|---|---|---|---|---|\n";
    const std::size_t n_w = r.widths_um.size();
    for (std::size_t w = 0; w < n_w; ++w) {
        double pw = 0, pc = 0, gw = 0, gc = 0;
        int points = 0, count = 0;
        for (const WaveValidityMap& m : r.maps)
            for (std::size_t v = 0; v < m.values.size(); ++v) {
                const WaveValidityPoint& p = m.points[v * n_w + w];
                pw += p.po_wall_s, pc += p.po_cpu_s, gw += p.go_wall_s, gc += p.go_cpu_s;
                ++points;
                if (m.axis == "b" && v == 0) count = p.count;
            }
        md << fmt::format("| {:g} | {} | {:.3g} | {:.3g} | {:.3g} | {:.3g} | {:.0f} |\n",
                          r.widths_um[w], count, pw / points, pc / points, gw / points, gc / points,
                          gw > 0.0 ? pw / gw : 0.0);
    }
    return md.str();
}

void write_report(const fs::path& path, const WaveValidityResult& r, const Settings& s,
                  const std::string& text, const std::string& run_time,
                  const std::vector<std::string>& pngs) {
    std::ofstream md(path);
    const Barbule& b = s.base;
    md << "# Where ray optics ends: physical optics against geometric optics for barbule rows\n\n"
       << fmt::format(
              "Physical optics (PO, sim/wave/surface/physical_optics_2d.h: the Kirchhoff far field "
              "of "
              "each lit element's thin-film reflection, coherent over the row) against geometric "
              "optics (GO, sim/wave/surface/geometric_optics_2d.h: the same elements' |r|² cos θ "
              "ds sent "
              "into their mirror directions). Both: single bounce, same samples, lit test and "
              "stack, outgoing visibility {}; PO − GO is diffraction alone. Rows of rock-dove "
              "barbule cross-sections (b = {}, φ0 = {:.2f}, φ1 = {:.2f} rad, d = {} µm over a {} "
              "µm air gap over melanin, H = {}, μ = {:.2f} rad; one parameter varied per map), "
              "at least {} barbules and {} µm long, jittered by {} H·A in position and {:.1f}° "
              "in rotation, {} realisations; {} wavelengths {}–{} nm, unpolarised (TE + TM)/2; "
              "θ_i = {}°.\n\n",
              s.options.outgoing_visibility ? "on" : "off", b.b, b.phi0, b.phi1, b.d, b.g, b.H,
              b.mu, s.min_count, s.min_length_um, s.jitter_position, s.jitter_rotation / kDeg,
              s.realisations, r.wavelengths_nm.size(), r.wavelengths_nm.front(),
              r.wavelengths_nm.back(), fmt::join(r.incidence_deg, "°, "))
       << fmt::format(
              "**Metric.** Both far fields read through a {} detector window of half-angle "
              "{:g}° (centres every {:g}° over the reflected half-space): relative L1 = Σ|W_PO − "
              "W_GO| / Σ W_PO, **the largest over the wavelengths** (the wavelength is in "
              "wave_validity.csv). Its noise floor is sqrt(2/π) Σ s_θ / Σ W_PO, s_θ the standard "
              "error of the ensemble mean of W_PO − W_GO: the L1 that the finite ensemble alone "
              "would show. Threshold {:g} %.\n\n",
              s.options.window.kernel == wave::WindowKernel::box ? "box"
                                                                 : "Gaussian (the box's variance)",
              s.options.window.half_angle_rad / kDeg, s.options.output_step_rad / kDeg,
              100.0 * r.threshold);
    md << "## Maps\n\n";
    for (std::size_t k = 0; k < r.maps.size(); ++k)
        md << fmt::format("![width × {}]({})\n\n", r.maps[k].label, pngs[k]);
    md << "## The width below which ray optics is off by more than "
       << fmt::format("{:g} %", 100.0 * r.threshold) << "\n\n"
       << boundary_table(r)
       << "\nExtrapolated: a power law L1 ∝ (2A)^s fitted to the largest four widths, carried to "
          "the threshold; an indication of the scale, not a measurement (the L1 there includes "
          "its noise floor).\n\n";
    if (!r.full_wave.empty()) md << full_wave_section(r, s);
    if (s.live.on) md << live_section(r, s.live);
    md << spongy_section(r.spongy);
    md << "## Cost of each level\n\nMean per map point (all wavelengths, incidences, both "
          "polarisations, every realisation), by width:\n\n"
       << cost_table(r)
       << fmt::format(
              "\nTotals: PO {:.1f} s wall ({:.1f} s CPU), GO {:.2f} s wall ({:.2f} s "
              "CPU), on {} threads. The lit test and the stack amplitudes are computed once per "
              "row and charged to both levels (either alone would pay them), so the two totals "
              "overlap; GO's time is mostly that shared part.\n\n",
              r.po_wall_s, r.po_cpu_s, r.go_wall_s, r.go_cpu_s, omp_get_max_threads());
    const int total = r.po_needed + r.go_suffices + r.undecided;
    md << "## Statistical verdict\n\n"
       << fmt::format(
              "Per point and incidence: *PO needed* when L1 − 2·floor > {0:g} %, *GO suffices* "
              "when L1 + 2·floor <= {0:g} %, else *undecided*. Of {1} comparisons: {2} PO needed, "
              "{3} GO suffices, {4} undecided. The largest noise floor is {5:.2g} % ({6}).\n\n",
              100.0 * r.threshold, total, r.po_needed, r.go_suffices, r.undecided,
              100.0 * r.max_noise_floor,
              r.undecided == 0 ? "every call is decided beyond twice its floor"
                               : "the undecided points sit within twice their floor of the "
                                 "threshold: more realisations would decide them");
    md << "*Validity of both levels:* barbules whose tips' radius of curvature (b²A) falls below "
          "the film thickness or λ are outside PO's planar-stack assumption too; there a *PO "
          "needed* means that ray optics fails, not that PO holds (sim/wave/"
          "ray_optics_validity.h).\n\n";
    md << run_time;
    md << fmt::format("---\nplumage {}\n\n## Study file\n\n```toml\n{}\n```\n", kVersion, text);
    if (!md) throw IoError(fmt::format("cannot write {}", path.string()));
}

// Build and measure one map (width × axis); points already measured for another map (the base
// point) are taken from `measured`.
WaveValidityMap measure_map(const Settings& s, const Axis& axis,
                            std::map<std::array<double, 4>, WaveValidityPoint>& measured) {
    WaveValidityMap m;
    m.axis = axis.key;
    m.label = axis.label;
    m.values = axis.values;
    for (double v : axis.values) {
        const Barbule b = with_axis(s.base, axis.key, v);
        for (double w : s.widths_um) {
            throw_if_interrupted(fmt::format("{} = {:g}, width {:g} µm", axis.key, v, w));
            const std::array<double, 4> key = {b.b, b.d, b.H, w};
            try {
                auto found = measured.find(key);
                if (found == measured.end())
                    found = measured.emplace(key, measure_point(s, b, v, w)).first;
                m.points.push_back(found->second);
                m.points.back().value = v;
            } catch (const InputError& e) {
                throw InputError(fmt::format("{}: sweep.{} = {:g}, width {:g} µm: {}",
                                             axis.location, axis.key, v, w, e.what()));
            }
        }
    }
    return m;
}

// Compare: each map's 5 % boundary per axis value and incidence, and the verdict counts.
void compare_map(WaveValidityMap& m, std::size_t n_inc, std::size_t n_w, WaveValidityResult& r) {
    m.boundary_um.assign(n_inc, std::vector<double>(m.values.size()));
    m.extrapolated_um.assign(n_inc, std::vector<double>(m.values.size(), 0.0));
    for (std::size_t i = 0; i < n_inc; ++i)
        for (std::size_t v = 0; v < m.values.size(); ++v) {
            m.boundary_um[i][v] = boundary_width(m, v, i, n_w, r.threshold);
            if (std::isinf(m.boundary_um[i][v]))
                m.extrapolated_um[i][v] = extrapolated_width(m, v, i, n_w, r.threshold);
        }
    for (const WaveValidityPoint& p : m.points) {
        for (std::size_t i = 0; i < n_inc; ++i) {
            r.max_noise_floor = std::max(r.max_noise_floor, p.noise_floor[i]);
            r.po_needed += p.verdict[i] == "PO needed";
            r.go_suffices += p.verdict[i] == "GO suffices";
            r.undecided += p.verdict[i] == "undecided";
        }
    }
}

// The maps' scenes for the live full wave: each (barbule, width, incidence) once, named by the
// map that varies it ("base" where it is the base barbule), with the map's verdict there.
std::vector<LiveScene> live_scenes(const Settings& s, const WaveValidityResult& r) {
    std::map<std::array<double, 5>, bool> seen;
    std::vector<LiveScene> out;
    const std::size_t n_w = s.widths_um.size();
    for (std::size_t k = 0; k < s.axes.size(); ++k) {
        const Axis& axis = s.axes[k];
        for (std::size_t v = 0; v < axis.values.size(); ++v) {
            const Barbule b = with_axis(s.base, axis.key, axis.values[v]);
            const bool base = b.b == s.base.b && b.d == s.base.d && b.H == s.base.H;
            for (std::size_t w = 0; w < n_w; ++w)
                for (std::size_t i = 0; i < s.incidence_deg.size(); ++i) {
                    if (!seen.emplace(std::array{b.b, b.d, b.H, s.widths_um[w], s.incidence_deg[i]},
                                      true)
                             .second)
                        continue;
                    out.push_back(
                        {base ? "base" : fmt::format("{} = {:g}", axis.key, axis.values[v]),
                         0.5 * s.widths_um[w], b.b, b.phi0, b.phi1, b.d, b.g, b.H, b.mu,
                         s.incidence_deg[i], r.maps[k].points[v * n_w + w].verdict[i]});
                }
        }
    }
    return out;
}

// Report: record, CSVs, figures and report.md, staged and committed together.
fs::path write_outputs(StudyContext& ctx, const Settings& s, WaveValidityResult& r, double cpu0) {
    const StudyProgress& clock = ctx.clock();
    const std::string& study_text = ctx.text();
    clock.say("report");  // report
    const fs::path dir = ctx.out();
    r.wall_seconds = clock.elapsed_s();
    write_record(dir / "wave_validity.h5", r, s, study_text, process_cpu_seconds() - cpu0);
    write_csv(dir / "wave_validity.csv", r);
    if (!r.full_wave.empty()) write_full_wave_csv(dir / "full_wave_check.csv", r);
    if (s.live.on) write_live_csv(dir / "full_wave_live.csv", r);
    std::vector<PlotJob> jobs;
    std::vector<std::string> pngs;
    for (const WaveValidityMap& m : r.maps) {
        const std::string stem = "width_x_" + m.axis;
        write_figure(dir / (stem + ".h5"), m, r, s);
        jobs.push_back({"wave_validity_map", dir / (stem + ".h5"), dir / (stem + ".png")});
        pngs.push_back(stem + ".png");
    }
    if (const int worst = worst_physical_optics_scene(r); worst >= 0) {
        write_live_figure(dir / "live_spectra.h5", r.live[worst], r.threshold);
        jobs.push_back({"level_spectra", dir / "live_spectra.h5", dir / "live_spectra.png"});
    }
    clock.say("plots");
    run_plots(jobs, dir / "plots.csv");
    write_report(dir / "report.md", r, s, study_text, ctx.run_time_by_stage(), pngs);
    return ctx.commit();
}

}  // namespace

WaveValidityResult run_wave_validity_study(const std::string& study_text,
                                           const fs::path& source_name,
                                           const fs::path& results_root, bool progress) {
    StudyContext ctx(study_text, source_name, results_root, {}, progress);
    const StudyProgress& clock = ctx.clock();
    const double cpu0 = process_cpu_seconds();
    const Settings s = read_settings(ctx);  // read
    ctx.begin(s.name);
    WaveValidityResult r;
    r.widths_um = s.widths_um;
    r.wavelengths_nm = s.wavelengths_nm;
    r.incidence_deg = s.incidence_deg;
    r.threshold = s.options.threshold;
    const std::size_t n_inc = s.incidence_deg.size(), n_w = s.widths_um.size();
    // The base point of one map is a point of the others: measured once.
    std::map<std::array<double, 4>, WaveValidityPoint> measured;
    for (const Axis& axis : s.axes) {  // build and measure, map by map
        clock.say(fmt::format("map width × {}: {} values × {} widths", axis.key, axis.values.size(),
                              n_w));
        WaveValidityMap m = measure_map(s, axis, measured);
        compare_map(m, n_inc, n_w, r);
        r.maps.push_back(std::move(m));
    }

    for (const auto& [key, p] : measured) {  // each measured point once
        r.po_wall_s += p.po_wall_s, r.po_cpu_s += p.po_cpu_s;
        r.go_wall_s += p.go_wall_s, r.go_cpu_s += p.go_cpu_s;
    }

    if (!s.full_wave.far_field.empty()) {  // compare with full wave
        clock.say(
            fmt::format("full-wave check: {} reference curves", s.full_wave.far_field.size()));
        r.full_wave = full_wave_check(s);
        r.full_wave_verdict = full_wave_verdict(r);
    }

    if (s.live.on) {  // compare with full wave, computed here
        r.live = judge_live(live_scenes(s, r), s.wavelengths_nm, s.live, r.threshold, clock,
                            r.live_seconds_per_cell_run);
        r.live_verdict = live_verdict(r);
    }

    clock.say("spongy scenes: each medium level against 3D full wave");  // compare
    r.spongy = judge_spongy_scenes(s.wavelengths_nm);

    r.output_dir = write_outputs(ctx, s, r, cpu0);
    return r;
}

void check_wave_validity_study(const std::string& study_text, const fs::path& source_name) {
    StudyContext ctx(study_text, source_name);
    read_settings(ctx);
}

namespace {

std::string run_from_command_line(const std::string& text, const fs::path& source,
                                  const fs::path& root, const RunLimits& limits) {
    refuse_limits("wave_validity", limits,
                  "its cost is set by the sweep and the ensemble in the study file");
    const WaveValidityResult r = run_wave_validity_study(text, source, root, true);
    return fmt::format(
        "plumage: wrote {} in {:.0f} s: {} PO needed, {} GO suffices, {} undecided (open "
        "report.md)\n",
        r.output_dir.string(), r.wall_seconds, r.po_needed, r.go_suffices, r.undecided);
}

}  // namespace

StudyEntry wave_validity_study_entry() {
    return {"wave_validity",
            "where ray optics ends: physical against geometric optics for barbule rows, as maps "
            "over width × film, aspect and spacing",
            check_wave_validity_study, run_from_command_line};
}

}  // namespace plumage::studies
