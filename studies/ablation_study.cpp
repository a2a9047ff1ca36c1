#include "studies/ablation_study.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <functional>
#include <iostream>
#include <limits>
#include <map>
#include <optional>

#include <fmt/format.h>

#include "analysis/fits/huang2022_fit.h"
#include "analysis/models/huang2022.h"
#include "common/constants.h"
#include "common/distributed.h"
#include "common/error.h"
#include "common/interrupt.h"
#include "common/relative_l1.h"
#include "common/seed.h"
#include "common/version.h"
#include "geometry/barbule.h"
#include "sim/optics/colour.h"
#include "sim/optics/spectrum.h"
#include "sim/tracer.h"
#include "studies/instrument_tables.h"
#include "studies/plots.h"
#include "studies/sections.h"
#include "studies/staged_directory.h"
#include "studies/study.h"
#include "studies/study_context.h"
#include "studies/study_file.h"
#include "studies/study_progress.h"
#include "studies/text_files.h"
#include "virtual_gonio/direction_sets.h"
#include "virtual_gonio/exr_image.h"
#include "virtual_gonio/record/hdf5_file.h"
#include "virtual_gonio/scatterometer.h"

namespace plumage::studies {
namespace {

namespace fs = std::filesystem;
using geometry::BarbuleRowParams;

// One parameter of the sweep: its study-file key, how it reads and writes a row, its
// valid range (study-file units) and the full variant's default range.
struct Parameter {
    const char* key;
    const char* label;  // for tables and plots
    const char* what;
    Range range;
    double from, to;  // defaults
    std::function<double(const BarbuleRowParams&)> get;
    std::function<void(BarbuleRowParams&, double)> set;
};

// A Huang parameter's range (analysis/models/huang2022.h's table), in the sweep's unit: `per_unit`
// of the table's unit make one of the sweep's (kDeg for degrees), rounded to 1e-9 so that π/4
// reads 45.
Range huang_range(int index, double per_unit = 1.0) {
    const ParameterSpec& p = analysis::kHuang2022ParameterTable[static_cast<std::size_t>(index)];
    const auto in_unit = [&](double v) {
        return std::isfinite(v) ? std::round(v / per_unit * 1e9) / 1e9 : v;
    };
    return {std::isfinite(p.min) ? in_unit(p.min) : -1e300,
            std::isfinite(p.max) ? in_unit(p.max) : 1e300, p.min_open, p.max_open};
}

const std::vector<Parameter>& parameters() {
    static const std::vector<Parameter> list = {
        {"b", "b", "semi-minor / semi-major axis", huang_range(analysis::kHuangB), 0.19, 0.31,
         [](const BarbuleRowParams& p) { return p.cell.b; },
         [](BarbuleRowParams& p, double v) { p.cell.b = v; }},
        {"phi0_deg", "φ0 (deg)", "arc start, normal azimuth, degrees", between(-360.0, 360.0),
         -41.2, -1.2, [](const BarbuleRowParams& p) { return p.cell.phi0 / kDeg; },
         [](BarbuleRowParams& p, double v) { p.cell.phi0 = v * kDeg; }},
        {"phi1_deg", "φ1 (deg)", "arc end, normal azimuth, degrees", between(-360.0, 360.0), 131.26,
         171.26, [](const BarbuleRowParams& p) { return p.cell.phi1 / kDeg; },
         [](BarbuleRowParams& p, double v) { p.cell.phi1 = v * kDeg; }},
        {"H", "H", "barbule spacing, in semi-major axes", huang_range(analysis::kHuangH), 0.95,
         2.15, [](const BarbuleRowParams& p) { return p.H; },
         [](BarbuleRowParams& p, double v) { p.H = v; }},
        {"film_thickness_um", "d (µm)", "keratin film thickness, um", film_thickness_range(), 0.39,
         0.79, [](const BarbuleRowParams& p) { return p.cell.film_thickness_um; },
         [](BarbuleRowParams& p, double v) { p.cell.film_thickness_um = v; }},
        {"theta_d_deg", "θ_d (deg)", "longitudinal half-opening, degrees (the model needs > 0)",
         huang_range(analysis::kHuangThetaD, kDeg), 0.5, 8.5,
         [](const BarbuleRowParams& p) { return p.cell.theta_d / kDeg; },
         [](BarbuleRowParams& p, double v) { p.cell.theta_d = v * kDeg; }},
        {"mu_deg", "μ (deg)", "barb-plane tilt, degrees", huang_range(analysis::kHuangMu, kDeg),
         -40.05, -20.05, [](const BarbuleRowParams& p) { return p.mu / kDeg; },
         [](BarbuleRowParams& p, double v) { p.mu = v * kDeg; }},
    };
    return list;
}

struct Sweep {
    const Parameter* parameter;
    std::vector<double> values;
};

// The beam scatterogram of every swept value: 65 px, 50000 quanta in one pass, a 60 µm beam at
// normal incidence.
ScatterometerTable ablation_scatterometer_defaults() {
    ScatterometerTable t;
    t.config.illumination = gonio::Illumination::beam;
    t.config.image_size = 65;
    t.config.quanta_per_pass = 50000;
    t.config.max_passes = 1;
    t.config.beam_radius_um = 60.0;
    t.config.beam_direction =
        gonio::direction_from_angles(t.beam_incidence_rad, t.beam_azimuth_rad);
    return t;
}

struct Settings {
    BarbuleRowParams row;
    geometry::TessellationTolerance tolerance;
    std::vector<double> wavelengths;
    // [scatterometer] (studies/instrument_tables.h) at the defaults above.
    ScatterometerTable scatterometer = ablation_scatterometer_defaults();
    std::uint64_t seed = kDefaultSeed;
    std::vector<Sweep> sweeps;
};

Settings read_settings(StudyFile& file, std::string& name, const fs::path& source) {
    Settings s;
    ParameterTable root = file.root();
    name = read_study_name(root, source);
    root.string("study", "ablation", {"ablation"}, "which study this file describes");
    s.seed = read_seed(root);
    ParameterTable geometry = root.table("geometry");
    s.row = read_barbule_row_params(geometry);
    s.tolerance = read_tolerance(geometry.table("tessellation"));
    ParameterTable spectrum = root.table("spectrum");
    s.wavelengths = read_wavelengths(spectrum, WavelengthRule{});
    ParameterTable sc = root.table("scatterometer");
    ScatterometerKeys keys;
    keys.azimuth_from = "the barb axis";
    s.scatterometer = read_scatterometer_table(sc, s.scatterometer, keys);
    ParameterTable sweep = root.table("sweep");
    const long default_values =
        sweep.integer("values", 5, 0, 50, "values per parameter (0: no sweeps)");
    for (const Parameter& p : parameters()) {
        ParameterTable t = sweep.table(p.key);
        const double from = t.number("from", p.from, p.range, p.what);
        const double to = t.number("to", p.to, p.range, p.what);
        const long n = t.integer("values", default_values, 0, 50,
                                 "values of this parameter (0: leave it out)");
        if (to < from) {
            throw InputError(
                fmt::format("{}: sweep.{}.to = {} is below from = {}: expected from <= to",
                            t.location("to"), p.key, to, from));
        }
        if (n == 0) continue;
        Sweep w{&p, {}};
        for (long i = 0; i < n; ++i)
            w.values.push_back(n == 1 ? from
                                      : from + (to - from) * static_cast<double>(i) /
                                                   static_cast<double>(n - 1));
        s.sweeps.push_back(std::move(w));
    }
    root.reject_unused();
    return s;
}

// The numbers of one simulation–model pair of scatterograms.
AblationPoint compare(const gonio::Scatterogram& sim, const gonio::Scatterogram& mod) {
    AblationPoint r;
    const std::size_t nl = sim.config.wavelengths_nm.size();
    double diff = 0.0, power_sim = 0.0, power_mod = 0.0, noise = 0.0;
    for (std::size_t i = 0; i < sim.pixels() * nl; ++i) {
        const double omega = sim.solid_angle_sr[i / nl];
        diff += std::abs(mod.intensity[i] - sim.intensity[i]) * omega;
        power_sim += sim.intensity[i] * omega;
        power_mod += mod.intensity[i] * omega;
        noise += sim.standard_error[i] * omega;
    }
    // A perfect model differs from the simulation by its noise alone: E|N(0, σ)| = σ √(2/π).
    r.relative_l1 = RelativeL1::of(diff, power_sim);
    r.relative_l1_model_reference = RelativeL1::of(diff, power_mod);
    r.noise_floor = power_sim > 0.0 ? std::sqrt(2.0 / kPi) * noise / power_sim : 0.0;
    r.simulated_reflected = power_sim / static_cast<double>(nl);
    r.model_reflected = power_mod / static_cast<double>(nl);
    for (std::size_t k = 0; k < nl; ++k) {
        r.simulated_transmitted += sim.transmitted[k] / static_cast<double>(nl);
        r.model_transmitted += mod.transmitted[k] / static_cast<double>(nl);
    }
    return r;
}

std::string csv_field(const std::string& s) {
    std::string quoted = "\"";
    for (char c : s) quoted += c == '"' ? std::string("\"\"") : std::string(1, c);
    return quoted + "\"";
}

std::string format_value(double v) { return fmt::format("{:.4g}", v); }

// Folder-safe name of a value: "0.22", "-31.2".
std::string file_tag(std::size_t index, double v) { return fmt::format("{:02d}_{:.4g}", index, v); }

// ---- One run: what every step shares. -------------------------------------------------------

// One value: the explicit patch and the model of the same parameters, or the reason the
// geometry or the model refuses them.
struct Measured {
    std::optional<gonio::Scatterogram> sim, mod;
    std::string reason;
};

// The values to measure: the base first, then every sweep's values but the base value.
struct ValueJob {
    const Sweep* sweep = nullptr;  // null: the base
    std::size_t index = 0;
};

struct Run {
    const Settings& s;
    const StudyContext& ctx;  // text, clock, streams (study_context.h)
    gonio::ScatterometerConfig config;
    fs::path dir;
    double exposure = 1.0;  // of every image: the base model's brightest pixel → white
    AblationPoint base_point;
    std::vector<ValueJob> jobs;      // every value measured, in chunk order
    std::vector<Measured> measured;  // [job]

