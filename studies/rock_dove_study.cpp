#include "studies/rock_dove_study.h"

#include <chrono>
#include <cmath>
#include <fstream>
#include <iostream>
#include <limits>
#include <map>
#include <memory>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "analysis/fits/fit_summary.h"
#include "analysis/fits/huang2022_fit.h"
#include "analysis/metrics/avian_compare.h"
#include "analysis/metrics/colour_quadrature.h"
#include "analysis/metrics/compare.h"
#include "analysis/metrics/convergence.h"
#include "analysis/metrics/statistics.h"
#include "analysis/models/huang2022.h"
#include "common/constants.h"
#include "common/error.h"
#include "common/seed.h"
#include "common/version.h"
#include "geometry/barbule.h"
#include "sim/optics/colour.h"
#include "sim/tracer.h"
#include "sim/wave/compare/levels_against_full_wave.h"
#include "sim/wave/compare/ray_optics_validity.h"
#include "sim/wave/surface/physical_optics_25d.h"
#include "studies/figure_data.h"
#include "studies/fullwave_rock_dove.h"  // generated: the embedded full-wave reference
#include "studies/instrument_tables.h"
#include "studies/level_choice.h"
#include "studies/measurement_cost.h"
#include "studies/plots.h"
#include "studies/sections.h"
#include "studies/staged_directory.h"
#include "studies/study.h"
#include "studies/study_checkpoints.h"
#include "studies/study_context.h"
#include "studies/study_file.h"
#include "studies/study_progress.h"
#include "studies/text_files.h"
#include "virtual_gonio/direction_sets.h"
#include "virtual_gonio/exr_image.h"
#include "virtual_gonio/goniometer.h"
#include "virtual_gonio/record/hdf5_file.h"
#include "virtual_gonio/scatterometer.h"

