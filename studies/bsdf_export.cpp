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
#include "common/require.h"
#include "virtual_gonio/hdf5_file.h"
#include "virtual_gonio/rgl_bsdf.h"

namespace plumage::studies {
namespace {

namespace fs = std::filesystem;

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

std::vector<Export> huang_fit_exports(const BsdfExportOptions& o, const fs::path& file) {
    const record::Dataset d = record::read_dataset(
        file, "fit/values", {-1, static_cast<std::uint64_t>(analysis::kHuang2022ParameterCount)});
    require(d.values.size() == analysis::kHuang2022ParameterCount, "export-bsdf",
            fmt::format("{}: fit/values has {} values, expected Huang 2022's {} ({})",
                        file.string(), d.values.size(), analysis::kHuang2022ParameterCount,
                        fmt::join(analysis::kHuang2022ParameterNames, ", ")));
    std::array<double, analysis::kHuang2022ParameterCount> v{};
    std::copy(d.values.begin(), d.values.end(), v.begin());
    std::vector<Export> out;
    out.push_back(
        {std::make_unique<analysis::Huang2022Bsdf>(analysis::huang2022_params(v)),
         output_or(o, fs::path(file).replace_extension(".bsdf")),
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
        out.push_back({std::make_unique<analysis::Filip2024Brdf>(analysis::from_vector(v)),
                       folder / (species + "_filip2024.bsdf"),
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
    require(o.step_nm > 0.0 && o.last_nm >= o.first_nm, "export-bsdf",
            "wavelengths: expected first <= last and step > 0");
    for (double l = o.first_nm; l <= o.last_nm + 1e-9; l += o.step_nm) {
        settings.wavelengths_nm.push_back(l);
    }
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
    std::vector<Export> exports = exports_of(o);  // every input checked before any work

    BsdfExportResult result;
    for (Export& e : exports) {
        throw_if_interrupted("tabulating " + e.path.string());
        settings.description = e.description;
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
