#include "studies/fit_command.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <functional>
#include <iostream>
#include <limits>
#include <set>

#include <fmt/format.h>

#include "analysis/fits/filip2024_fit.h"
#include "analysis/fits/huang2022_fit.h"
#include "analysis/fits/user_data.h"
#include "analysis/models/filip2024.h"
#include "common/constants.h"
#include "common/error.h"
#include "common/interrupt.h"
#include "common/version.h"
#include "studies/plots.h"
#include "studies/sections.h"
#include "studies/staged_directory.h"
#include "studies/text_files.h"
#include "virtual_gonio/record/hdf5_file.h"

namespace plumage::studies {
namespace {

namespace fs = std::filesystem;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr std::size_t kMaxPanels = 9;  // wavelengths drawn in the residual map

// The residual map: panels of (model − data)/σ on one grid, with its axes.
struct ResidualMap {
    std::size_t rows = 0, columns = 0;
    std::vector<double> values;  // [panel][row][column], NaN where nothing was fitted
    std::vector<std::string> panel_titles;
    std::string title, x_label, y_label, colour_label;
    std::array<double, 4> extent{};  // left, right, bottom, top of the image
    bool equal_aspect = false;       // the axes share a unit (degrees of the hemisphere map)
    std::vector<std::pair<std::string, std::vector<double>>> extra;  // axis tables, [n, 2]
};

void write_residual_map(const ResidualMap& m, const fs::path& path) {
    using Dims = std::vector<std::uint64_t>;
    record::Hdf5Writer h5(path);
    h5.write("residual", std::span<const double>(m.values),
             Dims{m.panel_titles.size(), m.rows, m.columns},
             {{"units", "1"},
              {"description", m.colour_label + ", [panel, row, column]; NaN: no "
                                               "observation"}});
    for (const auto& [name, table] : m.extra) {
        h5.write(name, std::span<const double>(table), Dims{table.size() / 2, 2},
                 {{"units", "deg"}, {"description", "theta, phi of each row or column, deg"}});
    }
    std::string titles;
    for (std::size_t i = 0; i < m.panel_titles.size(); ++i)
        titles += (i ? "|" : "") + m.panel_titles[i];
    h5.set_attribute("/", "panel_titles", titles);
    h5.set_attribute("/", "title", m.title);
    h5.set_attribute("/", "x_label", m.x_label);
    h5.set_attribute("/", "y_label", m.y_label);
    h5.set_attribute("/", "colour_label", m.colour_label);
    h5.set_attribute(
        "/", "extent",
        fmt::format("{} {} {} {}", m.extent[0], m.extent[1], m.extent[2], m.extent[3]));
    h5.set_attribute("/", "aspect", m.equal_aspect ? "equal" : "auto");
    h5.set_attribute("/", "plumage_version", kVersion);
    h5.commit();
}

// At most kMaxPanels of n panels, evenly spread, first and last included.
std::vector<std::size_t> panels_shown(std::size_t n) {
    std::vector<std::size_t> shown;
    const std::size_t k = std::min(n, kMaxPanels);
    for (std::size_t i = 0; i < k; ++i)
        shown.push_back(k == 1 ? 0 : (i * (n - 1) + (k - 1) / 2) / (k - 1));
    return shown;
}

// ---- filip2024 on BRDF data ------------------------------------------------------------------

// A direction's (θ, φ) in degrees, rounded to 1e-6°, φ in [0, 360) and 0 at the pole.
std::pair<double, double> angles_of(const Vec3d& w) {
    const double theta = std::acos(std::clamp(w.z(), -1.0, 1.0)) / kDeg;
    double phi = theta < 1e-9 ? 0.0 : std::atan2(w.y(), w.x()) / kDeg;
    if (phi < 0.0) phi += 360.0;
    const auto round = [](double v) { return std::round(v * 1e6) / 1e6; };
    return {round(theta), round(phi) >= 360.0 ? 0.0 : round(phi)};
}

double panel_key(const analysis::BrdfObservation& o) {
    return o.lambda_nm ? *o.lambda_nm : -1.0 - static_cast<double>(*o.channel);
}

std::string panel_title(double key) {
    if (key > 0.0) return fmt::format("{:g} nm", key);
    return std::string(1, "RGB"[static_cast<int>(-1.0 - key)]) + " channel";
}

// The map's rows (light directions) and columns (view directions) at most this many each: with
// more distinct directions, consecutive ones in the sorted order share a row or column, and a
// cell shows its largest residual. Bounded memory (kMaxMapAxis² × 9 panels × 8 bytes = 75 MB)
// whatever the data; one row per direction would need N² cells (20 000 CSV rows: 29 GB).
constexpr std::size_t kMaxMapAxis = 1024;

// Index of `key` in the sorted `all`, then its bin of `bins` over all.size() entries.
std::size_t bin_of(const std::vector<std::pair<double, double>>& all,
                   const std::pair<double, double>& key, std::size_t bins) {
    const auto index =
        static_cast<std::size_t>(std::lower_bound(all.begin(), all.end(), key) - all.begin());
    return all.size() <= bins ? index : index * bins / all.size();
}

// Each bin's first direction's (θ, φ), [bins, 2] flattened.
std::vector<double> bin_angles(const std::vector<std::pair<double, double>>& all,
                               std::size_t bins) {
    std::vector<double> angles;
    for (std::size_t b = 0; b < bins; ++b) {
        const auto& [t, p] = all[all.size() <= bins ? b : (b * all.size() + bins - 1) / bins];
        angles.insert(angles.end(), {t, p});
    }
    return angles;
}

ResidualMap filip_residual_map(const analysis::BrdfData& data, const std::vector<double>& model) {
    std::set<std::pair<double, double>> lights, views;
    std::set<double> keys;
    for (const auto& o : data.observations) {
        lights.insert(angles_of(o.wi));
        views.insert(angles_of(o.wo));
        keys.insert(panel_key(o));
    }
    const std::vector<std::pair<double, double>> l(lights.begin(), lights.end()),
        v(views.begin(), views.end());
    const std::vector<double> all_keys(keys.begin(), keys.end());
    ResidualMap m;
    m.rows = std::min(l.size(), kMaxMapAxis);
    m.columns = std::min(v.size(), kMaxMapAxis);
    const bool binned = m.rows < l.size() || m.columns < v.size();
    std::vector<double> shown_keys;
    for (std::size_t i : panels_shown(all_keys.size())) shown_keys.push_back(all_keys[i]);
    m.values.assign(shown_keys.size() * m.rows * m.columns, kNaN);
    for (double k : shown_keys) m.panel_titles.push_back(panel_title(k));
    for (std::size_t i = 0; i < data.observations.size(); ++i) {
        const auto& o = data.observations[i];
        const auto p = std::find(shown_keys.begin(), shown_keys.end(), panel_key(o));
        if (p == shown_keys.end()) continue;
        const std::size_t row = bin_of(l, angles_of(o.wi), m.rows);
        const std::size_t col = bin_of(v, angles_of(o.wo), m.columns);
        const double residual = (model[i] - o.value) / o.standard_error.value_or(1.0);
        double& cell =
            m.values[(static_cast<std::size_t>(p - shown_keys.begin()) * m.rows + row) * m.columns +
                     col];
        if (!(std::abs(cell) >= std::abs(residual))) cell = residual;
    }
    m.title = fmt::format(
        "Filip 2024 fit: residuals over {} light x {} view directions{}{}", l.size(), v.size(),
        binned ? fmt::format(" (in {} x {} cells of consecutive directions, each showing its "
                             "largest residual)",
                             m.rows, m.columns)
               : "",
        shown_keys.size() < all_keys.size()
            ? fmt::format(" ({} of {} wavelengths)", shown_keys.size(), all_keys.size())
            : "");
    m.x_label = "view direction (index; sorted by theta_o, then phi_o)";
    m.y_label = "light direction (index; sorted by theta_i, then phi_i)";
    m.colour_label = data.has_standard_errors ? "(model - data) / sigma"
                                              : "model - data (1/sr; the data give no sigma)";
    m.extent = {-0.5, static_cast<double>(m.columns) - 0.5, static_cast<double>(m.rows) - 0.5,
                -0.5};
    // Each row's and column's direction (binned: the first of its cell).
    m.extra = {{"light_angles_deg", bin_angles(l, m.rows)},
               {"view_angles_deg", bin_angles(v, m.columns)}};
    return m;
}

analysis::Filip2024Parameters filip_start(const FitCommand& c, analysis::Filip2024FitOptions& o) {
    auto values =
        analysis::to_vector(analysis::filip2024_preset(c.preset.empty() ? "parrot" : c.preset));
    const auto index = [](const std::string& name) {
        for (int i = 0; i < analysis::kFilip2024ParameterCount; ++i)
            if (analysis::kFilip2024ParameterTable[i].name == name) return i;
        std::string names;
        for (const auto& p : analysis::kFilip2024ParameterTable)
            names += (names.empty() ? "" : ", ") + std::string(p.name);
        throw InputError(
            fmt::format("filip2024: unknown parameter '{}'; the parameters: {}", name, names));
    };
    for (const auto& [name, value] : c.start) values[index(name)] = value;
    for (const auto& name : c.fixed) o.fixed[index(name)] = true;
    for (const auto& name : c.free) o.fixed[index(name)] = false;
    return analysis::from_vector(values);
}

struct Fitted {
    analysis::FitSummary summary;
    ResidualMap map;
    std::string extra_files;
    std::string residuals_csv;  // filip2024: every observation (empty: none)
};

Fitted fit_filip(const FitCommand& c) {
    const analysis::BrdfData data = analysis::read_brdf_data(c.data);
    analysis::Filip2024FitOptions options;
    options.progress = [last = 0.0, n = data.observations.size(),
                        most = options.max_function_evaluations](int evaluations, double chi2,
                                                                 double elapsed_s) mutable {
        // As the Huang fit's (huang_progress_printer): the cost after the first evaluation, then
        // a line every 5 s, so that a long fit of a large table is never silent.
        if (evaluations == 1) {
            std::cerr << fmt::format(
                "  filip2024 fit: {} observations; one evaluation {:.3g} s, the fit at most {} "
                "({:.3g} s); Ctrl-C stops it\n",
                n, elapsed_s, most, elapsed_s * most);
            last = elapsed_s;
        } else if (elapsed_s - last >= 5.0) {
            std::cerr << fmt::format(
                "  filip2024 fit: {} of at most {} evaluations in {:.1f} s, chi2 of the last "
                "{:.6g}\n",
                evaluations, most, elapsed_s, chi2);
            last = elapsed_s;
        }
    };
    const analysis::Filip2024Parameters start = filip_start(c, options);
    throw_if_interrupted("fitting");
    const analysis::Filip2024FitResult fit =
        analysis::fit_filip2024(data.observations, start, options);
    std::vector<double> model;
    std::set<double> wavelengths;
    std::string csv =
        "theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg,wavelength_nm,channel,value_per_sr,"
        "sigma_per_sr,model_per_sr,residual\n";
    std::array<double, analysis::kFilip2024ParameterCount> gradient{};
    for (const auto& o : data.observations) {
        const analysis::RgbChannel channel =
            o.channel ? *o.channel : analysis::filip2024_channel(*o.lambda_nm);
        model.push_back(analysis::filip2024_value_and_gradient(
            fit.parameters, analysis::filip2024_geometry(o.wi, o.wo), channel, gradient));
        if (o.lambda_nm) wavelengths.insert(*o.lambda_nm);
        const auto [ti, pi] = angles_of(o.wi);
        const auto [to, po] = angles_of(o.wo);
        const double sigma = o.standard_error.value_or(kNaN);
        csv += fmt::format("{},{},{},{},{},{},{:.10g},{:.10g},{:.10g},{:.6g}\n", ti, pi, to, po,
                           o.lambda_nm ? fmt::format("{:g}", *o.lambda_nm) : "",
                           std::string(1, "RGB"[static_cast<int>(channel)]), o.value, sigma,
                           model.back(), (model.back() - o.value) / o.standard_error.value_or(1.0));
    }
    analysis::FitProvenance provenance{c.data.string(),
                                       data.format,
                                       data.has_standard_errors,
                                       data.left_out,
                                       {wavelengths.begin(), wavelengths.end()}};
    return {analysis::summarise_fit(fit, options, std::move(provenance)),
            filip_residual_map(data, model), "residuals.csv (every observation, model, residual), ",
            std::move(csv)};
}

// ---- huang2022 on a scatterogram ---------------------------------------------------------------

// Progress on stderr: the cost of one model evaluation and the most the fit can take, after the
// first evaluation, then a line at most every kProgressEvery (a cone or hemisphere scatterogram
// evaluates the model once per illumination direction, so a fit can take minutes).
std::function<void(const analysis::HuangFitProgress&)> huang_progress_printer() {
    constexpr double kProgressEvery = 5.0;  // s
    return [last = 0.0](const analysis::HuangFitProgress& p) mutable {
        if (p.within_evaluation) {  // inside an evaluation: a slow one says where it is
            if (p.elapsed_s - last >= kProgressEvery) {
                std::cerr << fmt::format(
                    "  huang2022 fit: evaluation {}: {} of {} illumination directions after "
                    "{:.1f} s ({} observations); Ctrl-C stops it\n",
                    p.evaluations + 1, p.directions_done, p.illumination_directions, p.elapsed_s,
                    p.observations);
                last = p.elapsed_s;
            }
        } else if (p.evaluations == 1) {
            std::cerr << fmt::format(
                "  huang2022 fit: {} observations ({} pixels, {} illumination direction{}), {} "
                "free parameters; one model evaluation {:.3g} s, an iteration about {} "
                "evaluations, the fit at most {} ({:.3g} s); Ctrl-C stops it\n",
                p.observations, p.pixels, p.illumination_directions,
                p.illumination_directions == 1 ? "" : "s", p.free_parameters, p.elapsed_s,
                2 * p.free_parameters + 1, p.max_evaluations, p.elapsed_s * p.max_evaluations);
            last = p.elapsed_s;
        } else if (p.elapsed_s - last >= kProgressEvery) {
            std::cerr << fmt::format(
                "  huang2022 fit: {} of at most {} evaluations in {:.1f} s, chi2 of the last "
                "{:.6g}\n",
                p.evaluations, p.max_evaluations, p.elapsed_s, p.chi_square);
            last = p.elapsed_s;
        }
    };
}

Fitted fit_huang(const FitCommand& c) {
    const gonio::Scatterogram data = analysis::read_scatterogram_record(c.data);
    analysis::HuangFitOptions options;
    options.fixed = {"phi0", "phi1"};  // hidden under the neighbours at rock-dove spacings
    for (const auto& name : c.fixed)
        if (std::find(options.fixed.begin(), options.fixed.end(), name) == options.fixed.end())
            options.fixed.push_back(name);
    for (const auto& name : c.free) std::erase(options.fixed, name);
    options.pixel_stride = c.pixel_stride;
    options.progress = huang_progress_printer();
    // Negative pixels: background-subtracted data, whose σ are the user's own, not photon
    // counts; every pixel with a σ is then fitted, the dark and negative ones included.
    options.every_pixel_with_sigma =
        std::any_of(data.intensity.begin(), data.intensity.end(), [](double v) { return v < 0.0; });
    auto values = analysis::huang2022_values({});
    for (const auto& [name, value] : c.start) {
        const auto& names = analysis::kHuang2022ParameterNames;
        const auto it = std::find(names.begin(), names.end(), name);
        if (it == names.end()) {
            throw InputError(
                fmt::format("huang2022: unknown parameter '{}'; the parameters: b, "
                            "phi0, phi1, H, d_um, theta_d, mu",
                            name));
        }
        values[static_cast<std::size_t>(it - names.begin())] = value;
    }
    if (!c.preset.empty()) throw InputError("--preset: only filip2024 has presets");
    throw_if_interrupted("fitting");
    const analysis::HuangFitResult fit =
        analysis::fit_huang2022(data, analysis::huang2022_params(values), options);
    const gonio::Scatterogram model =
        analysis::huang2022_scatterogram(fit.parameters, data.config, options);
    ResidualMap m;
    m.rows = m.columns = static_cast<std::size_t>(data.config.image_size);
    const std::size_t nl = data.config.wavelengths_nm.size();
    for (std::size_t shown : panels_shown(fit.wavelengths_nm.size())) {
        const double lambda = fit.wavelengths_nm[shown];
        const std::size_t l =
            static_cast<std::size_t>(std::find(data.config.wavelengths_nm.begin(),
                                               data.config.wavelengths_nm.end(), lambda) -
                                     data.config.wavelengths_nm.begin());
        m.panel_titles.push_back(fmt::format("{:g} nm", lambda));
        for (std::size_t p = 0; p < data.pixels(); ++p) {
            const double d = data.intensity[p * nl + l], se = data.standard_error[p * nl + l];
            // The fit's observations (analysis/fits/huang2022_fit.h): signal, and σ with the floor.
            const bool signal = d > 0.0 && se <= options.max_relative_error * d;
            const bool used = data.solid_angle_sr[p] > 0.0 &&
                              (signal || (options.every_pixel_with_sigma && se > 0.0));
            const double sigma = std::hypot(se, options.relative_error_floor * std::max(d, 0.0));
            m.values.push_back(used ? (model.intensity[p * nl + l] - d) / sigma : kNaN);
        }
    }
    m.title = fmt::format(
        "Huang 2022 fit: residuals over the scatterogram (azimuthal equidistant map); "
        "sigma^2 = standard error^2 + ({:g} % of the data)^2",
        100.0 * options.relative_error_floor);
    m.x_label = "theta cos phi (deg)";
    m.y_label = "theta sin phi (deg)";
    m.colour_label = "(model - data) / sigma";
    m.extent = {-90.0, 90.0, -90.0, 90.0};
    m.equal_aspect = true;
    analysis::FitProvenance provenance{c.data.string(), "scatterogram_record", true, 0, {}};
    return {analysis::summarise_fit(fit, options, std::move(provenance)), m, "", ""};
}

// The fit, its refusals naming the data file (the model's own checks, "0 observations with
// signal", do not know which file the observations came from).
Fitted fitted_naming_the_data(const FitCommand& c) {
    try {
        return c.model == "filip2024" ? fit_filip(c) : fit_huang(c);
    } catch (const InputError& e) {
        throw analysis::naming_data_file(e, c.data.string());
    }
}

void write_report(const fs::path& path, const FitCommand& c, const Fitted& f) {
    const analysis::FitSummary& s = f.summary;
    std::ofstream md(path);
    md << fmt::format("# Fit of {} to {}\n\n{}.\n\n", s.model, c.data.filename().string(),
                      s.reference);
    md << fmt::format(
        "χ² = {:.4g} over {} observations, {} degrees of freedom: χ²/dof = {:.4g}; residual RMS "
        "{:.4g} 1/sr; {} ({}).\n\n",
        s.chi_square, s.observations, s.degrees_of_freedom, s.reduced_chi_square,
        s.residual_rms_per_sr, s.converged ? "converged" : "NOT converged", s.termination);
    if (s.warnings.empty()) {
        md << fmt::format("No warnings ({} Levenberg–Marquardt runs from different starts).\n\n",
                          s.local_fits);
    } else {
        md << "**Warnings** (analysis/fits/fit_summary.h):\n\n";
        for (const std::string& w : s.warnings) md << "- **" << w << "**\n";
        md << "\n";
    }
    md << "| parameter | value | σ | unit | valid range | |\n|---|---|---|---|---|---|\n";
    for (const auto& p : s.parameters) {
        md << fmt::format("| {} | {:.6g} | {} | {} | [{:g}, {:g}] | {} |\n", p.name, p.value,
                          std::isfinite(p.sigma) ? fmt::format("{:.3g}", p.sigma) : "—", p.unit,
                          p.min, p.max,
                          p.fixed      ? "fixed"
                          : p.at_bound ? "at a bound: σ meaningless"
                                       : "");
    }
    md << "\nσ: from the covariance s² (JᵀJ)⁻¹ at the optimum, s² = χ²/dof (docs/user_data.md)."
       << (s.provenance.standard_errors ? ""
                                        : " The data give no σ: every observation weighs the "
                                          "same, and σ comes from the scatter of the residuals.")
       << "\n\n![residuals](residuals.png)\n\nFiles: parameters.json (docs/user_data.md), "
       << f.extra_files << "residuals.h5 (the map's data), residuals.png. plumage " << kVersion
       << ".\n";
    close_written(md, path);
}

}  // namespace

FitCommandResult run_fit_command(const FitCommand& c, const fs::path& results_root) {
    if (c.model != "huang2022" && c.model != "filip2024") {
        throw InputError(fmt::format("--model {}: expected huang2022 or filip2024", c.model));
    }
    if (c.pixel_stride < 1 || c.pixel_stride > 64)
        throw InputError(fmt::format("--pixel-stride {}: expected 1 to 64", c.pixel_stride));
    const std::string name =
        c.name.empty() ? fmt::format("fit_{}_{}", c.model, c.data.stem().string()) : c.name;
    if (const std::string problem = study_name_problem(name); !problem.empty()) {
        if (!c.name.empty()) throw InputError(fmt::format("--name {}: {}", name, problem));
        throw InputError(fmt::format(
            "{}: the results folder's name is made from the data file's, '{}', which {}; give "
            "one with --name",
            c.data.string(), name, problem));
    }
    analysis::data_kind(c.data);  // the file exists and is a table or a record
    StagedDirectory::prepare(results_root / name);
    // Everything that can refuse the input (data, parameters, the fit itself) runs before the
    // results folder is created.
    const Fitted f = fitted_naming_the_data(c);
    StagedDirectory out(results_root / name);
    if (!f.residuals_csv.empty()) write_text_file(out.path() / "residuals.csv", f.residuals_csv);
    write_text_file(out.path() / "parameters.json", f.summary.to_json());
    write_residual_map(f.map, out.path() / "residuals.h5");
    run_plot("fit_residuals", out.path() / "residuals.h5", out.path() / "residuals.png");
    write_report(out.path() / "report.md", c, f);
    out.commit();
    return {out.final_path(), f.summary};
}

}  // namespace plumage::studies