namespace plumage::studies {
namespace {

namespace fs = std::filesystem;

// [scatterometer]'s defaults: 101 px, 100000 quanta in 2 passes, 64 illumination directions per
// pass, a 40 µm beam at normal incidence, a 16° cone.
ScatterometerTable scatterometer_defaults() {
    ScatterometerTable t;
    t.config.image_size = 101;
    t.config.quanta_per_pass = 100000;
    t.config.max_passes = 2;
    t.config.illumination_strata = 64;
    t.config.cone_aperture_rad = 16.0 * kDeg;
    t.config.beam_radius_um = 40.0;
    return t;
}

gonio::GoniometerConfig goniometer_defaults() {
    gonio::GoniometerConfig g;
    g.direction_set = "filip2024_btf";
    g.detector_half_angle_rad = 5.0 * kDeg;
    g.quanta_per_pass = 20000;
    g.max_passes = 2;
    g.estimator = gonio::Estimator::photon;
    return g;
}

struct Settings {
    geometry::BarbuleRowParams row;
    geometry::TessellationTolerance tolerance;
    std::vector<double> wavelengths;
    // [scatterometer] (studies/instrument_tables.h) at the defaults above; its shared and split
    // paths are the simulated scatterograms' (a model cannot share paths).
    gonio::ScatterometerConfig scatterometer = scatterometer_defaults().config;
    double beam_incidence = 0.0, beam_azimuth = 0.0;  // as read, radians
    // The Huang model's quanta per wavelength and pass (0: as the simulation's). A model cannot
    // share paths, so the simulation's shared quanta would cost it 1 path per wavelength each.
    std::uint64_t model_scatter_quanta = 0;
    // The hemisphere scatterogram ([scatterometer.hemisphere]; absent keys as above): broad
    // rings, so fewer pixels and more illumination directions, and passes until its median
    // per-pixel relative error is reached (0: all passes).
    struct {
        int image_size = 101;
        std::uint64_t quanta = 100000;
        int passes = 2;
        int strata = 64;
        double target_median_error = 0.0;
        std::uint64_t model_quanta = 0;
        bool split_paths = false;
    } hemisphere;
    // [goniometer] (studies/instrument_tables.h), its defaults: the Filip BTF set, 5° cones,
    // 20000 quanta in 2 passes. The options of shared, split and guided paths are off unless the
    // file sets them (the rock dove's film lies in air, so no path needs a hero wavelength).
    gonio::GoniometerConfig goniometer = goniometer_defaults();
    double time_budget_s = std::numeric_limits<double>::infinity();  // per measurement
    double target_relative_error = 0.0;
    // validation and convergence
    double validation_cell_coupling = 0.01;
    double validation_light_theta = 30.0 * kDeg;
    double validation_detector_half_angle = 3.0 * kDeg;
    std::uint64_t validation_quanta = 200000;
    int convergence_passes = 8;
    std::uint64_t convergence_quanta = 20000;
    int convergence_reference_rings = 48;
    // Huang's parameters fitted to a simulated beam scatterogram (analysis/fits/huang2022_fit.h)
    bool fit = true;
    double fit_incidence = 20.0 * kDeg, fit_azimuth = 180.0 * kDeg;
    int fit_image_size = 41;
    std::uint64_t fit_quanta = 1000000;
    int fit_pixel_stride = 3;
    std::uint64_t seed = kDefaultSeed;
    LevelSettings level;  // [level]: which level of physics measures, certified by full wave
};

// [scatterometer] and [scatterometer.hemisphere]
void read_scatterometer(ParameterTable sc, Settings& s) {
    ScatterometerTable t{s.scatterometer, s.beam_incidence, s.beam_azimuth};
    ScatterometerKeys keys;
    keys.illumination_strata = keys.cone_aperture = keys.path_options = true;
    keys.azimuth_from = "the barb axis";
    t = read_scatterometer_table(sc, t, keys);
    s.scatterometer = t.config;
    s.beam_incidence = t.beam_incidence_rad;
    s.beam_azimuth = t.beam_azimuth_rad;
    s.model_scatter_quanta = static_cast<std::uint64_t>(
        sc.integer("model_quanta_per_pass", static_cast<long>(s.scatterometer.quanta_per_pass),
                   1000, 100000000, "the Huang model's quanta per wavelength and pass"));
    ParameterTable he = sc.table("hemisphere");
    s.hemisphere.image_size =
        static_cast<int>(he.integer("image_size", s.scatterometer.image_size, 17, 1025,
                                    "pixels across the hemisphere scatterogram"));
    s.hemisphere.quanta = static_cast<std::uint64_t>(
        he.integer("quanta_per_pass", static_cast<long>(s.scatterometer.quanta_per_pass), 1000,
                   100000000, "hemisphere light: quanta per wavelength and pass"));
    s.hemisphere.passes = static_cast<int>(he.integer("passes", s.scatterometer.max_passes, 1, 1000,
                                                      "hemisphere light: passes (at most)"));
    s.hemisphere.strata =
        static_cast<int>(he.integer("illumination_strata", s.scatterometer.illumination_strata, 1,
                                    1000000, "hemisphere light: directions per pass"));
    s.hemisphere.model_quanta = static_cast<std::uint64_t>(
        he.integer("model_quanta_per_pass", static_cast<long>(s.hemisphere.quanta), 1000, 100000000,
                   "hemisphere light: the Huang model's quanta per wavelength and pass"));
    s.hemisphere.split_paths =
        he.boolean("split_paths", s.scatterometer.split_paths,
                   "hemisphere light: split each shared path at its first film event");
    s.hemisphere.target_median_error = he.number(
        "target_median_relative_error", 0.0, between(0.0, 1.0),
        "hemisphere light: stop the passes once the median per-pixel relative error is this");
}

// [validation]
void read_validation(ParameterTable va, Settings& s) {
    s.validation_cell_coupling =
        va.number("cell_coupling", s.validation_cell_coupling, {0.0, 0.1, true, false},
                  "r_theta (1 - cos theta_d) / (b^2 A) of the short cells");
    s.validation_light_theta =
        va.angle_deg("light_theta_deg", s.validation_light_theta, between(0.0, 70.0),
                     "light polar angle, transversal plane");
    s.validation_quanta =
        static_cast<std::uint64_t>(va.integer("quanta", static_cast<long>(s.validation_quanta),
                                              1000, 1000000000, "quanta per wavelength"));
    s.validation_detector_half_angle = va.angle_deg(
        "detector_half_angle_deg", s.validation_detector_half_angle, {0.0, 20.0, true, false},
        "detector cone half-angle: small enough to resolve the R lobe");
}

// [convergence]
void read_convergence(ParameterTable co, Settings& s) {
    s.convergence_passes =
        static_cast<int>(co.integer("passes", s.convergence_passes, 2, 1000, "passes"));
    s.convergence_quanta = static_cast<std::uint64_t>(
        co.integer("quanta_per_pass", static_cast<long>(s.convergence_quanta), 100, 100000000,
                   "quanta per pass"));
    s.convergence_reference_rings = static_cast<int>(
        co.integer("reference_rings", s.convergence_reference_rings, 4, 256,
                   "cubature rings of the exact reference (eval; its error is |rings − rings/2|)"));
}

// [fit]
void read_fit(ParameterTable fi, Settings& s) {
    s.fit = fi.boolean("enabled", s.fit, "fit Huang's parameters to a simulated beam scatterogram");
    s.fit_incidence = fi.angle_deg("beam_incidence_deg", s.fit_incidence, between(0.0, 80.0),
                                   "beam polar angle of the fitted scatterogram");
    s.fit_azimuth = fi.angle_deg("beam_azimuth_deg", s.fit_azimuth, between(-360.0, 360.0),
                                 "beam azimuth from the barb axis");
    s.fit_image_size = static_cast<int>(
        fi.integer("image_size", s.fit_image_size, 17, 257, "pixels across the fitted image"));
    s.fit_quanta = static_cast<std::uint64_t>(
        fi.integer("quanta", static_cast<long>(s.fit_quanta), 10000, 100000000,
                   "quanta per wavelength of the fitted scatterogram"));
    s.fit_pixel_stride =
        static_cast<int>(fi.integer("pixel_stride", s.fit_pixel_stride, 1, 64,
                                    "fit the pixels with (row + column) % stride 0"));
}

Settings read_settings(StudyFile& file, std::string& name, const fs::path& source) {
    Settings s;
    ParameterTable root = file.root();
    name = read_study_name(root, source);
    root.string("study", "rock_dove", {"rock_dove"}, "which study this file describes");
    ParameterTable geometry = root.table("geometry");
    s.row = read_barbule_row_params(geometry);
    s.tolerance = read_tolerance(geometry.table("tessellation"));
    ParameterTable spectrum = root.table("spectrum");
    s.wavelengths = read_wavelengths(spectrum, WavelengthRule{});
    read_scatterometer(root.table("scatterometer"), s);
    ParameterTable go = root.table("goniometer");
    GoniometerKeys keys;
    keys.direction_sets = {"filip2024_btf", "filip2024_in_plane"};
    keys.path_options = true;
    s.goniometer = read_goniometer_table(go, s.goniometer, keys);
    s.time_budget_s = root.number(
        "time_budget_s", s.time_budget_s, positive(),
        "wall-time budget per measurement, s (progressive passes stop when it is spent)");
    s.target_relative_error =
        root.number("target_relative_error", 0.0, between(0.0, 1.0),
                    "stop a measurement's passes once its estimated relative error is below this");
    read_validation(root.table("validation"), s);
    read_convergence(root.table("convergence"), s);
    read_fit(root.table("fit"), s);
    s.level = read_level(root.table("level"));
    if (s.level.measure == kPhysicalOptics && !(s.row.cell.theta_d > 0.0))
        throw InputError(fmt::format(
            "{}: geometry.cell.theta_d_deg = 0 with [level] measure = \"physical optics\": the "
            "2.5D level spreads the light over the cells' tilt band, so it needs θ_d > 0 (a "
            "straight extrusion reflects into a cone of zero width: no BRDF)",
            geometry.table("cell").location("theta_d_deg")));
    s.seed = read_seed(root);
    root.reject_unused();
    return s;
}

// ---- One run: what every step shares. -------------------------------------------------------

struct Run {
    const Settings& s;
    const StudyContext& ctx;              // text, clock, streams, checkpoints (study_context.h)
    fs::path dir;                         // the staging folder
    std::vector<MeasurementCost>& costs;  // each measurement's error and time, in order
};

// The explicit patch and the analytic model of the same parameters.
struct Built {
    geometry::BarbuleRow row;
    std::unique_ptr<const sim::ExplicitScatterer> simulation;
    std::unique_ptr<const analysis::Huang2022Bsdf> model;
};

Built build(const Settings& s, StudyFile& file, const StudyProgress& clock,
            RockDoveResult& result) {
    clock.say("building the explicit rock-dove barbule patch");
    Built b;
    try {
        b.row = geometry::build_barbule_row(s.row, s.tolerance);
    } catch (const InputError& e) {
        throw InputError(
            fmt::format("{}: [geometry]: {}", file.root().table("geometry").location(), e.what()));
    }
    const geometry::BarbuleCell cell(s.row.cell);
    result.eq7_edge_coupling = cell.longitudinal_radius_um() *
                               (1.0 - std::cos(s.row.cell.theta_d)) /
                               (s.row.cell.b * s.row.cell.b * s.row.cell.semi_major_um);
    // Ctrl-C between the build's parts (each well under a second in a Release build, several
    // together under a sanitizer): no part is started after it.
    throw_if_interrupted("building the barbule patch");
    b.simulation = std::make_unique<const sim::ExplicitScatterer>(sim::barbule_row_scene(b.row));
    throw_if_interrupted("building the barbule patch");
    b.model = std::make_unique<const analysis::Huang2022Bsdf>(analysis::huang_params_of(s.row));
    throw_if_interrupted("building the barbule patch");
    return b;
}

// ---- 1. Scatterograms. -----------------------------------------------------------------------

gonio::ScatterometerConfig scatterometer_config(const Run& run, gonio::Illumination mode) {
    const Settings& s = run.s;
    gonio::ScatterometerConfig c = s.scatterometer;
    c.illumination = mode;
    c.wavelengths_nm = s.wavelengths;
    // One stream root per measurement (common/seed.h); scatterogram_pair gives the model's its own.
    c.seed = run.ctx.stream("rock_dove/scatterogram/simulation", static_cast<std::uint64_t>(mode));
    c.time_budget_s = s.time_budget_s;
    c.target_relative_error = s.target_relative_error;
    if (mode == gonio::Illumination::hemisphere) {
        c.image_size = s.hemisphere.image_size;
        c.quanta_per_pass = s.hemisphere.quanta;
        c.max_passes = s.hemisphere.passes;
        c.illumination_strata = s.hemisphere.strata;
        c.target_median_relative_error = s.hemisphere.target_median_error;
        c.split_paths = s.hemisphere.split_paths;
    }
    c.config_text = run.ctx.text();
    return c;
}

// Cells of a scatterogram with signal, for its median per-pixel σ: above 1 % of the peak.
constexpr double kSignalFraction = 0.01;

// Simulation against model over the (pixel, wavelength) cells where the model is above
// kSignalFraction of its brightest pixel at that wavelength: both images are Monte Carlo (the
// model's too: the scatterometer samples it), so the noise is sqrt(σ_sim² + σ_model²).
analysis::AgreementVerdict scatterogram_verdict(const gonio::Scatterogram& sim,
                                                const gonio::Scatterogram& model) {
    const std::size_t n_l = model.config.wavelengths_nm.size(), n = model.intensity.size();
    std::vector<double> peak(n_l, 0.0), sigma(n);
    for (std::size_t c = 0; c < n; ++c) peak[c % n_l] = std::max(peak[c % n_l], model.intensity[c]);
    std::vector<std::uint8_t> use(n);
    for (std::size_t c = 0; c < n; ++c) {
        use[c] = model.solid_angle_sr[c / n_l] > 0.0 &&
                 model.intensity[c] > kSignalFraction * peak[c % n_l];
        sigma[c] = std::hypot(sim.standard_error[c], model.standard_error[c]);
    }
    return analysis::agreement(sim.intensity, sigma, model.intensity, {}, use);
}

// One illumination's scatterograms: simulation and model on one instrument, independent noise.
struct ScatterogramPair {
    gonio::Scatterogram simulation, model;
};

ScatterogramPair measure_scatterogram_pair(const Run& run, const Built& b, gonio::Illumination mode,
                                           const std::string& label) {
    const gonio::ScatterometerConfig c = scatterometer_config(run, mode);
    gonio::ScatterometerConfig model_c = c;  // the same instrument; independent noise
    model_c.quanta_per_pass = mode == gonio::Illumination::hemisphere
                                  ? run.s.hemisphere.model_quanta
                                  : run.s.model_scatter_quanta;
    model_c.seed = run.ctx.stream("rock_dove/scatterogram/model", static_cast<std::uint64_t>(mode));
    ScatterogramPair p;
    // Each image's passes are checkpointed: Ctrl-C keeps them, the same command resumes.
    fs::create_directories(run.ctx.checkpoints());
    gonio::RunControl control;
    control.progress = run.ctx.progress();
    run.ctx.clock().say("scatterogram (" + label + "): simulation");
    control.checkpoint =
        run.ctx.checkpoints() / ("scatterogram_" + label + "_simulation.checkpoint");
    p.simulation = gonio::measure_scatterogram(*b.simulation, c, control);
    run.ctx.clock().say("scatterogram (" + label + "): Huang model");
    control.checkpoint = run.ctx.checkpoints() / ("scatterogram_" + label + "_model.checkpoint");
    p.model = gonio::measure_scatterogram(*b.model, model_c, control);
    return p;
}

// One illumination: both scatterograms' records and images, and the table row.
std::string scatterogram_pair(const Run& run, const ScatterogramPair& pair,
                              gonio::Illumination mode, const std::string& label,
                              RockDoveResult& result) {
    const gonio::Scatterogram &sim_s = pair.simulation, &mod_s = pair.model;
    const fs::path dir = run.dir / "scatterograms";
    gonio::write_scatterogram_record(sim_s, dir / (label + "_simulation.h5"));
    gonio::write_scatterogram_record(mod_s, dir / (label + "_model.h5"));
    const double l1 = analysis::image_relative_l1(sim_s, mod_s, -1, -1);
    const double l1_floor = analysis::image_relative_l1_noise_floor(sim_s, mod_s);
    const double l1_r =
        analysis::image_relative_l1(sim_s, mod_s, analysis::lobe_index(sim_s.lobes, "R"),
                                    analysis::lobe_index(mod_s.lobes, "R"));
    const double l1_trt =
        analysis::image_relative_l1(sim_s, mod_s, analysis::lobe_index(sim_s.lobes, "TRT"),
                                    analysis::lobe_index(mod_s.lobes, "TRT"));
    result.scatterogram_relative_l1.push_back(l1);
    result.verdicts.push_back({"scatterogram (" + label + ")", scatterogram_verdict(sim_s, mod_s)});
    const double t_sim = analysis::mean_transmitted(sim_s, analysis::lobe_index(sim_s.lobes, "T"));
    const double t_mod = analysis::mean_transmitted(mod_s, analysis::lobe_index(mod_s.lobes, "T"));
    const double multi_share =
        analysis::reflected_share(sim_s, analysis::lobe_index(sim_s.lobes, "multi"));
    if (mode == gonio::Illumination::hemisphere) result.simulated_multi_share = multi_share;
    if (mode == gonio::Illumination::beam) result.simulated_t = t_sim, result.model_t = t_mod;
    record::Hdf5Writer h5(dir / (label + "_comparison.h5"));
    const std::vector<double> values = {l1, l1_r, l1_trt, t_sim, t_mod, multi_share};
    h5.write("relative_error", std::span<const double>(values), {values.size()},
             {{"units", "1"},
              {"description",
               "how the simulated scatterogram departs from the model's (six numbers: columns)"},
              {"columns",
               "power-weighted relative L1 of simulation against model: all, R, TRT; then T below "
               "(simulation, model) and the simulation's multi-event share of reflected power"}});
    h5.set_attribute("/", "illumination", label);
    write_scatterogram_figure(h5, sim_s, mod_s, label + " illumination");
    h5.commit();
    run_plot("scatterogram_comparison", dir / (label + "_comparison.h5"),
             dir / (label + "_comparison.png"));
    gonio::write_spectral_exr(dir / (label + "_comparison.exr"),
                              {gonio::scatterogram_exr_image(sim_s, "simulation"),
                               gonio::scatterogram_exr_image(mod_s, "model")},
                              "rock_dove");
    const MeasurementCost sim_cost =
        scatterogram_cost("scatterogram (" + label + "): simulation", sim_s, kSignalFraction);
    const MeasurementCost mod_cost =
        scatterogram_cost("scatterogram (" + label + "): Huang model", mod_s, kSignalFraction);
    run.costs.push_back(sim_cost);
    run.costs.push_back(mod_cost);
    const double sigma_sim = sim_cost.error, sigma_mod = mod_cost.error;
    if (mode == gonio::Illumination::hemisphere) {
        result.hemisphere_median_sigma_simulation = sigma_sim;
        result.hemisphere_median_sigma_model = sigma_mod;
    }
    return fmt::format(
        "| {} | {:.3f} | {:.3f} | {:.3f} | {:.3f} | {:.2e} | {:.2e} | {:.3f} | {:.1f} % / {:.1f} % "
        "({}, {} px, {}/{} passes) |\n",
        label, l1, l1_floor, l1_r, l1_trt, t_sim, t_mod, multi_share, 100.0 * sigma_sim,
        100.0 * sigma_mod,
        sim_s.quanta == mod_s.quanta
            ? fmt::format("{:.2g} quanta/λ", static_cast<double>(sim_s.quanta))
            : fmt::format("{:.2g}/{:.2g} quanta/λ", static_cast<double>(sim_s.quanta),
                          static_cast<double>(mod_s.quanta)),
        sim_s.config.image_size, sim_s.passes, mod_s.passes);
}

// The scatterograms' section, and the beam pair kept for the physical-optics level's figure.
struct Scatterograms {
    std::string markdown;
    ScatterogramPair beam;
};

Scatterograms scatterograms(const Run& run, const Built& b, RockDoveResult& result) {
    const std::vector<std::pair<gonio::Illumination, std::string>> modes = {
        {gonio::Illumination::beam, "beam"},
        {gonio::Illumination::cone, "cone"},
        {gonio::Illumination::hemisphere, "hemisphere"}};
    std::string table =
        "| illumination | relative L1 (all) | its noise floor | R | TRT | T below, simulation | "
        "T below, model | multi share (simulation) | median per-pixel σ (sim / model) "
        "|\n|---|---|---|---|---|---|---|---|---|\n";
    Scatterograms out;
    for (const auto& [mode, label] : modes) {
        ScatterogramPair pair = measure_scatterogram_pair(run, b, mode, label);
        table += scatterogram_pair(run, pair, mode, label, result);
        if (mode == gonio::Illumination::beam) out.beam = std::move(pair);
    }
    std::string md =
        "## Scatterograms\n\nEach figure: simulation (left) and Huang model (middle) at one "
        "exposure (stated above them), and the signed luminance difference simulation − model "
        "(right, red: the simulation is brighter; scaled to its own range, colour bar in 1/sr). "
        "Azimuthal equidistant map of the upper hemisphere, rings at ϑ = 30°, 60°, 90°, barb "
        "axis (φ = 0°) to the right. The figure's data: `figure/` in each "
        "`<illumination>_comparison.h5`.\n\n";
    for (const auto& [mode, label] : modes) {
        md += fmt::format("**{}**\n\n![{}](scatterograms/{}_comparison.png)\n\n", label, label,
                          label);
    }
    out.markdown =
        md + table +
        "\nRelative L1 = Σ|I_sim − I_model|Ω / Σ I_model Ω over pixels and wavelengths (the "
        "model is the reference here; the ablation study divides by the simulation). Its noise "
        "floor is the L1 two images of the same scatterer would show with these standard "
        "errors: sqrt(2/π) Σ sqrt(σ_sim² + σ_model²) Ω / Σ I_model Ω. "
        "Median per-pixel σ: the median of σ/I over (pixel, wavelength) cells whose intensity "
        "is above 1 % of that wavelength's brightest pixel "
        "(gonio::median_relative_standard_error).\n\n";
    return out;
}

// ---- 2. Goniometric BRDF. --------------------------------------------------------------------

gonio::GoniometerConfig goniometer_config(const Run& run) {
    const Settings& s = run.s;
    gonio::GoniometerConfig g = s.goniometer;
    g.wavelengths_nm = s.wavelengths;
    g.beam_radius_um = s.scatterometer.beam_radius_um;
    g.seed = run.ctx.stream("rock_dove/brdf");
    g.time_budget_s = s.time_budget_s;
    g.target_relative_error = s.target_relative_error;
    g.config_text = run.ctx.text();
    return g;
}

struct Brdfs {
    gonio::BrdfRecord simulation, model;
};

// The simulation checkpointed in `checkpoint` (Ctrl-C keeps its completed passes), the model
// by cubature.
Brdfs measure_brdfs(const Run& run, const Built& b, const fs::path& checkpoint) {
    gonio::GoniometerConfig g = goniometer_config(run);
    run.ctx.clock().say(
        fmt::format("BRDF on {} ({} pairs): simulation", g.direction_set, g.pairs.size()));
    Brdfs m;
    fs::create_directories(checkpoint.parent_path());
    gonio::RunControl control;
    control.progress = run.ctx.progress();
    control.checkpoint = checkpoint;
    m.simulation = gonio::measure_brdf(*b.simulation, g, control);
    if (m.simulation.interrupted) {
        throw Interrupted(
            interrupted_with_checkpoint("the simulated BRDF", m.simulation.passes, checkpoint));
    }
    run.ctx.clock().say("BRDF: Huang model");
    g.estimator = gonio::Estimator::eval;
    // The model's cubature converged to 1 % per cell: its error is not noise, so it must not
    // be what the comparison sees (issue 40).
    g.eval_tolerance = 0.01;
    m.model = gonio::measure_brdf(*b.model, g);
    gonio::write_brdf_record(m.simulation, run.dir / "brdf" / "simulation.h5");
    gonio::write_brdf_record(m.model, run.dir / "brdf" / "model.h5");
    return m;
}

std::string brdf_section(const Run& run, const Brdfs& m, RockDoveResult& result) {
    const analysis::RecordComparison cmp = analysis::compare_records(m.simulation, m.model);
    result.brdf_relative_l1 = cmp.total.relative_l1;
    // The model's values come from its cone cubature: their error estimate is not noise.
    result.verdicts.push_back(
        {"BRDF (" + run.s.goniometer.direction_set + ")",
         analysis::agreement(m.simulation.value, m.simulation.standard_error, m.model.value,
                             m.model.standard_error, m.simulation.signal_cells)});
    std::string md = "## BRDF (in-plane sweep)\n\n";
    if (run.s.goniometer.direction_set == "filip2024_btf") {
        write_fingerprint_figure(
            run.dir / "brdf" / "fingerprints.h5", "Rock-dove barbules: BRDF fingerprints",
            {{"simulation", &m.simulation}, {"Huang 2022 model", &m.model}}, 61, 60);
        run_plot("fingerprints", run.dir / "brdf" / "fingerprints.h5",
                 run.dir / "brdf" / "fingerprints.png");
        gonio::write_spectral_exr(
            run.dir / "brdf" / "fingerprints.exr",
            {gonio::fingerprint_exr_image(m.simulation, 61, 60, "simulation"),
             gonio::fingerprint_exr_image(m.model, 61, 60, "Huang 2022 model")},
            "rock_dove");
        md = "## BRDF (Filip 2024 set, 61 light × 60 view directions)\n\nFingerprints (rows: light "
             "directions, columns: view directions, grouped by polar angle; simulation left, model "
             "right; colour at one exposure for both, luminance below on one logarithmic scale; "
             "data in `brdf/fingerprints.h5`):\n\n"
             "![fingerprints](brdf/fingerprints.png)\n\n";
    }
    md += analysis::comparison_markdown(cmp, m.simulation, "simulation", "Huang model") + "\n";
    md += fmt::format(
        "Simulation: photon estimator, {} quanta per light direction and wavelength, detector "
        "half-angle "
        "{:.1f}°, estimated relative RMS error {:.1f} % ({:.0f} s). Model: cone cubature of "
        "eval().\n\n",
        m.simulation.quanta, run.s.goniometer.detector_half_angle_rad / kDeg,
        100.0 * m.simulation.convergence.back().estimated_relative_rms_error,
        m.simulation.wall_time_s);
    return md;
}

// What the study's wavelength grid costs in colour: the model's spectra (exact at any λ) on the
// study's grid against 1 nm, at every direction pair of the BRDF.
std::string colour_quadrature(const Run& run, const Built& b, const Brdfs& m,
                              RockDoveResult& result) {
    const std::vector<double>& wl = m.model.config.wavelengths_nm;
    if (!optics::carries_colour(wl)) {
        return {};
    }
    run.ctx.clock().say("colour quadrature: Huang model on the study's wavelengths against 1 nm");
    // An eval costs tens of µs: about 200 pairs (every 18th of the 3660) tell the grid's error
    // in a few seconds; smaller sets are taken whole.
    const auto& pairs = m.model.config.pairs;
    const std::size_t stride = std::max<std::size_t>(1, pairs.size() / 200);
    const std::size_t count = (pairs.size() + stride - 1) / stride;
    const analysis::Huang2022Bsdf& model = *b.model;
    const analysis::ColourQuadratureError e = analysis::colour_quadrature_error(
        count, optics::WavelengthGrid(wl), [&](std::size_t i, double lambda) {
            if (interrupt_requested()) return 0.0;  // abandoned: thrown just below
            const gonio::DirectionPair& p = pairs[i * stride];
            return kPi * model.eval(p.wi, p.wo, lambda);
        });
    throw_if_interrupted("the colour quadrature error");
    result.colour_quadrature_max_delta_e00 = e.max;
    return fmt::format(
        "Colour quadrature: the colours above come from {} wavelengths ({}–{} nm, trapezoidal "
        "rule). The model's own spectra at {} of the {} pairs (every {}), on this grid against "
        "{} nm, differ by ΔE00 {:.2f} on average, {:.2f} at the 95th percentile and {:.2f} at "
        "most (1 is a just-noticeable difference).\n\n",
        wl.size(), wl.front(), wl.back(), count, pairs.size(),
        stride == 1 ? std::string("one") : fmt::format("{}th", stride), e.reference_step_nm, e.mean,
        e.p95, e.max);
}

// What the study's grid costs each bird: the model's spectra (exact at any λ) on the grid against
// 1 nm, over about 200 direction pairs (as colour_quadrature).
std::string avian_quadrature(const Built& b, const Brdfs& m) {
    const auto& pairs = m.model.config.pairs;
    const std::size_t stride = std::max<std::size_t>(1, pairs.size() / 200);
    const std::size_t count = (pairs.size() + stride - 1) / stride;
    const analysis::Huang2022Bsdf& model = *b.model;
    std::string md = fmt::format(
        "\nThe grid's own error: the model's spectra at {} of the {} pairs on this grid against "
        "1 nm (analysis/metrics/avian_compare.h), RMS and largest:",
        count, pairs.size());
    for (const auto* system :
         {&analysis::ultraviolet_sensitive_system(), &analysis::violet_sensitive_system()}) {
        const analysis::AvianQuadratureError e = analysis::avian_quadrature_error(
            count, optics::WavelengthGrid(m.model.config.wavelengths_nm), *system,
            [&](std::size_t i, double lambda) {
                if (interrupt_requested()) return 0.0;  // abandoned: thrown below
                const gonio::DirectionPair& p = pairs[i * stride];
                return kPi * model.eval(p.wi, p.wo, lambda);
            });
        md += fmt::format(" {}: ΔS {:.2f} and {:.2f}, ΔL {:.2f} and {:.2f} JND;", system->name,
                          e.rms_delta_s, e.max_delta_s, e.rms_delta_l, e.max_delta_l);
    }
    throw_if_interrupted("the avian quadrature error");
    md.back() = '.';
    return md + "\n";
}

// The BRDFs as birds see them (analysis/metrics/avian_compare.h), and the spectra of a few pairs in
// pavo's layout (brdf/spectra_pavo.csv).
std::string avian_vision(const Run& run, const Built& b, const Brdfs& m, RockDoveResult& result) {
    const auto& wl = m.model.config.wavelengths_nm;
    if (wl.size() < 2 || wl.front() < 300.0) return {};
    run.ctx.clock().say("avian vision: UVS and VS distances, simulation against model");
    std::vector<analysis::AvianRecordComparison> rows;
    for (const auto* system :
         {&analysis::ultraviolet_sensitive_system(), &analysis::violet_sensitive_system()}) {
        rows.push_back(analysis::compare_records_avian(m.simulation, m.model, *system));
    }
    result.avian_median_delta_s = {rows[0].median, rows[1].median};
    result.avian_median_noise_floor = {rows[0].median_noise_floor, rows[1].median_noise_floor};
    std::vector<std::string> names;
    std::vector<std::vector<double>> columns;
    for (std::size_t p : analysis::pavo_export_pairs(m.model, rows)) {
        for (const auto& [name, record] :
             {std::pair{"simulation", &m.simulation}, std::pair{"model", &m.model}}) {
            names.push_back(analysis::pavo_pair_name(name, record->config.pairs[p]));
            std::vector<double>& c = columns.emplace_back();
            for (std::size_t k = 0; k < wl.size(); ++k) c.push_back(100.0 * kPi * record->at(p, k));
        }
    }
    write_text_file(run.dir / "brdf" / "spectra_pavo.csv",
                    analysis::pavo_csv_text(wl, names, columns));
    write_text_file(run.dir / "brdf" / "avian_catches.csv",
                    analysis::avian_catches_csv(wl, names, columns));
    return "## Avian vision\n\nColour differences as a bird sees them: receptor-noise-limited "
           "distance ΔS (Vorobyev & Osorio 1998; 1 = one just-noticeable difference) between the "
           "spectra of π·f under D65 at each direction pair, for an ultraviolet-sensitive (blue "
           "tit) and a violet-sensitive (peafowl) tetrachromat (analysis/metrics/avian_vision.h), "
           "beside "
           "the ΔS the Monte Carlo error alone gives:\n\n" +
           analysis::avian_comparison_markdown(rows, m.model, "simulation", "Huang model") +
           avian_quadrature(b, m) +
           (wl.front() > 300.0
                ? fmt::format("\nThe grid starts at {:.0f} nm: the UV/violet cone gets no light "
                              "below it, so its catch, and ΔS, rest on the part of its "
                              "sensitivity the grid covers (shares above).",
                              wl.front())
                : std::string()) +
           "\nSpectra of the pairs above (brightest, largest ΔS, median) in pavo's layout: "
           "`brdf/spectra_pavo.csv` (`wl` in nm, then one column per sample, 100·π·f in per "
           "cent); their von Kries-adapted quantum catches (cones and double cone) for pavo's "
           "four birds: `brdf/avian_catches.csv`.\n\n";
}

// In-plane curves at the middle wavelength (the set's own order of light angles).
std::string in_plane_sweep(const Run& run, const Built& b) {
    const Settings& s = run.s;
    gonio::GoniometerConfig ip = goniometer_config(run);
    ip.direction_set = "filip2024_in_plane";
    ip.pairs = gonio::filip2024_in_plane_pairs();
    ip.wavelengths_nm = {s.wavelengths[s.wavelengths.size() / 2]};
    ip.estimator = gonio::Estimator::photon;
    ip.quanta_per_pass = s.goniometer.quanta_per_pass * 4;
    ip.seed = run.ctx.stream("rock_dove/in_plane_sweep");
    run.ctx.clock().say("in-plane sweep: simulation and model");
    const gonio::BrdfRecord a = gonio::measure_brdf(*b.simulation, ip);
    ip.estimator = gonio::Estimator::eval;
    const gonio::BrdfRecord m = gonio::measure_brdf(*b.model, ip);
    run.costs.push_back(brdf_cost("in-plane sweep: simulation", a));
    run.costs.push_back(brdf_cost("in-plane sweep: Huang model", m));
    const auto angles = gonio::filip2024_in_plane_light_angles();
    std::ofstream csv(run.dir / "brdf" / "in_plane.csv");
    csv << fmt::format(
        "light angle (deg) at {:.0f} nm,simulation,simulation_err,Huang model,"
        "model_err\n",
        ip.wavelengths_nm.front());
    for (std::size_t p = 0; p < ip.pairs.size(); ++p) {
        csv << fmt::format("{:.1f},{:.6g},{:.6g},{:.6g},{:.6g}\n", angles[p] / kDeg, a.at(p, 0),
                           a.error_at(p, 0), m.at(p, 0), m.error_at(p, 0));
    }
    close_written(csv, run.dir / "brdf" / "in_plane.csv");
    run_plot("curves", run.dir / "brdf" / "in_plane.csv", run.dir / "brdf" / "in_plane.png");
    return fmt::format(
        "In-plane sweep (Filip 2024 Sect. 4: view 45° in the plane across the barbs, light "
        "−81°…81°) at {:.0f} "
        "nm:\n\n![in-plane](brdf/in_plane.png)\n\n",
        ip.wavelengths_nm[0]);
}

// ---- 2b. The BRDF at the physical-optics level ([level] measure, studies/level_choice.h). -----

// The study's barbule row for the 2D wave levels: Huang's cell cross-section (semi-major A, b,
// normal azimuths φ0…φ1; keratin film d over the air gap g over melanin), spacing H·A, tilt μ,
// as full wave's row certificate and the level-of-physics comparison have it
// (sim::wave::barbule_row_2d); `count` barbules, at least 4 and 40 µm and at most the patch's;
// the patch's rotation jitter over 8 realisations when it has one.
sim::wave::Row2d study_wave_row(const Settings& s, std::uint64_t jitter_seed) {
    const geometry::BarbuleRowParams& p = s.row;
    const double a = p.cell.semi_major_um;
    const int count =
        std::min(p.barbules, std::max(4, static_cast<int>(std::ceil(40.0 / (p.H * a)))));
    sim::wave::Row2d row =
        sim::wave::barbule_row_2d(a, p.cell.b, p.cell.phi0, p.cell.phi1, p.cell.film_thickness_um,
                                  p.cell.melanin_depth_um, p.H, p.mu, count);
    row.jitter_rotation_rad = p.jitter_phi_rad;
    row.realisations = p.jitter_phi_rad > 0.0 ? 8 : 1;
    row.seed = jitter_seed;  // ctx.stream("rock_dove/wave_row"); the closed row: the same
    return row;
}

// The step sampling the arc: λ/10 at each wavelength (0) where the arc's sharpest curvature
// allows it at every wavelength, as the certificate's min(λ/10, 0.95 ρ_min); else one step for
// every wavelength, the smaller of the two at the shortest.
double physical_optics_step_um(const Settings& s) {
    const geometry::BarbuleCellParams& c = s.row.cell;
    const double rho =
        0.95 * sim::wave::barbule_row_min_radius_um(c.semi_major_um, c.b, c.phi0, c.phi1);
    const auto [shortest, longest] =
        std::minmax_element(s.wavelengths.begin(), s.wavelengths.end());
    return rho >= 1e-4 * *longest ? 0.0 : std::min(rho, 1e-4 * *shortest);
}

// The 2.5D physical-optics scatterer of the study's row (sim/wave/surface/physical_optics_25d.h):
// the row above extruded along the barbules with the cells' tilt band θ_d.
std::unique_ptr<const sim::wave::PhysicalOptics25d> build_physical_optics(const Settings& s,
                                                                          StudyContext& ctx) {
    StudyFile& file = ctx.file();
    ctx.clock().say("building the physical-optics level: the study's barbule row in 2.5D");
    sim::wave::PhysicalOptics25dParams params;
    params.row = study_wave_row(s, ctx.stream("rock_dove/wave_row"));
    params.theta_d = s.row.cell.theta_d;
    params.step_um = physical_optics_step_um(s);
    try {
        return std::make_unique<const sim::wave::PhysicalOptics25d>(std::move(params));
    } catch (const InputError& e) {
        throw InputError(fmt::format("{}: [geometry] at physical optics: {}",
                                     file.root().table("geometry").location(), e.what()));
    }
}

// The physical-optics BRDF on the simulation's instrument (pairs, wavelengths, detector, photon
// estimator, passes and stop rule), its own streams, checkpointed as the simulation's.
gonio::BrdfRecord measure_physical_optics_brdf(const Run& run,
                                               const sim::wave::PhysicalOptics25d& po,
                                               const fs::path& checkpoint) {
    gonio::GoniometerConfig g = goniometer_config(run);
    g.seed = run.ctx.stream("rock_dove/brdf/physical_optics");
    run.ctx.clock().say(fmt::format("BRDF on {} ({} pairs): physical optics (2.5D)",
                                    g.direction_set, g.pairs.size()));
    fs::create_directories(checkpoint.parent_path());
    gonio::RunControl control;
    control.progress = run.ctx.progress();
    control.checkpoint = checkpoint;
    gonio::BrdfRecord r = gonio::measure_brdf(po, g, control);
    if (r.interrupted)
        throw Interrupted(
            interrupted_with_checkpoint("the physical-optics BRDF", r.passes, checkpoint));
    gonio::write_brdf_record(r, run.dir / "brdf" / "physical_optics.h5");
    run.costs.push_back(brdf_cost(fmt::format("BRDF on {} ({} pairs): physical optics (2.5D)",
                                              g.direction_set, g.pairs.size()),
                                  r));
    return r;
}

// The figure beside the ray-traced one: fingerprints (Filip's 61 × 60 set) of physical optics,
// ray optics and the model; or, on the in-plane set, the three as curves at the middle
// wavelength.
std::string physical_optics_figure(const Run& run, const Brdfs& m, const gonio::BrdfRecord& po) {
    const fs::path dir = run.dir / "brdf";
    if (run.s.goniometer.direction_set == "filip2024_btf") {
        write_fingerprint_figure(dir / "fingerprints_physical_optics.h5",
                                 "Rock-dove barbules: BRDF fingerprints by level",
                                 {{"physical optics (2.5D)", &po},
                                  {"ray optics + thin film", &m.simulation},
                                  {"Huang 2022 model", &m.model}},
                                 61, 60);
        run_plot("fingerprints", dir / "fingerprints_physical_optics.h5",
                 dir / "fingerprints_physical_optics.png");
        return "![fingerprints by level](brdf/fingerprints_physical_optics.png)\n\n";
    }
    const std::size_t k = po.config.wavelengths_nm.size() / 2;
    const auto angles = gonio::filip2024_in_plane_light_angles();
    std::ofstream csv(dir / "physical_optics_in_plane.csv");
    csv << fmt::format(
        "light angle (deg) at {:.0f} nm,physical optics,physical optics_err,ray optics,"
        "ray optics_err,Huang model,model_err\n",
        po.config.wavelengths_nm[k]);
    for (std::size_t p = 0; p < po.config.pairs.size() && p < angles.size(); ++p)
        csv << fmt::format("{:.1f},{:.6g},{:.6g},{:.6g},{:.6g},{:.6g},{:.6g}\n", angles[p] / kDeg,
                           po.at(p, k), po.error_at(p, k), m.simulation.at(p, k),
                           m.simulation.error_at(p, k), m.model.at(p, k), m.model.error_at(p, k));
    close_written(csv, dir / "physical_optics_in_plane.csv");
    run_plot("curves", dir / "physical_optics_in_plane.csv", dir / "physical_optics_in_plane.png");
    return "![in-plane by level](brdf/physical_optics_in_plane.png)\n\n";
}

// What the 2.5D level leaves out (sim/wave/surface/physical_optics_2d.h and _25d.h), for the
// report.
std::string physical_optics_scope() {
    return "What this level leaves out (sim/wave/surface/physical_optics_2d.h, _25d.h): light "
           "reaches "
           "the melanin only through the planar stack's r under each point of the film (keratin "
           "film / air gap / melanin, coherent): no light crosses the film to a melanin layer "
           "that does not follow it, nothing passes through the barbule, so it has no TRT, T or "
           "multi lobe (its record has R only); one bounce (no reflection between barbules); "
           "light reflected towards a neighbour is not blocked; Kirchhoff's abrupt lit/dark "
           "boundary (no creeping waves); TE and TM averaged as scalars (their coupling out of "
           "the cross-section's plane is left out); Huang's tilt band without the curved cell's "
           "(1 ± r_θ(1 − cos θ)/ρ) correction; and a finite row, whose ends diffract.";
}

// The physical-optics BRDF against the model with the ray-traced one's metrics and verdict,
// and beside the ray-traced BRDF.
std::string physical_optics_section(const Run& run, const Brdfs& m, const gonio::BrdfRecord& po,
                                    const sim::wave::PhysicalOptics25d& level,
                                    RockDoveResult& result) {
    const analysis::RecordComparison cmp = analysis::compare_records(po, m.model);
    const analysis::RecordComparison by_level = analysis::compare_records(po, m.simulation);
    const analysis::AgreementVerdict v = analysis::agreement(
        po.value, po.standard_error, m.model.value, m.model.standard_error, po.signal_cells);
    result.verdicts.push_back(
        {"BRDF (" + run.s.goniometer.direction_set + "), physical optics", v});
    result.physical_optics_measured = true;
    result.physical_optics_brdf_relative_l1 = cmp.total.relative_l1;
    result.physical_optics_brdf_relative_l1_noise_floor = cmp.total.relative_l1_noise_floor;
    result.physical_optics_against_ray_optics_l1 = by_level.total.relative_l1;
    result.physical_optics_brdf_error = po.convergence.back().estimated_relative_rms_error;
    result.physical_optics_brdf_seconds = po.wall_time_s;
    const sim::wave::Row2d row = study_wave_row(run.s, run.ctx.stream("rock_dove/wave_row"));
    return fmt::format(
               "## BRDF at the physical-optics level (2.5D)\n\n"
               "The same instrument (the {} pairs, {} wavelengths, {:.1f}° detectors, photon "
               "estimator, passes and stop rule of the BRDF above, its own random streams) "
               "measures the physical-optics level (sim/wave/surface/physical_optics_25d.h): {} of "
               "this "
               "study's barbule cross-sections ({:g} µm wide, b = {}, film {:g} µm over a {:g} µm "
               "air gap over melanin), {:g} µm apart, tilted by μ = {:.2f} rad, coherent, "
               "extruded along the barbules with the cells' tilt band θ_d = {:.4f} rad "
               "(patch width {:g} µm; the cross-section, spacing and tilt full wave certifies "
               "below). Against the Huang "
               "model: relative L1 **{:.3f}** (noise floor {:.3f}; ray-traced: {:.3f}); against "
               "the ray-traced BRDF: {:.3f}. Estimated relative RMS error {:.1f} % ({} quanta "
               "per light direction and wavelength, {:.0f} s).\n\n{}",
               po.config.pairs.size(), po.config.wavelengths_nm.size(),
               run.s.goniometer.detector_half_angle_rad / kDeg, row.count,
               2.0 * run.s.row.cell.semi_major_um, run.s.row.cell.b,
               run.s.row.cell.film_thickness_um, run.s.row.cell.melanin_depth_um, row.spacing_um,
               row.tilt_rad, run.s.row.cell.theta_d, level.patch_width_um(), cmp.total.relative_l1,
               cmp.total.relative_l1_noise_floor, result.brdf_relative_l1,
               by_level.total.relative_l1, 100.0 * result.physical_optics_brdf_error, po.quanta,
               po.wall_time_s, physical_optics_figure(run, m, po)) +
           analysis::comparison_markdown(cmp, po, "physical optics", "Huang model") + "\n" +
           physical_optics_scope() +
           " The model's total has its TRT lobe, which this level lacks: the R row of the table "
           "above is the like-for-like comparison. Section \"Level of physics\" below shows how "
           "much of the difference between the two levels the coherent air gap under the film "
           "makes.\n\n";
}

// The physical-optics beam scatterogram on the ray-traced beam scatterogram's instrument
// (beam, spot, image, wavelengths, quanta, passes and stop rule), its own streams.
gonio::Scatterogram measure_physical_optics_scatterogram(const Run& run,
                                                         const sim::wave::PhysicalOptics25d& po) {
    gonio::ScatterometerConfig c = scatterometer_config(run, gonio::Illumination::beam);
    c.seed = run.ctx.stream("rock_dove/scatterogram/beam/physical_optics");
    const std::string what = "scatterogram (beam): physical optics (2.5D)";
    run.ctx.clock().say(what);
    gonio::Scatterogram r = gonio::measure_scatterogram(po, c);
    gonio::write_scatterogram_record(r, run.dir / "scatterograms" / "beam_physical_optics.h5");
    run.costs.push_back(scatterogram_cost(what, r, kSignalFraction));
    return r;
}

// The beam scatterogram by level against the model, in numbers: all lobes with the noise
// floor, the R lobe alone (this level has no other), and against the ray-traced one.
struct LevelScatterogramErrors {
    double l1 = 0.0, floor = 0.0, l1_r = 0.0, against_ray_optics = 0.0, ray_optics_l1 = 0.0;
};

LevelScatterogramErrors level_scatterogram_errors(const ScatterogramPair& beam,
                                                  const gonio::Scatterogram& po) {
    LevelScatterogramErrors e;
    e.l1 = analysis::image_relative_l1(po, beam.model, -1, -1);
    e.floor = analysis::image_relative_l1_noise_floor(po, beam.model);
    e.l1_r = analysis::image_relative_l1(po, beam.model, analysis::lobe_index(po.lobes, "R"),
                                         analysis::lobe_index(beam.model.lobes, "R"));
    e.against_ray_optics = analysis::image_relative_l1(po, beam.simulation, -1, -1);
    e.ray_optics_l1 = analysis::image_relative_l1(beam.simulation, beam.model, -1, -1);
    return e;
}

// beam_levels.h5 (the numbers and the figure's data, scatterograms/) and beam_levels.png: the
// three levels at one exposure and on one luminance scale.
void physical_optics_scatterogram_figure(const Run& run, const ScatterogramPair& beam,
                                         const gonio::Scatterogram& po,
                                         const LevelScatterogramErrors& e) {
    const fs::path dir = run.dir / "scatterograms";
    record::Hdf5Writer h5(dir / "beam_levels.h5");
    const std::vector<double> values = {e.l1, e.floor, e.l1_r, e.against_ray_optics,
                                        e.ray_optics_l1};
    h5.write("relative_error", std::span<const double>(values), {values.size()},
             {{"units", "1"},
              {"description", "the beam scatterogram by level, power-weighted relative L1"},
              {"columns",
               "physical optics against the model: all lobes, its noise floor, R lobe; physical "
               "optics against ray optics; ray optics against the model"}});
    write_scatterogram_panels(h5, "beam illumination by level",
                              {{"physical optics (2.5D)", &po},
                               {"ray optics + thin film", &beam.simulation},
                               {"Huang 2022 model", &beam.model}});
    h5.set_attribute("/figure", "note",
                     fmt::format("relative L1 against the model: physical optics {:.3f} (noise "
                                 "floor {:.3f}; R lobe {:.3f}), ray optics {:.3f}",
                                 e.l1, e.floor, e.l1_r, e.ray_optics_l1));
    h5.commit();
    run_plot("scatterogram_levels", dir / "beam_levels.h5", dir / "beam_levels.png");
}

// The beam scatterogram at the physical-optics level beside the ray-traced one and the model's,
// with the ray-traced one's metrics and verdict.
std::string physical_optics_scatterogram_section(const Run& run, const ScatterogramPair& beam,
                                                 const gonio::Scatterogram& po,
                                                 RockDoveResult& result) {
    const LevelScatterogramErrors e = level_scatterogram_errors(beam, po);
    result.verdicts.push_back(
        {"scatterogram (beam), physical optics", scatterogram_verdict(po, beam.model)});
    result.physical_optics_scatterogram_relative_l1 = e.l1;
    result.physical_optics_scatterogram_relative_l1_noise_floor = e.floor;
    result.physical_optics_scatterogram_error =
        gonio::median_relative_standard_error(po, kSignalFraction);
    result.physical_optics_scatterogram_seconds = po.wall_time_s;
    physical_optics_scatterogram_figure(run, beam, po, e);
    const gonio::ScatterometerConfig& c = po.config;
    return fmt::format(
        "### Beam scatterogram at the physical-optics level\n\n"
        "The beam scatterogram's instrument above (beam at ϑ = {:.0f}°, φ = {:.0f}°, {:g} µm "
        "spot radius, {} px, {} wavelengths, its own random streams) measures the same 2.5D "
        "level. Against the Huang model: relative L1 **{:.3f}** (noise floor {:.3f}; "
        "ray-traced: {:.3f}); R lobe alone, the like-for-like part: {:.3f}; against the "
        "ray-traced scatterogram: {:.3f}. Median per-pixel σ {:.1f} % ({:.2g} quanta/λ, {} "
        "pass{}, {:.1f} s).\n\n![beam scatterograms by level](scatterograms/beam_levels.png)"
        "\n\nLeft to right: physical optics (2.5D), ray optics + thin film, Huang model; top: "
        "colour at one exposure for all three, bottom: their luminance on one logarithmic "
        "scale. As above, this level has the R lobe only (none of the TRT, T and multi light "
        "around the model's and ray optics' peak) and does not block light reflected towards a "
        "neighbour. Data: `scatterograms/beam_levels.h5` (`figure/`, `relative_error`) and the "
        "records `beam_physical_optics.h5`, `beam_simulation.h5`, `beam_model.h5`.\n\n",
        std::acos(std::clamp(c.beam_direction.z(), -1.0, 1.0)) / kDeg,
        std::atan2(c.beam_direction.y(), c.beam_direction.x()) / kDeg, c.beam_radius_um,
        c.image_size, c.wavelengths_nm.size(), e.l1, e.floor, e.ray_optics_l1, e.l1_r,
        e.against_ray_optics, 100.0 * result.physical_optics_scatterogram_error,
        static_cast<double>(po.quanta), po.passes, po.passes == 1 ? "" : "es", po.wall_time_s);
}

// The physical-optics level, when chosen: its BRDF, then its beam scatterogram.
std::string physical_optics_level(const Run& run, const sim::wave::PhysicalOptics25d& level,
                                  const Brdfs& brdfs, const ScatterogramPair& beam,
                                  const fs::path& checkpoints, RockDoveResult& result) {
    const gonio::BrdfRecord po =
        measure_physical_optics_brdf(run, level, checkpoints / "brdf_physical_optics.checkpoint");
    std::string md = physical_optics_section(run, brdfs, po, level, result);
    const gonio::Scatterogram po_beam = measure_physical_optics_scatterogram(run, level);
    return md + physical_optics_scatterogram_section(run, beam, po_beam, result);
}

// ---- 3. Validation where the model's assumptions hold: R lobe only, short cells. ------------

// Cells short enough that Eq. 7's longitudinal coupling is s.validation_cell_coupling, on a row
// long and wide enough for a beam spanning many barbule periods.
geometry::BarbuleRowParams short_cell_row(const Settings& s) {
    geometry::BarbuleRowParams short_row = s.row;
    const double rho_min = short_row.cell.b * short_row.cell.b * short_row.cell.semi_major_um;
    const double r_theta =
        s.validation_cell_coupling * rho_min / (1.0 - std::cos(short_row.cell.theta_d));
    short_row.cell.cell_length_um = 2.0 * r_theta * std::sin(short_row.cell.theta_d);
    short_row.cell.melanin_depth_um = std::min(short_row.cell.melanin_depth_um, 0.5 * rho_min);
    const double length_y =
        std::max(200.0, 4.0 * std::max(s.scatterometer.beam_radius_um,
                                       5.0 * short_row.H * short_row.cell.semi_major_um));
    short_row.barbules = std::max(
        short_row.barbules,
        static_cast<int>(std::ceil(length_y / (short_row.H * short_row.cell.semi_major_um))));
    short_row.cells_per_barbule =
        static_cast<int>(std::ceil(length_y / short_row.cell.cell_length_um));
    return short_row;
}

gonio::GoniometerConfig validation_config(const Settings& s,
                                          const geometry::BarbuleRowParams& short_row,
                                          std::uint64_t seed) {
    gonio::GoniometerConfig v;
    v.direction_set = "custom: light in the transversal plane, views across it";
    const Vec3d light = gonio::direction_from_angles(s.validation_light_theta, 0.0);
    for (int k = -15; k <= 15; ++k)
        v.pairs.push_back(
            {light, gonio::direction_from_angles(std::abs(k) * 5.0 * kDeg, k < 0 ? kPi : 0.0)});
    v.wavelengths_nm = {s.wavelengths.front(), s.wavelengths[s.wavelengths.size() / 2],
                        s.wavelengths.back()};
    v.detector_half_angle_rad = s.validation_detector_half_angle;
    // The beam must span many barbule periods: the model averages over one.
    v.beam_radius_um =
        std::max(s.scatterometer.beam_radius_um, 5.0 * short_row.H * short_row.cell.semi_major_um);
    v.seed = seed;  // ctx.stream("rock_dove/validation")
    v.quanta_per_pass = s.validation_quanta;
    v.max_passes = 1;
    v.estimator = gonio::Estimator::photon;
    return v;
}

// The R lobes cell by cell in units of σ (writes r_lobe.csv at the middle wavelength). σ from
// the expected counts (Poisson: a reflected quantum carries weight 1, so Var = f / (P N) with
// P = π sin²α cos θ_v the detector's projected solid angle) — the sample σ is 0 in cells where
// the simulation saw nothing — plus the model's cone-cubature error.
void compare_r_lobes(const gonio::BrdfRecord& a, const gonio::BrdfRecord& b,
                     const fs::path& csv_path, RockDoveResult& result) {
    const gonio::GoniometerConfig& v = a.config;
    const int ra = analysis::lobe_index(a.lobes, "R"), rb = analysis::lobe_index(b.lobes, "R");
    const std::size_t np = v.pairs.size(), nl = v.wavelengths_nm.size();
    std::ofstream csv(csv_path);
    csv << fmt::format(
        "view angle (deg) at {:.0f} nm,simulation R,simulation_err,model R,model_err\n",
        v.wavelengths_nm[nl / 2]);
    for (std::size_t p = 0; p < np; ++p) {
        for (std::size_t k = 0; k < nl; ++k) {
            const double sa = a.lobe_values[(static_cast<std::size_t>(ra) * np + p) * nl + k];
            const double sb = b.lobe_values[(static_cast<std::size_t>(rb) * np + p) * nl + k];
            const double projected =
                kPi * std::pow(std::sin(v.detector_half_angle_rad), 2) * v.pairs[p].wo.z();
            const double sigma =
                std::sqrt(std::max(sa, sb) / (projected * static_cast<double>(a.quanta))) +
                b.error_at(p, k);
            if (sa > 0.0 || sb > 0.0) {
                if (sigma > 0.0)
                    result.validation_max_sigma =
                        std::max(result.validation_max_sigma, std::abs(sa - sb) / sigma);
                ++result.validation_cells;
            }
            if (k == nl / 2) {
                const double angle = (static_cast<double>(p) - 15.0) * 5.0;
                csv << fmt::format("{:.1f},{:.6g},{:.6g},{:.6g},{:.6g}\n", angle, sa,
                                   a.error_at(p, k), sb, b.error_at(p, k));
            }
        }
    }
    close_written(csv, csv_path);
}

std::string validation(const Run& run, const Built& b, RockDoveResult& result) {
    const Settings& s = run.s;
    const geometry::BarbuleRowParams short_row = short_cell_row(s);
    run.ctx.clock().say(
        fmt::format("validation: {} short cells ({:.3f} um) per barbule, R lobe only",
                    short_row.cells_per_barbule, short_row.cell.cell_length_um));
    const geometry::BarbuleRow vrow = geometry::build_barbule_row(short_row, s.tolerance);
    sim::TracerOptions single;
    single.max_events = 1;
    const sim::ExplicitScatterer vsim(sim::barbule_row_scene(vrow), single);
    gonio::GoniometerConfig v =
        validation_config(s, short_row, run.ctx.stream("rock_dove/validation"));
    const gonio::BrdfRecord a = gonio::measure_brdf(vsim, v);
    v.estimator = gonio::Estimator::eval;
    const gonio::BrdfRecord m = gonio::measure_brdf(*b.model, v);
    const fs::path dir = run.dir / "validation";
    gonio::write_brdf_record(a, dir / "simulation_R.h5");
    gonio::write_brdf_record(m, dir / "model.h5");
    compare_r_lobes(a, m, dir / "r_lobe.csv", result);
    run_plot("curves", dir / "r_lobe.csv", dir / "r_lobe.png");
    // P(max |z| ≥ z_max) over n independent normal cells: 1 − (1 − erfc(z_max/√2))^n.
    const double p =
        -std::expm1(static_cast<double>(result.validation_cells) *
                    std::log1p(-std::erfc(result.validation_max_sigma / std::sqrt(2.0))));
    return fmt::format(
        "## Where the model's assumptions hold\n\nR lobe only (the tracer stops after one event), "
        "smooth film, "
        "cells {:.3f} µm long so that Eq. 7's longitudinal coupling r_θ(1 − cos θ_d)/(b²A) = "
        "{:.3f}; light at θ = "
        "{:.0f}° in the transversal plane, views across it. Largest |simulation − model| = {:.2f} "
        "σ over {} cells "
        "with signal ({} wavelengths); if the two agree, a largest |z| at least this large over "
        "that many independent cells has probability p = {:.2g} (Šidák), so {}:\n\n![R "
        "lobe](validation/r_lobe.png)\n\n",
        short_row.cell.cell_length_um, s.validation_cell_coupling, s.validation_light_theta / kDeg,
        result.validation_max_sigma, result.validation_cells, v.wavelengths_nm.size(), p,
        p >= 0.01 ? "they agree within the Monte Carlo error"
                  : "they differ by more than the Monte Carlo error (p < 0.01)");
}

// ---- 3b. Huang's parameters fitted to the simulation. ----------------------------------------

// The study grid's wavelengths nearest 450, 550 and 650 nm (distinct): the film's colour
// across the visible at a third of a full spectrum's cost.
std::vector<double> fit_wavelengths(const std::vector<double>& grid) {
    std::vector<double> picked;
    for (double target : {450.0, 550.0, 650.0}) {
        const double nearest = *std::min_element(grid.begin(), grid.end(), [&](double a, double b) {
            return std::abs(a - target) < std::abs(b - target);
        });
        if (std::find(picked.begin(), picked.end(), nearest) == picked.end())
            picked.push_back(nearest);
    }
    return picked;
}

using HuangValues = std::array<double, analysis::kHuang2022ParameterCount>;

// The fitted parameters against those the patch was built with, in standard errors.
std::string huang_fit_table(const analysis::HuangFitResult& fit, const HuangValues& expected) {
    std::string table =
        "| parameter | fitted | standard error | built with | (fitted − built) / σ |\n"
        "|---|---|---|---|---|\n";
    for (int i = 0; i < analysis::kHuang2022ParameterCount; ++i) {
        const std::string name(analysis::kHuang2022ParameterNames[i]);
        if (std::isnan(fit.standard_errors[i])) {
            table += fmt::format("| {} | {:.5g} (held) | — | {:.5g} | — |\n", name, fit.values[i],
                                 expected[i]);
            continue;
        }
        table += fmt::format("| {} | {:.5g} | {:.2g} | {:.5g} | {:+.1f}{} |\n", name, fit.values[i],
                             fit.standard_errors[i], expected[i],
                             (fit.values[i] - expected[i]) / fit.standard_errors[i],
                             fit.at_bound[i] ? " (at its bound)" : "");
    }
    return table;
}

// fit/huang2022_fit.h5: the fitted values, their standard errors and the built-with values.
void write_huang_fit_record(const fs::path& path, const analysis::HuangFitResult& fit,
                            const HuangValues& expected) {
    const std::vector<double> values(fit.values.begin(), fit.values.end()),
        errors(fit.standard_errors.begin(), fit.standard_errors.end());
    record::Hdf5Writer h5(path);
    const std::string names =
        fmt::format("{}", fmt::join(analysis::kHuang2022ParameterNames, ", "));
    h5.write(
        "fit/values", std::span<const double>(values), {values.size()},
        {{"units", "b 1, phi0 rad, phi1 rad, H 1, d_um um, theta_d rad, mu rad"},
         {"description", "Huang 2022 parameters fitted to fit/simulation.h5 (" + names + ")"}});
    h5.write("fit/standard_errors", std::span<const double>(errors), {errors.size()},
             {{"units", "as fit/values"},
              {"description", "standard errors from the covariance at the optimum; NaN: held"}});
    h5.write("fit/built_with", std::span<const double>(expected.data(), expected.size()),
             {expected.size()},
             {{"units", "as fit/values"},
              {"description", "the parameters the explicit patch was built from"}});
    h5.set_attribute("/fit", "reduced_chi_square", fit.reduced_chi_square);
    h5.set_attribute("/fit", "observations", static_cast<double>(fit.observations));
    h5.set_attribute("/fit", "termination", fit.termination);
    h5.commit();
}

// The explicit patch was built from Huang's rock-dove parameters; fitting the model to its
// simulated scatterogram asks whether the model, given the simulation, gives them back, and by
// how many standard errors it misses each (the model leaves out interreflection and the curved
// film of long cells, so it need not).
std::string huang_fit(const Run& run, const Built& b, RockDoveResult& result) {
    const Settings& s = run.s;
    if (!s.fit) return {};
    gonio::ScatterometerConfig c;
    c.illumination = gonio::Illumination::beam;
    c.beam_direction = gonio::direction_from_angles(s.fit_incidence, s.fit_azimuth);
    c.image_size = s.fit_image_size;
    c.wavelengths_nm = fit_wavelengths(s.wavelengths);
    c.beam_radius_um = s.scatterometer.beam_radius_um;
    c.seed = run.ctx.stream("rock_dove/fit_scatterogram");
    c.quanta_per_pass = s.fit_quanta;
    c.max_passes = 1;
    c.config_text = run.ctx.text();
    run.ctx.clock().say("Huang fit: simulated beam scatterogram");
    const gonio::Scatterogram data = gonio::measure_scatterogram(*b.simulation, c);
    gonio::write_scatterogram_record(data, run.dir / "fit" / "simulation.h5");
    run.ctx.clock().say("Huang fit: Levenberg-Marquardt");
    const analysis::Huang2022Params truth = analysis::huang_params_of(s.row);
    analysis::HuangFitOptions options;
    options.fixed = {"phi0", "phi1"};  // the arc's ends are hidden at these parameters
    options.pixel_stride = s.fit_pixel_stride;
    // Blind: from the model's defaults and its global stage (analysis/fits/huang2022_fit.h), not
    // from the values the patch was built with; φ0 and φ1 are held at those (hidden, so unfitted).
    analysis::Huang2022Params start;
    start.phi0 = truth.phi0;
    start.phi1 = truth.phi1;
    const analysis::HuangFitResult fit = analysis::fit_huang2022(data, start, options);
    analysis::FitProvenance provenance;
    provenance.standard_errors = true;
    const std::vector<std::string> warnings =
        analysis::summarise_fit(fit, options, provenance).warnings;
    throw_if_interrupted("the Huang fit");
    result.fit_reduced_chi_square = fit.reduced_chi_square;
    const auto expected = analysis::huang2022_values(truth);
    const std::string table = huang_fit_table(fit, expected);
    write_huang_fit_record(run.dir / "fit" / "huang2022_fit.h5", fit, expected);
    const int dof = fit.degrees_of_freedom;
    const double p = analysis::chi_square_p_value(fit.reduced_chi_square * dof, dof);
    return fmt::format(
        "## Huang's parameters fitted to the simulation\n\n"
        "The explicit patch under a beam at θ = {:.0f}°, φ = {:.0f}° ({}×{} pixels, {} quanta at "
        "{} nm), fitted blind: from the model's defaults, through its global stage (a grid of "
        "film thickness, tilt and spacing, Levenberg–Marquardt from the best points, then scans "
        "from the best optimum; analysis/fits/huang2022_fit.h), not from the parameters the patch "
        "was "
        "built with; φ0 and φ1 "
        "held (the arc's ends are hidden). {} observations, reduced χ² {:.2f} ({}; σ² includes "
        "a 1 % model floor), {} runs, {} iterations in the best, {:.1f} s, {}. {}A parameter "
        "many σ from the value the patch was built with is one the model, given the simulation, "
        "reads differently: the model leaves out interreflection and the curved film of long "
        "cells (next sections).\n\n{}\n",
        s.fit_incidence / kDeg, s.fit_azimuth / kDeg, c.image_size, c.image_size, c.quanta_per_pass,
        fmt::join(c.wavelengths_nm, ", "), fit.observations, fit.reduced_chi_square,
        p_value_text(p), fit.local_fits, fit.iterations, fit.wall_time_s,
        fit.converged ? "converged" : "not converged: " + fit.termination,
        warnings.empty() ? std::string()
                         : fmt::format("**Warnings** (analysis/fits/fit_summary.h): {}. ",
                                       fmt::join(warnings, "; ")),
        table);
}

// ---- 4. Error against run time. ----------------------------------------------------------------

std::string exponent_text(const analysis::PowerLawFit& f) {
    if (f.points < 2) return "(too few passes to fit)";
    if (f.points == 2)
        return fmt::format("t^{:.2f} (two passes: no error on the slope)", f.exponent);
    return fmt::format("t^({:.2f} ± {:.2f})", f.exponent, f.exponent_standard_error);
}

// The caption of the error-against-time figure, every claim computed from the passes.
std::string convergence_caption(const std::vector<analysis::ErrorAgainstReference>& rows,
                                const std::vector<double>& times,
                                const std::vector<double>& estimated,
                                const std::vector<double>& true_error,
                                const std::vector<double>& sim_times,
                                const std::vector<double>& sim_errors) {
    if (rows.empty()) return "No pass completed.";
    const analysis::ErrorAgainstReference& last = rows.back();
    const analysis::PowerLawFit est = analysis::fit_power_law(times, estimated);
    const analysis::PowerLawFit tru = analysis::fit_power_law(times, true_error);
    std::string text = fmt::format(
        "The model's R lobe measured by the same photon estimator the simulation uses, pass by "
        "pass, against its exact values (eval, the cone cubature at {} cells with signal). Over "
        "{} passes the error the instrument estimates falls as {}, the true error as {} "
        "(a Monte Carlo error falls as t^−0.5). ",
        last.cells, rows.size(), exponent_text(est), exponent_text(tru));
    const bool consistent = last.p_value >= 0.01;
    text += fmt::format(
        "At the last pass ({:.1f} s) the true error is {:.3f} and the estimate {:.3f}; the "
        "reference's own cubature error is {:.3f}. χ² of the deviations against σ² + ε² is {:.1f} "
        "over {} cells ({}): {}. ",
        times.back(), last.true_error, last.estimated, last.reference_floor, last.chi_square,
        last.cells, p_value_text(last.p_value),
        consistent ? "the deviations are as large as the stated errors say"
                   : "the deviations are larger than the stated errors (bias, or a reference "
                     "worse than its estimated error)");
    // Levelling off: the true error's slope over the later half of the passes.
    const std::size_t half = times.size() / 2;
    if (times.size() - half >= 3) {
        const std::span<const double> t_late(times.data() + half, times.size() - half),
            e_late(true_error.data() + half, times.size() - half);
        const analysis::PowerLawFit late = analysis::fit_power_law(t_late, e_late);
        if (late.exponent > -0.25) {
            text += fmt::format(
                "Over the last {} passes the true error no longer falls (slope {:.2f}); it is an "
                "RMS over {} cells, which scatters by about 1/√(2n) = {:.0f} % of itself even "
                "when σ is right{}. ",
                late.points, late.exponent, last.cells, 100.0 / std::sqrt(2.0 * last.cells),
                last.true_error < 2.0 * last.reference_floor
                    ? ", and it is within twice the reference's own error"
                    : "");
        } else {
            text +=
                fmt::format("Over the last {} passes the true error still falls (slope {:.2f}). ",
                            late.points, late.exponent);
        }
    }
    const analysis::PowerLawFit sim = analysis::fit_power_law(sim_times, sim_errors);
    if (sim.points >= 2) {
        text += fmt::format("The simulation's estimated error falls as {}, to {:.3f} in {:.1f} s.",
                            exponent_text(sim), sim_errors.back(), sim_times.back());
    }
    return text;
}

// The R lobe by the photon estimator against the model's exact values (eval), pass by pass,
// and the simulation's estimated error. The caption's claims (slopes, agreement, where the
// true error stops falling) are computed from the passes, not written in advance.
std::string convergence(const Run& run, const Built& b,
                        const std::vector<gonio::ConvergenceRow>& simulation_passes) {
    const Settings& s = run.s;
    gonio::GoniometerConfig c = goniometer_config(run);
    c.direction_set = "filip2024_in_plane";
    c.pairs = gonio::filip2024_in_plane_pairs();
    c.wavelengths_nm = {s.wavelengths[s.wavelengths.size() / 2]};
    c.estimator = gonio::Estimator::eval;
    // The narrow R lobe crosses the detector cones and Eq. 7's facet tilts end sharply at ±θ_d:
    // a fine rule for the truth, whose own error (against half the rings) is carried along.
    c.eval_rings = s.convergence_reference_rings;
    const gonio::BrdfRecord truth = gonio::measure_brdf(*b.model, c);
    c.estimator = gonio::Estimator::photon;
    c.seed = run.ctx.stream("rock_dove/convergence");
    c.quanta_per_pass = s.convergence_quanta;
    c.max_passes = s.convergence_passes;
    const std::size_t np = c.pairs.size();
    const int r_truth = analysis::lobe_index(truth.lobes, "R");
    const std::span<const double> reference(
        truth.lobe_values.data() + static_cast<std::size_t>(r_truth) * np, np);
    // The cubature's error estimate is for the total; the R lobe carries all of it here (TRT
    // is smooth), so the total's |fine − coarse| bounds the lobe's.
    const std::span<const double> reference_error(truth.standard_error.data(), np);
    std::vector<double> times, estimated, true_error;
    std::vector<analysis::ErrorAgainstReference> rows;
    gonio::RunControl rc;
    rc.on_pass_record = [&](const gonio::BrdfRecord& r) {
        const std::size_t rl = static_cast<std::size_t>(analysis::lobe_index(r.lobes, "R"));
        const analysis::ErrorAgainstReference e = analysis::error_against_reference(
            std::span<const double>(r.lobe_values.data() + rl * np, np),
            std::span<const double>(r.lobe_standard_error.data() + rl * np, np), reference,
            reference_error);
        rows.push_back(e);
        times.push_back(r.wall_time_s);
        estimated.push_back(e.estimated);
        true_error.push_back(e.true_error);
    };
    run.ctx.clock().say(
        "error against run time: Huang R lobe, photon estimator against exact values");
    gonio::measure_brdf(*b.model, c, rc);
    std::ofstream csv(run.dir / "convergence" / "error_vs_time.csv");
    csv << "label,wall_time_s,estimated_error,true_error,reference_floor,chi_square,cells,"
           "p_value\n";
    for (std::size_t i = 0; i < rows.size(); ++i) {
        csv << fmt::format(
            "Huang R lobe (photon estimator),{:.6g},{:.6g},{:.6g},{:.6g},{:.6g},{},"
            "{:.6g}\n",
            times[i], rows[i].estimated, rows[i].true_error, rows[i].reference_floor,
            rows[i].chi_square, rows[i].cells, rows[i].p_value);
    }
    std::vector<double> sim_times, sim_errors;
    for (const auto& r : simulation_passes) {
        // No exact values exist for the simulation: its true error is unknown (−1, not plotted).
        csv << fmt::format("simulation BRDF,{:.6g},{:.6g},-1,-1,-1,-1,-1\n", r.wall_time_s,
                           r.estimated_relative_rms_error);
        sim_times.push_back(r.wall_time_s);
        sim_errors.push_back(r.estimated_relative_rms_error);
    }
    close_written(csv, run.dir / "convergence" / "error_vs_time.csv");
    run_plot("convergence", run.dir / "convergence" / "error_vs_time.csv",
             run.dir / "convergence" / "error_vs_time.png");
    return "## Error against run time\n\n" +
           convergence_caption(rows, times, estimated, true_error, sim_times, sim_errors) +
           "\n\n![error vs time](convergence/error_vs_time.png)\n\n";
}

// ---- Level of physics judged by full wave ------------------------------------------------------

// The study's barbule row in 2D (one cell, its spacing and tilt) and the sampling step its
// sharpest curvature allows (sim/wave/compare/ray_optics_validity.h), for the full-wave judgements.
struct StudyRow2d {
    sim::wave::Row2d row;
    double step_um = 0.0;
};

StudyRow2d study_row_2d(const geometry::BarbuleRowParams& p) {
    const double a = p.cell.semi_major_um;
    return {
        sim::wave::barbule_row_2d(a, p.cell.b, p.cell.phi0, p.cell.phi1, p.cell.film_thickness_um,
                                  p.cell.melanin_depth_um, p.H, p.mu, 1),
        0.95 * sim::wave::barbule_row_min_radius_um(a, p.cell.b, p.cell.phi0, p.cell.phi1)};
}

// The cross-section the embedded full-wave reference was computed for
// (tests/reference/fullwave_rock_dove/README.md): studies/rock_dove.toml's barbule, beam at 0°
// (μ within 0.01°: the quick study's −0.35 rad is −20.0535°).
struct FullWaveReferenceCase {
    double semi_major_um = 10.0, b = 0.25, film_um = 0.59, gap_um = 0.3, mu_rad = -20.05 * kDeg;
};

bool matches_reference(const Settings& s) {
    const FullWaveReferenceCase r;
    const geometry::BarbuleRowParams& p = s.row;
    const auto same = [](double a, double b) {
        return std::abs(a - b) <= 1e-9 * std::max(1.0, std::abs(b));
    };
    return same(p.cell.semi_major_um, r.semi_major_um) && same(p.cell.b, r.b) &&
           same(p.cell.film_thickness_um, r.film_um) && same(p.cell.melanin_depth_um, r.gap_um) &&
           std::abs(p.mu - r.mu_rad) <= 0.01 * kDeg && std::abs(s.beam_incidence) <= 1e-9;
}

// σ curves per wavelength (TE/TM, coarse and fine) from the embedded far_field_back.csv:
// case, polarisation, theta_i_deg, lambda_nm, resolution_px_per_um, theta_s_deg, sigma_um_per_rad.
std::vector<sim::wave::FullWaveCurves2d> embedded_full_wave_curves() {
    const auto rows = embedded_csv_rows(kFullWaveRockDoveFarField);
    std::map<double, sim::wave::FullWaveCurves2d> by_lambda;
    double coarse = std::numeric_limits<double>::infinity(), fine = 0.0;
    for (std::size_t i = 1; i < rows.size(); ++i) {
        const double res = std::stod(rows[i].at(4));
        coarse = std::min(coarse, res);
        fine = std::max(fine, res);
    }
    for (std::size_t i = 1; i < rows.size(); ++i) {
        const auto& r = rows[i];
        const double lambda = std::stod(r.at(3)), res = std::stod(r.at(4));
        sim::wave::FullWaveCurves2d& c = by_lambda[lambda];
        c.lambda_nm = lambda;
        c.coarse_px_per_um = coarse;
        c.fine_px_per_um = fine;
        const int pol = r.at(1) == "TE" ? 0 : 1;
        auto& curve = res == fine ? c.fine[pol] : c.coarse[pol];
        curve.push_back(std::stod(r.at(6)));
        if (pol == 0 && res == fine) c.theta_s_rad.push_back(std::stod(r.at(5)) * kDeg);
    }
    std::vector<sim::wave::FullWaveCurves2d> out;
    for (auto& [lambda, c] : by_lambda) out.push_back(std::move(c));
    return out;
}

// Band-integrated back-scattered width (TE + TM, trapezoid over the reference's wavelengths) at
// each resolution, from the embedded totals.csv: the convergence the issue asks of the air-gap
// case.
std::pair<double, double> back_power_by_resolution(double& coarse_res, double& fine_res) {
    const auto rows = embedded_csv_rows(kFullWaveRockDoveTotals);
    std::map<double, std::map<double, double>> by_res;  // resolution → λ → Σ_pol back width
    for (std::size_t i = 1; i < rows.size(); ++i)
        by_res[std::stod(rows[i].at(4))][std::stod(rows[i].at(3))] += std::stod(rows[i].at(5));
    const auto band = [](const std::map<double, double>& w) {
        double sum = 0.0;
        for (auto it = w.begin(); std::next(it) != w.end(); ++it)
            sum += 0.5 * (it->second + std::next(it)->second) * (std::next(it)->first - it->first);
        return sum;
    };
    coarse_res = by_res.begin()->first;
    fine_res = by_res.rbegin()->first;
    return {band(by_res.begin()->second), band(by_res.rbegin()->second)};
}

// The per-wavelength table of the full-wave judgement: each level's L1 and power error, and the
// reference's own coarse-vs-fine difference.
std::string verdict_table(const sim::wave::FullWaveVerdict2d& v) {
    std::string table =
        "| λ (nm) | physical optics: L1, power | ray optics + film: L1, power | full wave, "
        "coarse vs fine: L1, power |\n|---|---|---|---|\n";
    for (const auto& w : v.wavelengths)
        table += fmt::format(
            "| {:.0f} | {:.1f} %, {:+.1f} % | {:.1f} %, {:+.1f} % | {:.1f} %, {:+.1f} % |\n",
            w.lambda_nm, 100.0 * w.physical_optics.relative_l1,
            100.0 * w.physical_optics.power_error, 100.0 * w.ray_optics.relative_l1,
            100.0 * w.ray_optics.power_error, 100.0 * w.full_wave_resolution.relative_l1,
            100.0 * w.full_wave_resolution.power_error);
    return table;
}

std::string full_wave_judgement(const Run& run, RockDoveResult& result) {
    const geometry::BarbuleRowParams& p = run.s.row;
    if (!matches_reference(run.s))
        return "**Judged by full wave: not for this cross-section.** The embedded full-wave "
               "reference "
               "(tests/reference/fullwave_rock_dove) is the default study's barbule (A = 10 µm, b "
               "= 0.25, "
               "film 0.59 µm over a 0.3 µm gap, μ = −20.05°, beam at 0°); this study's differs, so "
               "the "
               "verdict above is physical against ray optics only. `plumage_fullwave_reference` "
               "computes "
               "a reference for the default barbule; other cross-sections are not yet wired "
               "in.\n\n";
    run.ctx.clock().say(
        "level of physics: physical and ray optics against the full-wave reference");
    const auto start = std::chrono::steady_clock::now();
    const std::vector<sim::wave::FullWaveCurves2d> curves = embedded_full_wave_curves();
    const StudyRow2d barbule = study_row_2d(p);
    const sim::wave::FullWaveVerdict2d v =
        sim::wave::judge_against_full_wave(barbule.row, curves, {}, 0.05, barbule.step_um);
    double coarse_res = 0.0, fine_res = 0.0;
    const auto [back_coarse, back_fine] = back_power_by_resolution(coarse_res, fine_res);
    const double back_diff = back_coarse / back_fine - 1.0;
    result.level_full_wave = v.level;
    result.level_full_wave_po_l1 = v.worst_po_l1;
    result.level_full_wave_go_l1 = v.worst_go_l1;
    result.level_full_wave_resolution_l1 = v.worst_resolution_l1;
    result.level_full_wave_back_power_diff = back_diff;
    const std::string table = verdict_table(v);
    // where a level's miss exceeds the reference's own grid difference, it is resolved
    int po_resolved = 0, go_resolved = 0;
    for (const auto& w : v.wavelengths) {
        po_resolved += w.physical_optics.relative_l1 > w.full_wave_resolution.relative_l1 ? 1 : 0;
        go_resolved += w.ray_optics.relative_l1 > w.full_wave_resolution.relative_l1 ? 1 : 0;
    }
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return fmt::format(
        "**Judged by full wave.** One barbule of this study with its {:g} µm air gap, in 2D, "
        "solved by the "
        "suite's full-wave level (Meep's FDTD library, sim/fullwave; the reference embedded from "
        "tests/reference/fullwave_rock_dove, {} wavelengths {:.0f}–{:.0f} nm, TE and TM at {:g} "
        "and {:g} "
        "px/µm): its band-integrated back-scattered power differs by {:+.2f} % between the two "
        "grids "
        "({}). Through the same 5° window, unpolarised, over the back half-space:\n\n{}\n"
        "**Cheapest level within 5 % of full wave: {}** (largest L1: physical optics {:.1f} % at "
        "{:.0f} nm, "
        "ray optics + film {:.1f} % at {:.0f} nm; full wave's own coarse-vs-fine L1 at most {:.1f} "
        "%, exceeded by physical optics' miss at {} and by ray optics' at {} of the {} "
        "wavelengths, "
        "where the miss is resolved; {:.1f} s). What the cheaper levels leave out here: both "
        "sample the barbule's lit arc with "
        "a "
        "planar stack under each point (light crosses the film and the gap only through the "
        "stack's "
        "r), no light through the melanin, no multiple scattering; physical optics adds the arc's "
        "diffraction, ray optics has none. Full wave has the closed body (melanin core under a "
        "uniform gap and film, whose outer surface departs from Huang's ellipse by O((d + g)²/ρ) "
        "at "
        "the tips) and leaves out only the grid.\n\n",
        p.cell.melanin_depth_um, curves.size(), curves.front().lambda_nm, curves.back().lambda_nm,
        coarse_res, fine_res, 100.0 * back_diff,
        std::abs(back_diff) <= 0.02 ? "converged: within 2 %" : "NOT converged: over 2 %", table,
        v.level, 100.0 * v.worst_po_l1, v.worst_po_lambda_nm, 100.0 * v.worst_go_l1,
        v.worst_go_lambda_nm, 100.0 * v.worst_resolution_l1, po_resolved, go_resolved,
        v.wavelengths.size(), seconds);
}

// The embedded row reference's reflectances (totals.csv: polarisation, theta_i_deg, lambda_nm,
// resolution_px_per_um, reflectance, …) per wavelength, TE and TM at its two grids.
std::vector<sim::wave::RowReflectanceFullWave> embedded_row_reflectances(double& coarse_res,
                                                                         double& fine_res) {
    const auto rows = embedded_csv_rows(kFullWaveRockDoveRowTotals);
    coarse_res = std::numeric_limits<double>::infinity();
    fine_res = 0.0;
    for (std::size_t i = 1; i < rows.size(); ++i) {
        coarse_res = std::min(coarse_res, std::stod(rows[i].at(3)));
        fine_res = std::max(fine_res, std::stod(rows[i].at(3)));
    }
    std::map<double, sim::wave::RowReflectanceFullWave> by_lambda;
    for (std::size_t i = 1; i < rows.size(); ++i) {
        const auto& r = rows[i];
        sim::wave::RowReflectanceFullWave& w = by_lambda[std::stod(r.at(2))];
        w.lambda_nm = std::stod(r.at(2));
        auto& pols = std::stod(r.at(3)) == fine_res ? w.fine : w.coarse;
        pols[r.at(0) == "TE" ? 0 : 1] = std::stod(r.at(4));
    }
    std::vector<sim::wave::RowReflectanceFullWave> out;
    for (const auto& [lambda, w] : by_lambda) out.push_back(w);
    return out;
}

// Every fifth wavelength of the row judgement, a table row each: R of each level.
std::string row_table(const sim::wave::RowVerdict2d& v) {
    std::string table =
        "| λ (nm) | full wave (fine) | full wave (coarse) | physical optics | ray optics + film "
        "|\n|---|---|---|---|---|\n";
    for (std::size_t k = 0; k < v.lambda_nm.size(); k += 5)
        table += fmt::format("| {:.0f} | {:.4f} | {:.4f} | {:.4f} | {:.4f} |\n", v.lambda_nm[k],
                             v.full_wave[k], v.full_wave_coarse[k], v.physical_optics[k],
                             v.ray_optics[k]);
    return table;
}

// Full wave's certificate of this study's row (studies/level_choice.h): the committed reference
// where it covers the row (tests/reference/fullwave_rock_dove_row), else full wave computed here
// when [level] full_wave_budget_minutes affords it, else none, with the reason.
LevelCertificate row_certificate(const Settings& s, const StudyProgress& clock) {
    const geometry::BarbuleRowParams& p = s.row;
    const double a = p.cell.semi_major_um;
    const StudyRow2d row = study_row_2d(p);
    LevelCertificate c;
    std::vector<sim::wave::RowReflectanceFullWave> reference;
    if (matches_reference(s) && std::abs(p.H - 1.25) <= 1e-9) {
        clock.say("level of physics: the barbule row against its committed full-wave reference");
        double coarse_res = 0.0, fine_res = 0.0;
        reference = embedded_row_reflectances(coarse_res, fine_res);
        c.source = fmt::format(
            "the committed reference tests/reference/fullwave_rock_dove_row: {} wavelengths "
            "{:.0f}–{:.0f} nm, TE and TM, at {:.4g} and {:.4g} px/µm",
            reference.size(), reference.front().lambda_nm, reference.back().lambda_nm, coarse_res,
            fine_res);
    } else {
        const RowScene scene{a,   p.cell.b, p.cell.film_thickness_um, p.cell.melanin_depth_um,
                             p.H, p.mu,     s.beam_incidence};
        const LiveRowReference live = live_row_reference(scene, s.wavelengths, s.level, clock);
        if (live.reflectance.empty()) {
            c.source = live.why_none;
            return c;
        }
        reference = live.reflectance;
        c.source = live.source;
    }
    c.verdict = sim::wave::judge_row_against_full_wave(row.row, s.beam_incidence, reference,
                                                       s.level.tolerance, row.step_um);
    c.present = true;
    return c;
}

// The row of this study's barbules, endless and periodic, judged by full wave through its
// reflectance (the certificate above; sim/wave/compare/levels_against_full_wave.h).
std::string full_wave_row_judgement(const Run& run, const LevelCertificate& c,
                                    RockDoveResult& result) {
    if (!c.present) return {};
    const geometry::BarbuleRowParams& p = run.s.row;
    const sim::wave::RowVerdict2d& v = c.verdict;
    result.row_full_wave_level = v.level;
    result.row_full_wave_reflectance = v.band_full_wave;
    result.row_full_wave_resolution_error = v.resolution_error;
    result.row_physical_optics_error = v.po_error;
    result.row_ray_optics_error = v.go_error;
    return fmt::format(
        "**On a row, judged by full wave.** The same barbules as an endless row, one every {:g} "
        "µm, lit at {:g}°, in full wave with Bloch boundaries (`full_wave_row`; {}): band-mean "
        "reflectance, all diffraction orders, unpolarised, **R = {:.4f}**; the coarse grid gives "
        "{:.4f} ({:+.2f} %: {}). From rows of 12 and 4 barbules, their ends cancelled: physical "
        "optics R = {:.4f} ({:+.1f} %), ray optics + film R = {:.4f} ({:+.1f} %).\n\n{}\n"
        "**Cheapest level within {:g} % of full wave on the row: {}**. This verdict is on the "
        "power the row sends back, band-mean and over all directions; how that power is spread "
        "over directions is judged above, on one barbule through the 5° window. On the row the "
        "cheaper levels also leave out what passes between and through the barbules and comes "
        "back after a second barbule (they trace one bounce off the lit arcs); full wave keeps "
        "all of it.\n\n",
        p.H * p.cell.semi_major_um, run.s.beam_incidence / kDeg, c.source, v.band_full_wave,
        v.band_full_wave_coarse, 100.0 * v.resolution_error,
        std::abs(v.resolution_error) <= 0.02 ? "converged: within 2 %" : "NOT converged: over 2 %",
        v.band_physical_optics, 100.0 * v.po_error, v.band_ray_optics, 100.0 * v.go_error,
        row_table(v), 100.0 * v.threshold, v.level);
}

// ---- Level of physics: does this row need physical optics? ----------------------------------

// The study's barbule row in 2D (its cross-section, spacing, tilt and rotation jitter; rows of
// at least 4 barbules and 40 µm, fewer than the patch's when it is longer), PO against GO at the
// study's wavelengths and the beam's incidence taken in the cross-section's plane
// (sim/wave/compare/ray_optics_validity.h: the 5° goniometer window, unpolarised).
std::string level_of_physics(const Run& run, RockDoveResult& result) {
    run.ctx.clock().say(
        "level of physics: physical against geometric optics on the 2D barbule row");
    const auto start = std::chrono::steady_clock::now();
    const geometry::BarbuleRowParams& p = run.s.row;
    const double a = p.cell.semi_major_um;
    const sim::wave::Row2d row = study_wave_row(run.s, run.ctx.stream("rock_dove/wave_row"));
    const int count = row.count;
    sim::wave::RayOpticsValidityOptions options;
    options.max_step_um =
        0.95 * sim::wave::barbule_row_min_radius_um(a, p.cell.b, p.cell.phi0, p.cell.phi1);
    const std::vector<double> incidence = {run.s.beam_incidence};
    const sim::wave::RayOpticsValidity2d v =
        sim::wave::compare_ray_and_physical_optics(row, run.s.wavelengths, incidence, options);
    // The same row with the air gap under the film closed (keratin directly on melanin): the
    // coherent gap makes the stack's r(θ) vary fast and its specular reflection dark at some
    // wavelengths, where PO's edge terms weigh most; the full-wave reference covers the
    // gap-free stack (tests/reference/barbule_2d/README.md). Both numbers are shown so that a
    // reader can tell the barbule's width from the gap.
    sim::wave::Row2d closed = sim::wave::barbule_row_2d(
        a, p.cell.b, p.cell.phi0, p.cell.phi1, p.cell.film_thickness_um, 0.0, p.H, p.mu, count);
    closed.jitter_rotation_rad = row.jitter_rotation_rad;
    closed.realisations = row.realisations;
    closed.seed = row.seed;
    const sim::wave::RayOpticsValidity2d v_closed =
        sim::wave::compare_ray_and_physical_optics(closed, run.s.wavelengths, incidence, options);
    result.level_relative_l1 = v.max_relative_l1;
    result.level_noise_floor = v.max_relative_l1_noise_floor;
    result.level_power_error = v.cases[v.worst_case].power_error;
    result.level_ray_optics_suffices = v.ray_optics_suffices;
    result.level_relative_l1_gap_closed = v_closed.max_relative_l1;
    result.level_seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    const sim::wave::LevelComparison2d& worst = v.cases[v.worst_case];
    const sim::wave::LevelComparison2d& worst_closed = v_closed.cases[v_closed.worst_case];
    return fmt::format(
        "## Level of physics\n\n"
        "Physical optics (diffraction, coherent over the row) against ray optics + thin film on "
        "this study's barbule cross-sections in 2D ({} barbules of width {:g} µm, H = {}, μ = "
        "{:.2f} rad{}), θ_i = {:.0f}° in the cross-section's plane, unpolarised, through a 5° "
        "window (sim/wave/compare/ray_optics_validity.h): relative L1 **{:.1f} %** (largest over "
        "the {} "
        "wavelengths, at {:g} nm; noise floor {:.1f} %{}), total reflected power {:+.1f} %. "
        "**{}** ({:.2f} s; PO {:.2f} s, GO {:.3f} s wall).\n\n"
        "With the {:g} µm air gap under the film closed (keratin directly on melanin, the stack "
        "the full-wave reference checks) the same row gives L1 {:.1f} % (at {:g} nm), total "
        "reflected power {:+.1f} %: {} The map of where ray optics ends, and how its metric "
        "compares with full wave, is the wave_validity study.\n\n",
        count, 2.0 * a, p.H, p.mu,
        p.jitter_phi_rad > 0.0 ? fmt::format(", rotation jitter {:.3f} rad, {} realisations",
                                             p.jitter_phi_rad, row.realisations)
                               : ", no jitter",
        run.s.beam_incidence / kDeg, 100.0 * v.max_relative_l1, run.s.wavelengths.size(),
        worst.lambda_nm, 100.0 * v.max_relative_l1_noise_floor,
        row.realisations > 1 ? "" : ": a regular row is deterministic", 100.0 * worst.power_error,
        v.ray_optics_suffices
            ? "Within 5 %: ray optics + thin film suffices for these barbules"
            : "Above 5 %: physical and ray optics differ on these barbules' angular "
              "distribution; physical optics is needed",
        result.level_seconds, v.po_wall_s, v.go_wall_s, p.cell.melanin_depth_um,
        100.0 * v_closed.max_relative_l1, worst_closed.lambda_nm, 100.0 * worst_closed.power_error,
        v_closed.max_relative_l1 <= 0.5 * v.max_relative_l1
            ? "most of the difference above comes from the coherent gap (its r(θ) varies fast "
              "and its specular reflection is dark at some wavelengths), not from the "
              "barbules' width. Two approximations that differ say neither is right: full wave "
              "judges them below."
            : "the gap is not what makes the difference; full wave judges both below.");
}

// ---- 5. Report. --------------------------------------------------------------------------------

// Each departure's measurement (studies/rock_dove_departures.h): the grazing specular pairs run
// again with one thing changed at a time, and the TRT lobe against the model's exit law.
void measure_departures(const Run& run, const Built& b, const Brdfs& m, RockDoveResult& result) {
    const Settings& s = run.s;
    const auto say = [&](const std::string& what) { run.ctx.clock().say(what); };
    gonio::GoniometerConfig g = goniometer_config(run);
    g.seed = run.ctx.stream("rock_dove/departures");
    g.time_budget_s = std::numeric_limits<double>::infinity();
    g.target_relative_error = 0.0;
    result.departures.grazing = measure_grazing_departures(
        {*b.model, b.row, s.tolerance, g, s.validation_cell_coupling}, say);
    result.departures.brdf = brdf_lobe_excess(m.simulation, m.model);
    run.ctx.clock().say("departures: TRT exit law");
    result.departures.trt = trt_exit_departures(m.simulation, m.model, *b.model);
    measure_trt_variants({*b.model, b.row, s.tolerance, g, s.validation_cell_coupling},
                         m.simulation, m.model, result.departures.trt, say);
    result.departures.measured = true;
}

std::string departures(const Settings& s, const RockDoveResult& result) {
    return "## Where and why the model departs\n\n" +
           departures_markdown(result.departures, result.simulated_multi_share) +
           fmt::format(
               "- **T lobe.** Under the beam ({:.0f}° incidence) {}.\n"
               "- **Curved film, real cell length.** The simulated cells are {:.1f} µm long: "
               "their normal distribution is Eq. 7 × (1 + r_θ(1 − cos θ_m)/ρ(φ_m)), up to {:.2f} "
               "at the barbule's sharp edges (geometry/barbule.h). Eq. 7 holds only for short "
               "cells (section above, coupling {:.3f}).\n"
               "- **Undersides.** Where barbules leave gaps, oblique light reaches the concave "
               "underside of an arc, which no model lobe handles (analysis/models/huang2022.h, "
               "back_hit_fraction).\n\n",
               s.beam_incidence / kDeg,
               result.simulated_t == 0.0 && result.model_t == 0.0
                   ? fmt::format("no light passes between the barbules unchanged, in the "
                                 "simulation or the model (Eq. 15): at H = {} neighbours overlap "
                                 "as the beam sees them",
                                 s.row.H)
                   : fmt::format("the simulation lets {:.3g} of the light pass between barbules "
                                 "unchanged, the model {:.3g} (Eq. 15)",
                                 result.simulated_t, result.model_t),
               s.row.cell.cell_length_um, result.eq7_edge_coupling, s.validation_cell_coupling);
}

// The model's own error: the BRDF's cubature (not noise), the scatterograms' Monte Carlo (in σ).
std::string reference_error_text(const MeasurementVerdict& m) {
    const analysis::AgreementVerdict& v = m.verdict;
    if (m.measurement.rfind("BRDF", 0) != 0) return "— (Monte Carlo, in σ)";
    if (!(v.reference_error > 0.0)) return "not estimated by the record";
    return fmt::format("{:.2g} %{}", 100.0 * v.reference_error,
                       v.reference_converged ? "" : " (not converged)");
}

// The report's opening: each measurement's verdict against the model, from noise alone.
std::string verdict_block(const RockDoveResult& r) {
    std::string md =
        "## Verdicts\n\nSimulation against the Huang model, per measurement, from the Monte Carlo "
        "noise alone (analysis/metrics/verdict.h): z = (simulation − model)/σ per cell, χ² over "
        "the cells "
        "used, and the power difference against its σ; p is the smaller of the two tests' p, "
        "doubled; **differs** when p < 0.001, **agrees** when p >= 0.01, **undecided** between. "
        "Cells: scatterograms, where the model is above 1 % of its brightest pixel (σ: both "
        "images' Monte Carlo errors); BRDF, the simulation's signal cells (σ: its Monte Carlo "
        "error). The model's own cubature error is not noise and is not in σ: it stands in the "
        "last column, and over 1 % a *differs* may be the model's numerics.\n\n"
        "| measurement | verdict | cells | RMS z | beyond 3σ | p | power, simulation / model − 1 "
        "| model's own error (median) |\n|---|---|---|---|---|---|---|---|\n";
    for (const MeasurementVerdict& m : r.verdicts) {
        const analysis::AgreementVerdict& v = m.verdict;
        md += fmt::format(
            "| {} | **{}** | {} | {:.2f} | {:.1f} % | {} | {:+.2f} % ± {:.2f} % | {} |\n",
            m.measurement, v.verdict, v.cells, v.rms_z, 100.0 * v.beyond_3_sigma,
            p_value_text(v.p_value), 100.0 * v.power_difference, 100.0 * v.power_difference_sigma,
            reference_error_text(m));
    }
    return md + "\n";
}

void write_report(const fs::path& path, const Settings& s, const std::string& md,
                  const RockDoveResult& result) {
    std::ofstream report(path);
    report << "# Rock dove: explicit barbules against Huang et al. 2022\n\n"
           << fmt::format(
                  "Rock-dove parameters (Huang 2022): b = {}, φ0 = {:.2f}, φ1 = {:.2f}, H = {}, d "
                  "= {} µm, "
                  "θ_d = {:.4f}, μ = {:.2f}; {} barbules × {} cells of {} µm, semi-major axis {} "
                  "µm; melanin "
                  "{} µm under the film. Wavelengths {}–{} nm ({}), D65, CIE 1931 2°.\n\n",
                  s.row.cell.b, s.row.cell.phi0, s.row.cell.phi1, s.row.H,
                  s.row.cell.film_thickness_um, s.row.cell.theta_d, s.row.mu, s.row.barbules,
                  s.row.cells_per_barbule, s.row.cell.cell_length_um, s.row.cell.semi_major_um,
                  s.row.cell.melanin_depth_um, s.wavelengths.front(), s.wavelengths.back(),
                  s.wavelengths.size())
           << md
           << fmt::format(
                  "---\nRun time {:.0f} s (plumage {}). Records (HDF5, virtual_gonio/RECORD.md) in "
                  "scatterograms/, brdf/, validation/; the study file is in each record's "
                  "provenance.\n",
                  result.wall_seconds, kVersion);
    close_written(report, path);
}

}  // namespace

RockDoveResult run_rock_dove_study(const std::string& study_text, const fs::path& source_name,
                                   const fs::path& results_root, bool progress,
                                   const RunLimits& limits) {
    StudyContext ctx(study_text, source_name, results_root, limits, progress);
    const StudyProgress& clock = ctx.clock();
    std::string name;
    Settings s = read_settings(ctx.file(), name, source_name);  // read
    ctx.begin(name);
    s.time_budget_s = ctx.time_budget_s(s.time_budget_s);
    s.target_relative_error = ctx.target_relative_error(s.target_relative_error);
    RockDoveResult result;
    const Built built = build(s, ctx.file(), clock, result);  // build

    const fs::path out = ctx.out();
    for (const char* part : {"scatterograms", "brdf", "validation", "convergence", "fit"}) {
        fs::create_directories(out / part);
    }
    std::vector<MeasurementCost> costs;
    const Run run{s, ctx, out, costs};
    // Which level measures: full wave's certificate of this row, before any measurement.
    const LevelCertificate certificate = row_certificate(s, clock);
    const LevelDecision level = decide_level(s.level, certificate);
    result.level_measured_with = level.measured_with;
    result.level_needed = level.needed;
    result.level_warning = level.warning;
    if (!level.warning.empty() && progress)
        fmt::print(stderr, "plumage: warning: {}\n", level.warning);
    const auto physical_optics = level.physical_optics ? build_physical_optics(s, ctx) : nullptr;
    const fs::path checkpoints = ctx.checkpoints();
    const Scatterograms scattered = scatterograms(run, built, result);
    std::string md = scattered.markdown;  // measure and compare, section by section
    const Brdfs brdfs = measure_brdfs(run, built, checkpoints / "brdf_simulation.checkpoint");
    costs.push_back(
        brdf_cost(fmt::format("BRDF on {} ({} pairs): simulation", s.goniometer.direction_set,
                              brdfs.simulation.config.pairs.size()),
                  brdfs.simulation));
    costs.push_back(brdf_cost("BRDF: Huang model", brdfs.model));
    md += brdf_section(run, brdfs, result);
    md += colour_quadrature(run, built, brdfs, result);
    md += avian_vision(run, built, brdfs, result);
    md += in_plane_sweep(run, built);
    if (physical_optics)
        md += physical_optics_level(run, *physical_optics, brdfs, scattered.beam, checkpoints,
                                    result);
    md += validation(run, built, result);
    md += huang_fit(run, built, result);
    // Every pass of the record, those of an interrupted earlier run resumed from the checkpoint
    // included (the passes of this process alone would lose them).
    md += convergence(run, built, brdfs.simulation.convergence);
    md += level_of_physics(run, result);
    md += full_wave_judgement(run, result);
    md += full_wave_row_judgement(run, certificate, result);
    measure_departures(run, built, brdfs, result);
    md += departures(s, result);  // report
    result.wall_seconds = clock.elapsed_s();
    md += measurement_cost_section(costs);
    md += ctx.run_time_by_stage();
    write_report(out / "report.md", s, level.summary + "\n\n" + verdict_block(result) + md, result);
    result.output_dir = ctx.commit();  // the finished records supersede the checkpoints
    return result;
}

void check_rock_dove_study(const std::string& study_text, const fs::path& source_name) {
    StudyContext ctx(study_text, source_name);
    std::string name;
    read_settings(ctx.file(), name, source_name);
}

namespace {

// `plumage run`: the run, and the summary printed on stdout.
std::string run_from_command_line(const std::string& text, const fs::path& source,
                                  const fs::path& root, const RunLimits& limits) {
    const auto r = run_rock_dove_study(text, source, root, true, limits);
    return fmt::format("plumage: wrote {} in {:.0f} s (open report.md)\n", r.output_dir.string(),
                       r.wall_seconds);
}

}  // namespace

StudyEntry rock_dove_study_entry() {
    return {"rock_dove",
            "explicit rock-dove barbules against Huang et al. 2022 (scatterograms, Filip BRDF, "
            "in-plane, validation, convergence)",
            check_rock_dove_study, run_from_command_line};
}

}  // namespace plumage::studies
