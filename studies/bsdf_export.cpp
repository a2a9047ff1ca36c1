#include "studies/bsdf_export.h"

#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>
#include <fstream>
#include <functional>
#include <memory>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "analysis/fits/huang2022_fit.h"
#include "analysis/metrics/energy.h"
#include "analysis/models/filip2024.h"
#include "analysis/models/huang2022.h"
#include "common/constants.h"
#include "common/error.h"
#include "common/interrupt.h"
#include "common/memory_limit.h"
#include "common/require.h"
#include "common/version.h"
#include "sim/optics/spectrum.h"
#include "studies/study_progress.h"
#include "virtual_gonio/record/hdf5_file.h"
#include "virtual_gonio/rgl_bsdf.h"

namespace plumage::studies {
namespace {

namespace fs = std::filesystem;

// In every file's description: what marks a file as this suite's (written_by_plumage).
constexpr const char* kWrittenBy = "written by plumage";

// One model to write: the scatterer, where it goes and what the file says it is. mount_rad:
// the azimuth of the barb axis in the frame the model was fitted in (the species study's
// instrument frame); the file is written in the patch frame (barb axis +x).
struct Export {
    std::unique_ptr<Scatterer> model;
    fs::path path;
    std::string description;
    double mount_rad = 0.0;
    std::string name;  // for messages: the source, or source:species
};

// Huang's own NDF (Eq. 7: the arc of barbule normals, ±θ_d along the barbule) in the patch
// frame, for the tabulation's warp (RglBsdfSettings::model_ndf): the R lobe is D G / (4 cos
// cos), so with this D the sample square's nodes crowd into the narrow band of the arc
// instead of spreading as the retro-reflection estimate, which a 64² grid cannot narrow to
// ±4.5°, spreads them.
std::function<double(const Vec3d&)> huang_ndf(const analysis::Huang2022Bsdf& model) {
    const double cos_mu = std::cos(model.params().mu), sin_mu = std::sin(model.params().mu);
    return [&model, cos_mu, sin_mu](const Vec3d& m) {
        // patch = R_y(μ) · barbule (analysis/models/huang2022.h); barbule ω = (sin φ cos θ, sin θ,
        // cos φ cos θ).
        const Vec3d b(m.x() * cos_mu - m.z() * sin_mu, m.y(), m.x() * sin_mu + m.z() * cos_mu);
        return model.ndf(std::atan2(b.x(), b.z()), std::asin(std::clamp(b.y(), -1.0, 1.0)));
    };
}

std::function<double(const Vec3d&)> model_ndf_of(const Scatterer& model) {
    if (const auto* huang = dynamic_cast<const analysis::Huang2022Bsdf*>(&model))
        return huang_ndf(*huang);
    return {};  // the retro-reflection estimate
}

fs::path output_or(const BsdfExportOptions& o, const fs::path& fallback) {
    if (o.output.empty()) return fallback;
    return fs::is_directory(o.output) ? o.output / fallback.filename() : o.output;
}

// The model's own refusal of fitted values ("huang2022: b = nan") knows neither the file nor
// the dataset they came from.
InputError in_dataset(const fs::path& file, const std::string& dataset, const InputError& e) {
    return InputError(fmt::format("HDF5 file '{}': /{}: {}", file.string(), dataset, e.what()));
}

std::vector<Export> huang_fit_exports(const BsdfExportOptions& o, const fs::path& file) {
    const record::Dataset d = record::read_dataset(
        file, "fit/values", {-1, static_cast<std::uint64_t>(analysis::kHuang2022ParameterCount)});
    require(d.values.size() == analysis::kHuang2022ParameterCount, "export-bsdf",
            fmt::format("{}: fit/values has {} values, expected Huang 2022's {} ({})",
                        file.string(), d.values.size(), analysis::kHuang2022ParameterCount,
                        fmt::join(analysis::kHuang2022ParameterNames, ", ")));
    std::array<double, analysis::kHuang2022ParameterCount> v{};
    std::copy(d.values.begin(), d.values.end(), v.begin());
    std::unique_ptr<analysis::Huang2022Bsdf> model;
    try {
        model = std::make_unique<analysis::Huang2022Bsdf>(analysis::huang2022_params(v));
    } catch (const InputError& e) {
        throw in_dataset(file, "fit/values", e);
    }
    std::vector<Export> out;
    out.push_back(
        {std::move(model), output_or(o, fs::path(file).replace_extension(".bsdf")),
         fmt::format("Huang 2022 barbule BSDF, parameters fitted in {} ({} = {})", file.string(),
                     fmt::join(analysis::kHuang2022ParameterNames, ", "), fmt::join(v, ", ")),
         0.0, file.string()});
    return out;
}

std::vector<Export> species_exports(const BsdfExportOptions& o, const fs::path& file) {
    std::vector<Export> out;
    const std::string suffix = "/fit/values";
    for (const std::string& path : record::dataset_paths(file)) {
        if (path.size() <= suffix.size() || !path.ends_with(suffix)) continue;
        const std::string species = path.substr(0, path.size() - suffix.size());
        // The species' name becomes a file name: one plain name, never a path out of the folder
        // (a group named ".." would otherwise write beside the source's folder).
        if (species.empty() || species == "." || species == ".." ||
            species.find_first_not_of("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz"
                                      "0123456789_-.") != std::string::npos) {
            throw InputError(fmt::format(
                "HDF5 file '{}': /{}: expected a species name of letters, digits, '_', '-' and "
                "'.' (it names the output file), not '.' or '..'",
                file.string(), path));
        }
        const record::Dataset d = record::read_dataset(
            file, path, {-1, static_cast<std::uint64_t>(analysis::kFilip2024ParameterCount)});
        require(d.values.size() == analysis::kFilip2024ParameterCount, "export-bsdf",
                fmt::format("{}: {} has {} values, expected Filip 2024's {}", file.string(), path,
                            d.values.size(), analysis::kFilip2024ParameterCount));
        std::array<double, analysis::kFilip2024ParameterCount> v{};
        std::copy(d.values.begin(), d.values.end(), v.begin());
        const fs::path folder = o.output.empty() ? file.parent_path() : o.output;
        const double mount_deg = record::read_number_attribute(file, "/" + species, "mount_deg");
        if (!std::isfinite(mount_deg) || std::abs(mount_deg) > 360.0) {
            throw InputError(
                fmt::format("HDF5 file '{}': /{}@mount_deg = {}: expected a finite "
                            "azimuth in [-360, 360] deg",
                            file.string(), species, mount_deg));
        }
        std::unique_ptr<analysis::Filip2024Brdf> model;
        try {
            model = std::make_unique<analysis::Filip2024Brdf>(analysis::from_vector(v));
        } catch (const InputError& e) {
            throw in_dataset(file, path, e);
        }
        out.push_back({std::move(model), folder / (species + "_filip2024.bsdf"),
                       fmt::format("Filip 2024 feather BRDF of the {}, parameters fitted in {} "
                                   "(instrument frame, barb axis at {} deg), turned into the "
                                   "patch frame (barb axis +x)",
                                   species, file.string(), mount_deg),
                       mount_deg * kDeg, file.string() + ":" + species});
    }
    require(!out.empty(), "export-bsdf",
            fmt::format("{}: no /<species>/fit/values dataset (is it a species study's "
                        "species.h5?)",
                        file.string()));
    require(o.output.empty() || fs::is_directory(o.output), "export-bsdf",
            fmt::format("--output {}: a species.h5 gives one file per species, so --output "
                        "must be an existing folder",
                        o.output.string()));
    return out;
}

// --first-nm, --last-nm, --step-nm as the grid, its size checked before it is built.
std::vector<double> wavelength_grid(const BsdfExportOptions& o) {
    const double span = o.last_nm - o.first_nm;
    const double count = optics::WavelengthGrid::uniform_count(o.first_nm, o.last_nm, o.step_nm);
    const auto max_count = optics::WavelengthGrid::kMaxWavelengths;
    if (!(std::isfinite(o.first_nm) && std::isfinite(o.last_nm) && o.step_nm > 0.0 &&
          std::isfinite(count) && span >= 0.0 && count <= static_cast<double>(max_count))) {
        throw InputError(fmt::format(
            "export-bsdf --first-nm {} --last-nm {} --step-nm {}: expected finite wavelengths, "
            "first <= last, step > 0 and at most {} wavelengths (step >= {:.4g} nm here)",
            o.first_nm, o.last_nm, o.step_nm, max_count,
            std::isfinite(span) ? span / static_cast<double>(max_count - 1) : 0.0));
    }
    const optics::WavelengthGrid grid =
        optics::WavelengthGrid::uniform(o.first_nm, o.last_nm, o.step_nm);
    return {grid.nm().begin(), grid.nm().end()};
}

// The tensor file's tables as float32 (spectra, luminance, vndf, ndf and sigma), twice: the
// tables and the fields they are written from.
double tables_bytes(const gonio::RglBsdfSettings& s) {
    const double directions = static_cast<double>(s.theta_i_count) * s.phi_i_count;
    const double samples = static_cast<double>(s.sample_resolution) * s.sample_resolution;
    const double spectra =
        directions * (static_cast<double>(s.wavelengths_nm.size()) + 1.0) * samples;
    const double vndf = directions * s.vndf_resolution * s.vndf_resolution;
    const double ndf = 2.0 * s.ndf_resolution * s.ndf_resolution;
    return 2.0 * 4.0 * (spectra + vndf + ndf);
}

// Whether `path` is a tensor file this suite wrote (its description says so): only such a file
// is replaced without --force.
bool written_by_plumage(const fs::path& path) {
    try {
        const gonio::TensorFields fields = gonio::read_tensor_file(path);
        const auto it = fields.find("description");
        if (it == fields.end()) return false;
        const std::string text(it->second.bytes.begin(), it->second.bytes.end());
        return text.find(kWrittenBy) != std::string::npos;
    } catch (const Error&) {
        return false;
    }
}

// An output may replace nothing but a regular file this suite wrote (or any regular file with
// --force): never a device, a folder, a link or a file of the user's. Checked for every output
// before any work.
void check_replaceable(const fs::path& path, bool force) {
    std::error_code error;
    const fs::file_status status = fs::symlink_status(path, error);
    const fs::path parent = path.has_parent_path() ? path.parent_path() : fs::path(".");
    if (status.type() == fs::file_type::not_found) {
        if (!fs::is_directory(parent, error)) {
            throw InputError(fmt::format("export-bsdf: '{}': its folder '{}' does not exist",
                                         path.string(), parent.string()));
        }
        return;
    }
    if (status.type() == fs::file_type::symlink) {
        throw InputError(fmt::format(
            "export-bsdf: '{}' is a symbolic link: plumage writes no file over or through a "
            "link; give the file's own path",
            path.string()));
    }
    if (status.type() != fs::file_type::regular) {
        throw InputError(fmt::format(
            "export-bsdf: '{}' exists and is not a regular file (a device, folder, pipe or "
            "socket): plumage replaces only a .bsdf it wrote",
            path.string()));
    }
    if (!force && !written_by_plumage(path)) {
        throw InputError(fmt::format(
            "export-bsdf: '{}' exists and is not a .bsdf written by plumage: it is kept; choose "
            "another --output, or add --force to replace it",
            path.string()));
    }
}

std::vector<Export> exports_of(const BsdfExportOptions& o) {
    std::vector<Export> out;
    if (o.source == "huang2022") {
        out.push_back({std::make_unique<analysis::Huang2022Bsdf>(analysis::Huang2022Params{}),
                       output_or(o, "huang2022.bsdf"),
                       "Huang 2022 barbule BSDF, published rock-dove parameters", 0.0, o.source});
        return out;
    }
    if (o.source.starts_with("filip2024:")) {
        const std::string preset = o.source.substr(10);
        out.push_back(
            {std::make_unique<analysis::Filip2024Brdf>(analysis::filip2024_preset(preset)),
             output_or(o, "filip2024_" + preset + ".bsdf"),
             "Filip 2024 feather BRDF, Table 1 preset '" + preset + "'", 0.0, o.source});
        return out;
    }
    const fs::path file = o.source;
    require(fs::is_regular_file(file), "export-bsdf",
            fmt::format("source '{}': expected a huang2022_fit.h5 or species.h5 of a study, "
                        "'huang2022' or 'filip2024:<preset>'",
                        o.source));
    for (const std::string& path : record::dataset_paths(file)) {
        if (path == "fit/values") return huang_fit_exports(o, file);
    }
    return species_exports(o, file);
}

// Creates and removes the temporary file the export will write beside `path`: a folder where
// no file can be made (read-only, not ours) is found now, not after minutes of tabulation.
void check_writable(const fs::path& path) {
    fs::path probe = path;
    probe += fmt::format(".partial-{}", ::getpid());
    std::error_code error;
    if (fs::exists(fs::symlink_status(probe, error))) return;  // not ours to touch
    errno = 0;
    std::ofstream out(probe, std::ios::binary | std::ios::trunc);
    const int reason = errno;
    if (!out) {
        const fs::path parent = path.has_parent_path() ? path.parent_path() : fs::path(".");
        throw InputError(fmt::format(
            "export-bsdf: '{}' cannot be written: no file can be created in '{}' ({}); give -o "
            "or --out in a folder you can write",
            path.string(), parent.string(), reason != 0 ? std::strerror(reason) : "refused"));
    }
    out.close();
    fs::remove(probe, error);
}

// The exports of the source; a source file HDF5 cannot read (damaged, truncated) is bad input
// like a missing one, whatever layer noticed.
std::vector<Export> checked_exports(const BsdfExportOptions& o) {
    try {
        return exports_of(o);
    } catch (const InputError&) {
        throw;
    } catch (const Interrupted&) {
        throw;
    } catch (const Error& e) {
        throw InputError(
            fmt::format("export-bsdf: source '{}' cannot be read: {}", o.source, e.what()));
    }
}

// Up to three of the export's wavelengths, spread over its range: first, middle, last (the
// albedo check's cost; Filip's model has three bands).
std::vector<double> albedo_wavelengths(const std::vector<double>& grid) {
    if (grid.size() <= 3) return grid;
    return {grid.front(), grid[grid.size() / 2], grid.back()};
}

// The model's directional albedo at 21 directions θ_i ≤ 75° (every 15°, azimuths every 90°; the
// largest over the checked wavelengths per direction); a warning when it exceeds 1 beyond the
// quadrature's error. Huang's eval makes this ~1.6 s of CPU at 16 polar cells.
void check_albedo(const Export& e, const std::vector<double>& grid, int polar_cells,
                  BsdfFileReport& report) {
    const std::vector<Vec3d> directions =
        analysis::hemisphere_grid(15.0 * kDeg, kCheckMaxThetaDeg * kDeg, 90.0 * kDeg);
    const std::vector<double> lambdas = albedo_wavelengths(grid);
    const analysis::EnergyCheck check =
        analysis::check_energy(*e.model, directions, lambdas, polar_cells);
    report.albedo_directions = check.directions;
    report.directions_above_one = check.directions_above_one;
    report.max_albedo = std::max(report.max_albedo, check.max_albedo);
    const double worst_theta = std::acos(std::clamp(check.worst_wi.z(), -1.0, 1.0)) / kDeg;
    const double worst_lambda = check.worst_lambda_nm;
    if (report.directions_above_one == 0) return;
    report.warnings.push_back(fmt::format(
        "warning: {}: directional albedo up to {:.2f} (θ_i = {:.0f}°, {:.0f} nm), above 1 at {} "
        "of {} directions θ_i ≤ {:.0f}°: the model's parameters do not conserve energy, and a "
        "renderer using this file will create light",
        e.name, report.max_albedo, worst_theta, worst_lambda, report.directions_above_one,
        report.albedo_directions, kCheckMaxThetaDeg));
}

std::string percent(double x) { return fmt::format("{:.3g} %", 100.0 * x); }

// Reads the written file back (as Mitsuba would) and measures it against the model.
void check_between_nodes(const BsdfExportOptions& o, const gonio::BrdfFunction& f,
                         BsdfFileReport& report, const StudyProgress& progress) {
    if (o.check_pairs <= 0) return;
    const gonio::RglBsdf file = gonio::RglBsdf::read(report.file);
    report.error =
        gonio::interpolation_error(f, file, o.check_pairs, kCheckMaxThetaDeg, kCheckSeed);
    const gonio::InterpolationError& x = report.error;
    progress.done(fmt::format(
        "{}: read back against the model at {} random pairs (θ ≤ {:.0f}°, seed {}; {} with f > 0): "
        "median {}, 95th percentile {}, Σ f cos θ-weighted {}, worst {:.3g}×; {:.1f} MB, "
        "tabulated in {:.1f} s",
        report.file.string(), x.pairs, kCheckMaxThetaDeg, kCheckSeed, x.positive, percent(x.median),
        percent(x.p95), percent(x.weighted), x.worst, static_cast<double>(report.bytes) / 1e6,
        report.tabulate_seconds));
    if (x.median > kTargetMedianError) {
        report.warnings.push_back(fmt::format(
            "warning: {}: median between-node error {} is above the target {}: refine the grid, "
            "the view nodes first (--theta-nodes, --phi-nodes; Huang 2022 at 550 nm: 3.2 % at "
            "10 × 25, 1.5 % at 19 × 49), then --resolution",
            report.file.string(), percent(x.median), percent(kTargetMedianError)));
        progress.done(report.warnings.back());
    }
}

BsdfFileReport export_one(const Export& e, gonio::RglBsdfSettings settings,
                          const BsdfExportOptions& o, const StudyProgress& progress) {
    BsdfFileReport report;
    report.file = e.path;
    report.model = e.name;
    progress.say(fmt::format("{}: directional albedo (energy check)", e.name));
    check_albedo(e, settings.wavelengths_nm, o.albedo_polar_cells, report);
    for (const std::string& w : report.warnings) progress.done(w);
    settings.description = e.description + "; " + kWrittenBy + " " + kVersion;
    if (!report.warnings.empty()) settings.description += "; " + report.warnings.front();
    const Eigen::Matrix3d to_fit_frame =
        Eigen::AngleAxisd(e.mount_rad, Vec3d::UnitZ()).toRotationMatrix();
    const Scatterer& model = *e.model;
    const gonio::BrdfFunction f = [&](const Vec3d& wi, const Vec3d& wo, double lambda) {
        return model.eval(to_fit_frame * wi, to_fit_frame * wo, lambda);
    };
    if (const auto ndf = o.model_ndf_share > 0.0 ? model_ndf_of(model) : nullptr) {
        settings.model_ndf = [ndf, to_fit_frame](const Vec3d& m) { return ndf(to_fit_frame * m); };
        settings.model_ndf_share = o.model_ndf_share;
    }
    settings.progress = [&](const std::string& step) {
        progress.done(fmt::format("{}: {}", e.path.filename().string(), step));
    };
    progress.say(fmt::format("tabulating {} into {}", e.name, e.path.string()));
    const auto start = std::chrono::steady_clock::now();
    const gonio::RglBsdfTables tables = gonio::tabulate_rgl_bsdf(f, settings);
    report.tabulate_seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    progress.say("writing " + e.path.string());
    gonio::write_rgl_bsdf(e.path, tables);
    std::error_code error;
    report.bytes = fs::file_size(e.path, error);
    progress.say(fmt::format("{}: between-node error", e.path.filename().string()));
    check_between_nodes(o, f, report, progress);
    return report;
}

// The options with the model's own angular grid where they leave it to the model (0 nodes).
BsdfExportOptions with_model_grid(BsdfExportOptions o, const AngularGrid& grid) {
    if (o.theta_nodes == 0) o.theta_nodes = grid.theta_nodes;
    if (o.phi_nodes == 0) o.phi_nodes = grid.phi_nodes;
    return o;
}

// The tables' settings from the options, checked (grid, memory) before any work.
gonio::RglBsdfSettings settings_of(const BsdfExportOptions& o) {
    gonio::RglBsdfSettings settings;
    settings.wavelengths_nm = wavelength_grid(o);
    settings.theta_i_count = o.theta_nodes;
    settings.phi_i_count = o.phi_nodes;
    settings.sample_resolution = o.resolution;
    // The vndf and NDF grids twice as fine as the sample square, as the defaults (64 for 32).
    settings.vndf_resolution = settings.ndf_resolution = 2 * o.resolution;
    try {
        settings.validate();
    } catch (const InputError& e) {
        throw InputError(fmt::format(
            "export-bsdf: --theta-nodes {}, --phi-nodes {}, --resolution "
            "{}, --first-nm {}, --last-nm {}, --step-nm {}: {}",
            o.theta_nodes, o.phi_nodes, o.resolution, o.first_nm, o.last_nm, o.step_nm, e.what()));
    }
    require(o.model_ndf_share >= 0.0 && o.model_ndf_share <= 1.0, "export-bsdf", "model_ndf_share",
            o.model_ndf_share, "a value in [0, 1]");
    require(o.check_pairs >= 0 && o.check_pairs <= 1000000, "export-bsdf", "check_pairs",
            o.check_pairs, "an integer in [0, 10⁶]");
    require(
        o.albedo_polar_cells >= 2 && o.albedo_polar_cells <= 256 && o.albedo_polar_cells % 2 == 0,
        "export-bsdf", "albedo_polar_cells", o.albedo_polar_cells, "an even integer in [2, 256]");
    require_memory(
        tables_bytes(settings),
        fmt::format("export-bsdf --theta-nodes {} --phi-nodes {} --resolution {} with "
                    "{} wavelengths",
                    o.theta_nodes, o.phi_nodes, o.resolution, settings.wavelengths_nm.size()));
    return settings;
}

}  // namespace

BsdfExportResult export_bsdf(const BsdfExportOptions& o) {
    const StudyProgress progress(o.progress);
    settings_of(with_model_grid(o, kFilipGrid));  // the options' own checks, before the sources
    std::vector<Export> exports = checked_exports(o);  // every input checked before any work
    std::vector<BsdfExportOptions> options;
    std::vector<gonio::RglBsdfSettings> settings;
    for (const Export& e : exports) {
        check_replaceable(e.path, o.force);
        check_writable(e.path);
        const bool huang = dynamic_cast<const analysis::Huang2022Bsdf*>(e.model.get()) != nullptr;
        options.push_back(with_model_grid(o, huang ? kHuangGrid : kFilipGrid));
        settings.push_back(settings_of(options.back()));  // grid and memory, before any work
    }
    BsdfExportResult result;
    for (std::size_t i = 0; i < exports.size(); ++i) {
        result.reports.push_back(export_one(exports[i], settings[i], options[i], progress));
        result.files.push_back(exports[i].path);
    }
    result.wall_seconds = progress.elapsed_s();
    return result;
}

}  // namespace plumage::studies