    const Measured& measured_at(const Sweep& sweep, std::size_t index) const {
        for (std::size_t j = 0; j < jobs.size(); ++j)
            if (jobs[j].sweep == &sweep && jobs[j].index == index) return measured[j];
        throw Error(
            fmt::format("ablation: {} value {} was not measured", sweep.parameter->key, index));
    }
};

gonio::ScatterometerConfig scatterometer_config(const Settings& s, const std::string& study_text,
                                                const RunLimits& limits) {
    gonio::ScatterometerConfig config = s.scatterometer.config;
    config.wavelengths_nm = s.wavelengths;
    config.seed = s.seed;  // replaced per measurement (value_config)
    config.config_text = study_text;
    if (limits.time_budget_s > 0.0) config.time_budget_s = limits.time_budget_s;
    if (limits.target_relative_error > 0.0)
        config.target_relative_error = limits.target_relative_error;
    return config;
}

// The scatterometer of one job's simulation ("simulation") or model ("model"): each measurement
// draws its own streams (common/seed.h), so no two values, and not a value's two images, share
// their noise.
gonio::ScatterometerConfig value_config(const Run& run, std::string_view who, std::size_t job) {
    gonio::ScatterometerConfig c = run.config;
    c.seed = run.ctx.stream(fmt::format("ablation/{}", who), job);
    return c;
}

Measured measure(const Run& run, const BarbuleRowParams& params, std::size_t job) {
    const Settings& s = run.s;
    Measured m;
    geometry::BarbuleRow row;
    try {
        row = geometry::build_barbule_row(params, s.tolerance);
    } catch (const InputError& e) {
        m.reason = fmt::format("the geometry rejects it: {}", e.what());
        return m;
    }
    std::optional<analysis::Huang2022Bsdf> model;
    try {
        model.emplace(analysis::huang_params_of(params));
    } catch (const InputError& e) {
        m.reason = fmt::format("the model rejects it: {}", e.what());
        return m;
    }
    // The beam's footprint must lie on the patch, or the simulation loses light off its edge.
    const Eigen::AlignedBox3d box = row.bounds();
    const double footprint =
        s.scatterometer.config.beam_radius_um / std::cos(s.scatterometer.beam_incidence_rad);
    const double half_width = 0.5 * std::min(box.sizes().x(), box.sizes().y());
    if (footprint > 0.8 * half_width) {
        m.reason = fmt::format(
            "the beam's footprint ({:.0f} um) overfills the patch ({:.0f} x {:.0f} um): "
            "more barbules or cells, or a narrower beam",
            footprint, box.sizes().x(), box.sizes().y());
        return m;
    }
    const sim::ExplicitScatterer simulation(sim::barbule_row_scene(row));
    m.sim = gonio::measure_scatterogram(simulation, value_config(run, "simulation", job));
    m.mod = gonio::measure_scatterogram(*model, value_config(run, "model", job));
    return m;
}

// ---- Every value at once, one chunk each, dealt over the MPI ranks (common/distributed.h). ----

// A scatterogram as a chunk result: everything but its configuration (the run's, on every rank).
void put_scatterogram(Bytes& b, const gonio::Scatterogram& s) {
    b.put_string(s.scatterer);
    b.put(static_cast<std::uint64_t>(s.lobes.size()));
    for (const std::string& lobe : s.lobes) b.put_string(lobe);
    for (const auto* v : {&s.intensity, &s.standard_error, &s.lobe_intensity, &s.solid_angle_sr,
                          &s.transmitted, &s.transmitted_lobes})
        b.put_vector(*v);
    b.put_vector(s.convergence);
    b.put(s.passes);
    b.put(s.quanta);
    b.put(s.wall_time_s);
    b.put(s.cpu_time_s);
}

gonio::Scatterogram get_scatterogram(Bytes& b, const gonio::ScatterometerConfig& config) {
    gonio::Scatterogram s;
    s.config = config;
    s.scatterer = b.get_string();
    s.lobes.resize(b.get<std::uint64_t>());
    for (std::string& lobe : s.lobes) lobe = b.get_string();
    for (auto* v : {&s.intensity, &s.standard_error, &s.lobe_intensity, &s.solid_angle_sr,
                    &s.transmitted, &s.transmitted_lobes})
        *v = b.get_vector<double>();
    s.convergence = b.get_vector<gonio::ConvergenceRow>();
    s.passes = b.get<int>();
    s.quanta = b.get<std::uint64_t>();
    s.wall_time_s = b.get<double>();
    s.cpu_time_s = b.get<double>();
    return s;
}

// Every value's simulation and model, keyed like the jobs. Each value is one chunk: measured
// by some rank, checkpointed by rank 0 as it arrives, skipped when a rerun finds it there.
std::vector<Measured> measure_all(const Run& run, const fs::path& checkpoints,
                                  const std::string& key) {
    const std::vector<ValueJob>& jobs = run.jobs;
    // The rank count stays out of the stage's name: stages.csv is the same for any count.
    run.ctx.clock().say(
        fmt::format("{} values (the base and the sweeps): simulation and model", jobs.size()));
    if (distributed::active())
        run.ctx.clock().done(fmt::format("  dealt over {} MPI ranks", distributed::size()));
    auto work = [&](std::size_t j) {
        BarbuleRowParams params = run.s.row;
        if (jobs[j].sweep != nullptr)
            jobs[j].sweep->parameter->set(params, jobs[j].sweep->values[jobs[j].index]);
        const Measured m = measure(run, params, j);
        Bytes b;
        b.put_string(m.reason);
        b.put(static_cast<char>(m.sim.has_value()));
        if (m.sim) put_scatterogram(b, *m.sim), put_scatterogram(b, *m.mod);
        return b;
    };
    distributed::ChunkOptions options;
    options.interrupt = &interrupt_flag();
    options.checkpoint_dir = checkpoints;
    options.checkpoint_key = key;
    options.on_chunk = [&](std::size_t done, std::size_t total) {
        run.ctx.clock().done(fmt::format("  {} of {} values measured", done, total));
    };
    distributed::ChunkResults results = distributed::deal_chunks(jobs.size(), work, options);
    if (results.interrupted) {
        throw Interrupted(
            fmt::format("interrupted while measuring the ablation values; the "
                        "finished ones are kept in {}",
                        checkpoints.string()));
    }
    if (results.resumed > 0)
        run.ctx.clock().done(
            fmt::format("  {} values resumed from {}", results.resumed, checkpoints.string()));
    for (const auto& [why, count] : results.not_resumed)
        run.ctx.clock().done(
            fmt::format("  {} value checkpoint(s) in {} not resumed, measured again: {}", count,
                        checkpoints.string(), why));
    std::vector<Measured> measured(jobs.size());
    for (std::size_t j = 0; j < jobs.size(); ++j) {
        Bytes& b = results.results[j];
        measured[j].reason = b.get_string();
        if (b.get<char>() != 0) {
            measured[j].sim = get_scatterogram(b, value_config(run, "simulation", j));
            measured[j].mod = get_scatterogram(b, value_config(run, "model", j));
        }
    }
    return measured;
}

// A scatterogram's PNG (display colour at the run's exposure) and, beside it with the same
// stem, its spectra as OpenEXR (virtual_gonio/exr_image.h).
void write_images(const fs::path& png, const gonio::Scatterogram& s, double exposure,
                  const std::string& name) {
    record::write_png(png, gonio::scatterogram_srgb(s, exposure));
    gonio::write_spectral_exr(fs::path(png).replace_extension(".exr"),
                              {gonio::scatterogram_exr_image(s, name)}, "ablation");
}

// The base values first: every sweep passes through them, and their model's brightest pixel
// sets the one exposure of every image.
void measure_base(Run& run, const std::string& geometry_location, const Measured& base) {
    fs::create_directories(run.dir / "base");
    if (!base.sim) {
        throw InputError(fmt::format("{}: [geometry] (the base of every sweep): {}",
                                     geometry_location, base.reason));
    }
    run.base_point = compare(*base.sim, *base.mod);
    const double peak = gonio::scatterogram_peak_luminance(*base.mod);
    run.exposure = peak > 0.0 ? 1.0 / peak : 1.0;
    write_images(run.dir / "base" / "simulation.png", *base.sim, run.exposure, "simulation");
    write_images(run.dir / "base" / "model.png", *base.mod, run.exposure, "model");
    gonio::write_scatterogram_record(*base.sim, run.dir / "base" / "simulation.h5");
    gonio::write_scatterogram_record(*base.mod, run.dir / "base" / "model.h5");
}

// ---- One parameter's sweep. ------------------------------------------------------------------

// A measured value of a sweep, with its images (paths relative to the parameter's folder).
struct SweptValue {
    AblationPoint point;
    std::string sim_png, mod_png;
};

// The base value, up to the rounding of a study file's decimals (Huang's −0.37 rad is
// −21.1994°, 0.0785 rad 4.4977°; a file that writes −21.2 or 4.5 means them): within 1 % of
// the sweep's step.
bool is_base_value(const Sweep& sweep, double v, double base_value) {
    const double step = sweep.values.size() > 1 ? sweep.values[1] - sweep.values[0] : 0.0;
    return std::abs(v - base_value) <=
           std::max(0.01 * step, 1e-9 * std::max(1.0, std::abs(base_value)));
}

std::vector<ValueJob> value_jobs(const Settings& s) {
    std::vector<ValueJob> jobs(1);  // the base
    for (const Sweep& sweep : s.sweeps)
        for (std::size_t i = 0; i < sweep.values.size(); ++i)
            if (!is_base_value(sweep, sweep.values[i], sweep.parameter->get(s.row)))
                jobs.push_back({&sweep, i});
    return jobs;
}

SweptValue measure_value(const Run& run, const Sweep& sweep, std::size_t i, const fs::path& pdir) {
    const Parameter& p = *sweep.parameter;
    const double v = sweep.values[i], base_value = p.get(run.s.row);
    SweptValue out;
    if (is_base_value(sweep, v, base_value)) {
        out.point = run.base_point;
        out.point.is_base = true;
        out.sim_png = (run.dir / "base" / "simulation.png").string();
        out.mod_png = (run.dir / "base" / "model.png").string();
    } else {
        const Measured& m = run.measured_at(sweep, i);
        if (m.sim) {
            out.point = compare(*m.sim, *m.mod);
            const std::string tag = file_tag(i, v);
            out.sim_png = (pdir / (tag + "_simulation.png")).string();
            out.mod_png = (pdir / (tag + "_model.png")).string();
            write_images(out.sim_png, *m.sim, run.exposure, "simulation");
            write_images(out.mod_png, *m.mod, run.exposure, "model");
        } else {
            out.point.skipped = true;
            out.point.reason = m.reason;
            run.ctx.clock().done(
                fmt::format("{} = {}: skipped ({})", p.key, format_value(v), m.reason));
        }
    }
    out.point.parameter = p.key;
    out.point.value = out.point.is_base ? base_value : v;
    return out;
}

// What a sweep's report section and summary need, gathered while its values are measured.
struct SweepTables {
    std::string table, skipped_list;
    std::vector<double> values, l1, floor;
    int skipped = 0;
};

// One value's lines in errors.csv, the sheet, error.csv, the table and the HDF5 columns.
void record_value(const Parameter& p, const SweptValue& x, std::ofstream& all_csv,
                  std::ofstream& sheet, std::ofstream& error_csv, const fs::path& pdir,
                  SweepTables& t) {
    const AblationPoint& point = x.point;
    const std::string label = fmt::format("{} = {}{}", p.label, format_value(point.value),
                                          point.is_base ? " (base)" : "");
    all_csv << fmt::format(
        "{},{:.9g},{},{},{:.6g},{:.6g},{:.6g},{:.6g},{:.6g},{:.6g},{:.6g},{}\n", p.key, point.value,
        point.is_base ? 1 : 0, point.skipped ? 1 : 0, point.relative_l1, point.noise_floor,
        point.relative_l1_model_reference, point.simulated_reflected, point.model_reflected,
        point.simulated_transmitted, point.model_transmitted, csv_field(point.reason));
    t.values.push_back(point.value);
    if (point.skipped) {
        ++t.skipped;
        sheet << fmt::format("{},,,{}\n", csv_field(label), csv_field("skipped: " + point.reason));
        error_csv << fmt::format("{:.9g},nan,nan,0\n", point.value);
        t.table += fmt::format("| {} | skipped: {} | | | | | | |\n", format_value(point.value),
                               point.reason);
        t.skipped_list +=
            fmt::format("- {} = {}: {}\n", p.label, format_value(point.value), point.reason);
        t.l1.push_back(std::numeric_limits<double>::quiet_NaN());
        t.floor.push_back(std::numeric_limits<double>::quiet_NaN());
        return;
    }
    // Paths relative to the sheet: a record must not name the staging folder it was written in.
    sheet << fmt::format("{},{},{},{}\n", csv_field(label),
                         csv_field(fs::path(x.sim_png).lexically_relative(pdir).string()),
                         csv_field(fs::path(x.mod_png).lexically_relative(pdir).string()),
                         csv_field(fmt::format("e = {:.3f} (noise floor {:.3f})", point.relative_l1,
                                               point.noise_floor)));
    error_csv << fmt::format("{:.9g},{:.6g},{:.6g},{}\n", point.value, point.relative_l1,
                             point.noise_floor, point.is_base ? 1 : 0);
    t.table +=
        fmt::format("| {}{} | {:.3f} | {:.3f} | {:.3f} | {:.4f} | {:.4f} | {:.4f} | {:.4f} |\n",
                    format_value(point.value), point.is_base ? " (base)" : "", point.relative_l1,
                    point.noise_floor, point.relative_l1_model_reference, point.simulated_reflected,
                    point.model_reflected, point.simulated_transmitted, point.model_transmitted);
    t.l1.push_back(point.relative_l1);
    t.floor.push_back(point.noise_floor);
}

// The smallest, largest and base errors of a sweep (null: none measured).
struct Extremes {
    const AblationPoint *smallest = nullptr, *largest = nullptr, *at_base = nullptr;
};
Extremes extremes_of(std::span<const AblationPoint> points) {
    Extremes e;
    for (const AblationPoint& q : points) {
        if (q.skipped) continue;
        if (!e.smallest || q.relative_l1 < e.smallest->relative_l1) e.smallest = &q;
        if (!e.largest || q.relative_l1 > e.largest->relative_l1) e.largest = &q;
        if (q.is_base) e.at_base = &q;
    }
    return e;
}

// "What the sweeps show": one line, keyed by the largest excess of the error over its floor.
std::pair<double, std::string> finding(const Parameter& p, std::span<const AblationPoint> points,
                                       const Extremes& e) {
    const AblationPoint* most = nullptr;
    double t_sim_lo = 1.0, t_sim_hi = 0.0, t_mod_lo = 1.0, t_mod_hi = 0.0;
    for (const AblationPoint& q : points) {
        if (q.skipped) continue;
        if (!most || q.relative_l1 - q.noise_floor > most->relative_l1 - most->noise_floor)
            most = &q;
        t_sim_lo = std::min(t_sim_lo, q.simulated_transmitted),
        t_sim_hi = std::max(t_sim_hi, q.simulated_transmitted);
        t_mod_lo = std::min(t_mod_lo, q.model_transmitted),
        t_mod_hi = std::max(t_mod_hi, q.model_transmitted);
    }
    std::string line = fmt::format(
        "- **{}**: e {:.3f} at {} to {:.3f} at {} (noise floors {:.3f} and {:.3f});", p.label,
        e.smallest->relative_l1, format_value(e.smallest->value), e.largest->relative_l1,
        format_value(e.largest->value), e.smallest->noise_floor, e.largest->noise_floor);
    if (e.at_base)
        line += fmt::format(" e − floor {:.3f} at the base value,",
                            e.at_base->relative_l1 - e.at_base->noise_floor);
    line += fmt::format(" largest {:.3f} at {}.", most->relative_l1 - most->noise_floor,
                        format_value(most->value));
    if (std::max(t_sim_hi, t_mod_hi) > 0.01) {
        line +=
            fmt::format(" Light below the patch: simulation {:.3f}–{:.3f}, model {:.3f}–{:.3f}.",
                        t_sim_lo, t_sim_hi, t_mod_lo, t_mod_hi);
    }
    return {most->relative_l1 - most->noise_floor, line};
}

// The whole report's pieces, gathered parameter by parameter.
struct ReportParts {
    std::string sections, skipped_list;
    std::string summary =
        "| parameter | values | skipped | e at the base value | smallest e | largest e "
        "|\n|---|---|---|---|---|---|\n";
    std::vector<std::pair<double, std::string>> findings;
};

void report_sweep(const Parameter& p, const Sweep& sweep, std::span<const AblationPoint> points,
                  const SweepTables& t, ReportParts& parts) {
    const Extremes e = extremes_of(points);
    if (e.smallest) parts.findings.push_back(finding(p, points, e));
    auto at = [](const AblationPoint* q) {
        return q ? fmt::format("{:.3f} at {}", q->relative_l1, format_value(q->value))
                 : std::string("—");
    };
    parts.summary += fmt::format(
        "| [{}](#{}) | {}–{} ({}) | {} | {} | {} | {} |\n", p.label, p.key,
        format_value(sweep.values.front()), format_value(sweep.values.back()), sweep.values.size(),
        t.skipped,
        e.at_base ? fmt::format("{:.3f}", e.at_base->relative_l1) : std::string("(not swept)"),
        at(e.smallest), at(e.largest));
    parts.sections += fmt::format("<a id=\"{}\"></a>\n## {} ({})\n\n", p.key, p.label, p.what);
    if (e.smallest) {
        parts.sections += fmt::format(
            "![model error against {}]({}/error.png)\n\n"
            "Rows: values of {}; columns: simulation | Huang model (one exposure for every image: "
            "white = the brightest pixel of the base model).\n\n![contact "
            "sheet]({}/contact_sheet.png)\n\n",
            p.label, p.key, p.label, p.key);
    } else {
        parts.sections += "Every value was skipped; nothing to plot.\n\n";
    }
    parts.sections += t.table + "\n";
    parts.skipped_list += t.skipped_list;
}

// One parameter: every value measured, recorded (its folder, errors.csv, ablation.h5) and
// reported; its figures queued.
void sweep_parameter(const Run& run, const Sweep& sweep, std::ofstream& all_csv,
                     record::Hdf5Writer& h5, AblationResult& result, ReportParts& parts,
                     std::vector<PlotJob>& plots) {
    const Parameter& p = *sweep.parameter;
    const fs::path pdir = run.dir / p.key;
    fs::create_directories(pdir);
    std::ofstream sheet(pdir / "sheet.csv"), error_csv(pdir / "error.csv");
    sheet << "label,simulation,model,note\n";
    error_csv << csv_field(p.label) << ",relative L1 (simulation reference),noise floor,is_base\n";
    SweepTables t;
    t.table = fmt::format(
        "| {} | e | noise floor | e (model reference) | reflected, simulation | "
        "reflected, model | below, simulation | below, model "
        "|\n|---|---|---|---|---|---|---|---|\n",
        p.label);
    const std::size_t first_point = result.points.size();
    for (std::size_t i = 0; i < sweep.values.size(); ++i) {
        const SweptValue x = measure_value(run, sweep, i, pdir);
        result.points.push_back(x.point);
        record_value(p, x, all_csv, sheet, error_csv, pdir, t);
    }
    result.skipped += t.skipped;
    h5.write(std::string(p.key) + "/value", std::span<const double>(t.values), {t.values.size()},
             {{"units", "study-file units (degrees for angles, um for the film)"},
              {"description", "the swept parameter's values, one per sweep point"}});
    h5.write(std::string(p.key) + "/relative_l1", std::span<const double>(t.l1), {t.l1.size()},
             {{"units", "1"},
              {"description",
               "sum |I_model - I_sim| Omega / sum I_sim Omega over pixels and wavelengths"}});
    h5.write(std::string(p.key) + "/noise_floor", std::span<const double>(t.floor),
             {t.floor.size()},
             {{"units", "1"},
              {"description",
               "relative L1 a perfect model would show: sqrt(2/pi) sum sigma_sim Omega / sum I_sim "
               "Omega"}});
    const std::span<const AblationPoint> points(result.points.data() + first_point,
                                                result.points.size() - first_point);
    if (extremes_of(points).smallest) {
        plots.push_back({"contact_sheet", pdir / "sheet.csv", pdir / "contact_sheet.png"});
        plots.push_back({"sweep_error", pdir / "error.csv", pdir / "error.png"});
    }
    close_written(sheet, pdir / "sheet.csv");
    close_written(error_csv, pdir / "error.csv");
    report_sweep(p, sweep, points, t, parts);
}

// ---- Report. ---------------------------------------------------------------------------------

std::string report_introduction(const Settings& s, const AblationPoint& base_point) {
    const auto& c = s.row.cell;
    return "# Ablation: Huang et al. 2022 against explicit barbules, one parameter at a time\n\n" +
           fmt::format(
               "Each parameter of the barbule model is swept alone; all others keep the base "
               "values "
               "(the study's [geometry], Huang's rock-dove fit unless changed): b = {}, φ0 = "
               "{:.2f}°, "
               "φ1 = {:.2f}°, H = {}, d = {} µm, θ_d = {:.2f}°, μ = {:.2f}°; cells {} µm long, "
               "semi-major "
               "axis {} µm, melanin {} µm under the film; {} barbules × {} cells. For every value "
               "the "
               "explicit patch is traced and the model evaluated under the same beam (incidence "
               "{:.0f}°, "
               "azimuth {:.0f}°, radius {} µm), imaged by the same scatterometer ({} × {} pixels, "
               "{} "
               "wavelengths {}–{} nm, {} quanta per wavelength).\n\n",
               c.b, c.phi0 / kDeg, c.phi1 / kDeg, s.row.H, c.film_thickness_um, c.theta_d / kDeg,
               s.row.mu / kDeg, c.cell_length_um, c.semi_major_um, c.melanin_depth_um,
               s.row.barbules, s.row.cells_per_barbule, s.scatterometer.beam_incidence_rad / kDeg,
               s.scatterometer.beam_azimuth_rad / kDeg, s.scatterometer.config.beam_radius_um,
               s.scatterometer.config.image_size, s.scatterometer.config.image_size,
               s.wavelengths.size(), s.wavelengths.front(), s.wavelengths.back(),
               s.scatterometer.config.quanta_per_pass *
                   static_cast<std::uint64_t>(s.scatterometer.config.max_passes)) +
           "**Model error** e = Σ|I_model − I_sim| Ω / Σ I_sim Ω over pixels and wavelengths: the "
           "power-weighted "
           "relative L1 difference of the two scatterograms with the simulation as reference (0: "
           "identical; 1: "
           "as large as all the simulated light). The **noise floor** is the e a perfect model "
           "would show "
           "against this many simulated quanta, √(2/π) Σ σ_sim Ω / Σ I_sim Ω; an e near it is "
           "Monte Carlo noise, "
           "not model error. *e (model reference)* divides by the model's power instead, as the "
           "rock-dove "
           "study's tables do.\n\n" +
           fmt::format(
               "Base values: e = {:.3f} (noise floor {:.3f}); reflected {:.4f} (simulation) and "
               "{:.4f} "
               "(model) of the beam's power.\n\n![base: simulation](base/simulation.png) "
               "![base: model](base/model.png)\n\n",
               base_point.relative_l1, base_point.noise_floor, base_point.simulated_reflected,
               base_point.model_reflected);
}

void write_report(const fs::path& path, const Settings& s, const AblationPoint& base_point,
                  ReportParts& parts, double wall_seconds, double measure_seconds,
                  const std::string& run_time) {
    std::ofstream report(path);
    report << report_introduction(s, base_point) << "## Summary\n\n" << parts.summary << "\n";
    std::sort(parts.findings.begin(), parts.findings.end(),
              [](const auto& a, const auto& b) { return a.first > b.first; });
    report << "## What the sweeps show\n\nParameters in order of the largest excess of the model "
              "error over its "
              "noise floor, e − floor (a rough gauge, not a bound, of the part of the error that "
              "more quanta would not remove):\n\n";
    for (const auto& f : parts.findings) report << f.second << "\n";
    report << "\nWhere e − floor stays near its base value across a sweep, the model follows the "
              "parameter as the "
              "explicit barbules do; where it grows, the model's approximations (one film "
              "reflection and one melanin "
              "bounce, Eq. 7's normal distribution of short cells, no light between neighbours but "
              "the straight T "
              "lobe) lose accuracy in that direction. The tables below give every value.\n\n";
    if (!parts.skipped_list.empty()) {
        report << "**Skipped values** (the geometry or the model refuses them; the sweep goes on "
                  "without them):\n\n"
               << parts.skipped_list << "\n";
    } else {
        report << "No value was skipped.\n\n";
    }
    report << parts.sections << run_time
           << fmt::format(
                  "---\nRun time {:.0f} s (measuring every value {:.1f} s; plumage {}). Every "
                  "number is in "
                  "errors.csv "
                  "and ablation.h5; the base scatterograms as records (virtual_gonio/RECORD.md) in "
                  "base/.\n",
                  wall_seconds, measure_seconds, kVersion);
    close_written(report, path);
}

}  // namespace

const AblationPoint* AblationResult::base() const {
    for (const auto& p : points)
        if (p.is_base) return &p;
    return nullptr;
}

AblationResult run_ablation_study(const std::string& study_text, const fs::path& source_name,
                                  const fs::path& results_root, bool progress,
                                  const RunLimits& limits) {
    StudyContext ctx(study_text, source_name, results_root, limits, progress);
    const StudyProgress& clock = ctx.clock();
    std::string name;
    const Settings s = read_settings(ctx.file(), name, source_name);  // read
    ctx.begin(name);
    Run run{s, ctx, scatterometer_config(s, study_text, limits), ctx.out(), 1.0, {}, {}, {}};
    run.jobs = value_jobs(s);  // build and measure, value by value
    // The values' checkpoints belong to this build, study text and limits (the study reads no
    // input file: its geometry is made from the text).
    run.measured =
        measure_all(run, ctx.checkpoints() / "values",
                    fmt::format("{}|{}|{:.17g}|{:.17g}", gonio::checkpoint_build(), study_text,
                                limits.time_budget_s, limits.target_relative_error));
    measure_base(run, ctx.root().table("geometry").location(), run.measured.front());
    const double measure_seconds = clock.elapsed_s();

    AblationResult result;
    ReportParts parts;
    std::ofstream all_csv(run.dir / "errors.csv");
    all_csv << "parameter,value,is_base,skipped,relative_l1,noise_floor,relative_l1_model_"
               "reference,simulated_reflected,"
               "model_reflected,simulated_transmitted,model_transmitted,reason\n";
    record::Hdf5Writer h5(run.dir / "ablation.h5");
    h5.set_attribute(
        "/", "description",
        "Huang 2022 model against the explicit barbule patch, one parameter at a time: per "
        "parameter the "
        "swept values and the model's power-weighted relative L1 error of the beam scatterogram, "
        "simulation as reference (NaN: value skipped)");
    h5.set_attribute("/", "plumage_version", kVersion);
    std::vector<PlotJob> plots;  // drawn at the end, with one interpreter start
    for (const Sweep& sweep : s.sweeps)
        sweep_parameter(run, sweep, all_csv, h5, result, parts, plots);
    close_written(all_csv, run.dir / "errors.csv");
    h5.commit();
    clock.say(fmt::format("plots: {} figures", plots.size()));  // report
    run_plots(plots, run.dir / "plots.csv");
    fs::remove(run.dir / "plots.csv");
    result.wall_seconds = clock.elapsed_s();
    write_report(run.dir / "report.md", s, run.base_point, parts, result.wall_seconds,
                 measure_seconds, ctx.run_time_by_stage());
    result.output_dir = ctx.commit();
    return result;
}

void check_ablation_study(const std::string& study_text, const fs::path& source_name) {
    StudyContext ctx(study_text, source_name);
    std::string name;
    read_settings(ctx.file(), name, source_name);
}

namespace {

// `plumage run`: the run, and the summary printed on stdout.
std::string run_from_command_line(const std::string& text, const fs::path& source,
                                  const fs::path& root, const RunLimits& limits) {
    const auto r = run_ablation_study(text, source, root, true, limits);
    return fmt::format("plumage: wrote {} in {:.0f} s ({} values skipped; open report.md)\n",
                       r.output_dir.string(), r.wall_seconds, r.skipped);
}

}  // namespace

StudyEntry ablation_study_entry() {
    return {"ablation", "one-at-a-time sweeps of Huang's parameters, simulation against model",
            check_ablation_study, run_from_command_line};
}

}  // namespace plumage::studies
