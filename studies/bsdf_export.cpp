#include "studies/bsdf_export.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <functional>
#include <memory>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "analysis/filip2024.h"
#include "analysis/huang2022.h"
#include "analysis/huang2022_fit.h"
#include "common/constants.h"
#include "common/error.h"
#include "common/interrupt.h"
#include "common/memory_limit.h"
#include "common/require.h"
#include "common/version.h"
#include "sim/optics/spectrum.h"
#include "virtual_gonio/hdf5_file.h"
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
};

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
                     fmt::join(analysis::kHuang2022ParameterNames, ", "), fmt::join(v, ", "))});
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
                       mount_deg * kDeg});
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
    const double count = std::floor(span / o.step_nm + 1e-9) + 1.0;
    const auto max_count = optics::WavelengthGrid::kMaxWavelengths;
    if (!(std::isfinite(o.first_nm) && std::isfinite(o.last_nm) && o.step_nm > 0.0 &&
          std::isfinite(count) && span >= 0.0 && count <= static_cast<double>(max_count))) {
        throw InputError(fmt::format(
            "export-bsdf --first-nm {} --last-nm {} --step-nm {}: expected finite wavelengths, "
            "first <= last, step > 0 and at most {} wavelengths (step >= {:.4g} nm here)",
            o.first_nm, o.last_nm, o.step_nm, max_count,
            std::isfinite(span) ? span / static_cast<double>(max_count - 1) : 0.0));
    }
    std::vector<double> grid;
    for (std::size_t k = 0; k < static_cast<std::size_t>(count); ++k)
        grid.push_back(o.first_nm + static_cast<double>(k) * o.step_nm);
    return grid;
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
                       "Huang 2022 barbule BSDF, published rock-dove parameters"});
        return out;
    }
    if (o.source.starts_with("filip2024:")) {
        const std::string preset = o.source.substr(10);
        out.push_back(
            {std::make_unique<analysis::Filip2024Brdf>(analysis::filip2024_preset(preset)),
             output_or(o, "filip2024_" + preset + ".bsdf"),
             "Filip 2024 feather BRDF, Table 1 preset '" + preset + "'"});
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

}  // namespace

BsdfExportResult export_bsdf(const BsdfExportOptions& o) {
    const auto start = std::chrono::steady_clock::now();
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
    require_memory(
        tables_bytes(settings),
        fmt::format("export-bsdf --theta-nodes {} --phi-nodes {} --resolution {} with "
                    "{} wavelengths",
                    o.theta_nodes, o.phi_nodes, o.resolution, settings.wavelengths_nm.size()));
    std::vector<Export> exports = exports_of(o);  // every input checked before any work
    for (const Export& e : exports) check_replaceable(e.path, o.force);

    BsdfExportResult result;
    for (Export& e : exports) {
        throw_if_interrupted("tabulating " + e.path.string());
        settings.description = e.description + "; " + kWrittenBy + " " + kVersion;
        const Eigen::Matrix3d to_fit_frame =
            Eigen::AngleAxisd(e.mount_rad, Vec3d::UnitZ()).toRotationMatrix();
        const Scatterer& model = *e.model;
        const gonio::BrdfFunction f = [&](const Vec3d& wi, const Vec3d& wo, double lambda) {
            return model.eval(to_fit_frame * wi, to_fit_frame * wo, lambda);
        };
        gonio::write_rgl_bsdf(e.path, gonio::tabulate_rgl_bsdf(f, settings));
        result.files.push_back(e.path);
    }
    result.wall_seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return result;
}

}  // namespace plumage::studies
