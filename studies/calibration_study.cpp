// The calibration study (`study = "calibration"`): the goniometer's photon estimator on a
// virtual white standard, f = ρ/π, against its closed form. It is also the smallest complete
// study, and the template for a new one: one file (this), one line in PLUMAGE_STUDIES
// (studies/study.h), one example file (studies/calibration.toml).
//
// read → build → measure → compare → report, each a named step below.
//
// Study file keys (units, ranges):
//   name, seed                                        (studies/sections.h)
//   [spectrum]   first_nm, last_nm, step_nm           (300–800 nm; default 400–700, 50 nm)
//   [standard]   albedo                               ρ of the standard, [0, 1]; default 0.99
//   [goniometer] direction_set                        "filip2024_in_plane" (55 pairs) or
//                                                     "filip2024_btf" (3660); default in-plane
//                quanta_per_pass, passes              per (light, wavelength); 20 000 × 4
//                detector_half_angle_deg              (0, 10]; default 2.5
//                significance                         of the χ² verdict, (0, 0.5); 0.01
//
// The comparison is exact: for a cone wholly above the horizon the photon estimator's mean is
// the cosine-weighted cone average of f, which for a Lambertian is ρ/π itself; so
// z = (f̂ − ρ/π)/σ̂ per cell, Σz² is χ² with one degree of freedom per cell, and the verdict is
// its p-value against the significance.
#include <cmath>
#include <fstream>
#include <numbers>

#include <fmt/format.h>

#include "analysis/metrics/statistics.h"
#include "analysis/models/lambertian.h"
#include "common/version.h"
#include "sim/scatterer/random.h"
#include "studies/instrument_tables.h"
#include "studies/sections.h"
#include "studies/staged_directory.h"
#include "studies/study.h"
#include "studies/study_context.h"
#include "studies/study_progress.h"
#include "virtual_gonio/direction_sets.h"
#include "virtual_gonio/goniometer.h"
#include "virtual_gonio/record/hdf5_file.h"

namespace plumage::studies {
namespace {

namespace fs = std::filesystem;

struct Settings {
    std::string name;
    double albedo = 0.99;
    double significance = 0.01;
    gonio::GoniometerConfig goniometer;
};

struct Comparison {
    std::vector<double> z;  // per cell, (f̂ − ρ/π)/σ̂; NaN where σ̂ = 0
    double chi_square = 0.0;
    int dof = 0;
    double p_value = 1.0;
    double max_abs_z = 0.0;
    bool agrees = true;
};

Settings read(StudyContext& ctx) {
    ParameterTable root = ctx.root();
    root.string("study", "calibration", {"calibration"}, "which study this file describes");
    Settings s;
    s.name = read_study_name(root, ctx.source());
    ParameterTable spectrum = root.table("spectrum");
    ParameterTable standard = root.table("standard");
    s.albedo = standard.number("albedo", s.albedo, between(0.0, 1.0), "albedo of the standard");
    ParameterTable g = root.table("goniometer");
    gonio::GoniometerConfig& c = s.goniometer;
    c.direction_set = "filip2024_in_plane";
    c.detector_half_angle_rad = 2.5 * std::numbers::pi / 180.0;
    c.quanta_per_pass = 20000;
    c.max_passes = 4;
    GoniometerKeys keys;
    keys.direction_sets = {"filip2024_in_plane", "filip2024_btf"};
    keys.max_detector_half_angle_deg = 10.0;
    c = read_goniometer_table(g, c, keys);
    c.wavelengths_nm = read_wavelengths(spectrum, WavelengthRule{});
    s.significance = g.number("significance", s.significance, {0.0, 0.5, true, true},
                              "significance of the chi-square verdict");
    c.estimator = gonio::Estimator::photon;
    c.seed = ctx.stream("calibration/brdf");
    c.config_text = ctx.text();
    root.reject_unused();
    return s;
}

Comparison compare(const gonio::BrdfRecord& measured, double albedo, double significance) {
    Comparison c;
    const double expected = albedo / std::numbers::pi;
    for (std::size_t i = 0; i < measured.value.size(); ++i) {
        const double sigma = measured.standard_error[i];
        const double z = sigma > 0.0 ? (measured.value[i] - expected) / sigma : std::nan("");
        c.z.push_back(z);
        if (!std::isfinite(z)) continue;
        c.chi_square += z * z;
        c.max_abs_z = std::max(c.max_abs_z, std::abs(z));
        ++c.dof;
    }
    c.p_value = c.dof > 0 ? analysis::chi_square_p_value(c.chi_square, c.dof) : 1.0;
    c.agrees = c.p_value >= significance;
    return c;
}

void write_records(const fs::path& dir, const gonio::BrdfRecord& measured, const Comparison& c,
                   const Settings& s) {
    gonio::write_brdf_record(measured, dir / "brdf.h5");
    record::Hdf5Writer h5(dir / "calibration.h5");
    const std::uint64_t pairs = measured.config.pairs.size();
    const std::uint64_t wavelengths = measured.config.wavelengths_nm.size();
    h5.write(
        "z", std::span<const double>(c.z), {pairs, wavelengths},
        {{"units", "1"},
         {"description",
          "(measured - albedo/pi) / standard error per cell, [pair, wavelength]; NaN: no error "
          "estimate"}});
    h5.set_attribute("/", "albedo", s.albedo);
    h5.set_attribute("/", "chi_square", c.chi_square);
    h5.set_attribute("/", "chi_square_dof", static_cast<double>(c.dof));
    h5.set_attribute("/", "p_value", c.p_value);
    h5.set_attribute("/", "plumage_version", kVersion);
    h5.commit();
}

void write_report(const fs::path& path, const gonio::BrdfRecord& measured, const Comparison& c,
                  const Settings& s, const std::string& text, const std::string& run_time) {
    std::ofstream md(path);
    md << fmt::format(
        "# Calibration: the goniometer on a white standard\n\n"
        "A Lambertian standard of albedo {0} (f = ρ/π = {1:.6f} sr⁻¹) measured by the photon "
        "estimator on the {2} set ({3} pairs × {4} wavelengths), {5} quanta per light direction "
        "and "
        "wavelength, detector half-angle {6:.2f}°, {7:.1f} s. Each cell's mean is ρ/π exactly, so "
        "z = (f̂ − ρ/π)/σ̂ tests the estimator and its standard errors together.\n\n"
        "| χ² | degrees of freedom | χ²/dof | p-value | largest abs(z) | verdict at {8} |\n"
        "|---|---|---|---|---|---|\n"
        "| {9:.1f} | {10} | {11:.3f} | {12:.3g} | {13:.2f} | {14} |\n\n"
        "Records: `brdf.h5` (virtual_gonio/RECORD.md), `calibration.h5` (z per cell).\n\n"
        "{15}## Study file\n\n```toml\n{16}\n```\n",
        s.albedo, s.albedo / std::numbers::pi, measured.config.direction_set,
        measured.config.pairs.size(), measured.config.wavelengths_nm.size(), measured.quanta,
        measured.config.detector_half_angle_rad * 180.0 / std::numbers::pi, measured.wall_time_s,
        s.significance, c.chi_square, c.dof, c.dof > 0 ? c.chi_square / c.dof : 0.0, c.p_value,
        c.max_abs_z, c.agrees ? "agrees" : "DISAGREES", run_time, text);
    if (!md) throw IoError(fmt::format("cannot write {}", path.string()));
}

std::string run(const std::string& text, const fs::path& source, const fs::path& results_root,
                const RunLimits& limits) {
    StudyContext ctx(text, source, results_root, limits, true);
    const StudyProgress& clock = ctx.clock();
    Settings s = read(ctx);  // read
    ctx.begin(s.name);
    s.goniometer.time_budget_s = ctx.time_budget_s(s.goniometer.time_budget_s);
    s.goniometer.target_relative_error =
        ctx.target_relative_error(s.goniometer.target_relative_error);
    const analysis::LambertianScatterer standard(s.albedo);  // build
    clock.say(fmt::format("measuring the standard on {} pairs", s.goniometer.pairs.size()));
    const gonio::BrdfRecord measured = gonio::measure_brdf(standard, s.goniometer);  // measure
    const Comparison c = compare(measured, s.albedo, s.significance);                // compare
    const fs::path out = ctx.out();                                                  // report
    write_records(out, measured, c, s);
    write_report(out / "report.md", measured, c, s, text, ctx.run_time_by_stage());
    const fs::path final_path = ctx.commit();
    return fmt::format("plumage: wrote {}: chi2/dof {:.3f} over {} cells, p = {:.3g}: {}\n",
                       final_path.string(), c.dof > 0 ? c.chi_square / c.dof : 0.0, c.dof,
                       c.p_value, c.agrees ? "agrees" : "DISAGREES");
}

void check(const std::string& text, const fs::path& source) {
    StudyContext ctx(text, source);
    read(ctx);
}

}  // namespace

StudyEntry calibration_study_entry() {
    return {"calibration", "the goniometer on a virtual white standard against f = albedo/pi",
            check, run};
}

}  // namespace plumage::studies
