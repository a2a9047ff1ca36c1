#include "studies/sections.h"

#include <fmt/format.h>

#include "common/error.h"
#include "geometry/barb.h"
#include "geometry/barbule.h"
#include "sim/optics/spectrum.h"
#include "sim/scatterer/random.h"
#include "studies/staged_directory.h"

namespace plumage::studies {

std::string study_name_problem(std::string_view name) {
    if (name.empty()) return "is empty";
    if (name == "." || name == "..") return "is a relative folder reference";
    if (name.size() > kMaxStudyNameLength) {
        return fmt::format("has {} characters (at most {})", name.size(), kMaxStudyNameLength);
    }
    for (const char c : name) {
        const bool plain = (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') ||
                           (c >= '0' && c <= '9') || c == '.' || c == '_' || c == '-';
        if (!plain) {
            return fmt::format("contains '{}' (only letters, digits, '.', '_' and '-')",
                               c == '/' ? std::string("/") : std::string(1, c));
        }
    }
    return staging_name_problem(name);  // names the results root's own entries could take
}

std::string read_study_name(ParameterTable& root, const std::filesystem::path& source) {
    const bool given = root.has("name");
    const std::string name = root.string("name", source.stem().string(), {}, "results folder name");
    const std::string problem = study_name_problem(name);
    if (problem.empty()) return name;
    if (given) {
        throw InputError(fmt::format(
            "{}: name = \"{}\" {}: expected one plain folder name inside the results root "
            "({} characters at most from [A-Za-z0-9._-], not \".\" or \"..\")",
            root.location("name"), name, problem, kMaxStudyNameLength));
    }
    throw InputError(fmt::format(
        "{}: the results folder name defaults to the file's stem \"{}\", which {}: set name = "
        "\"...\" (one plain folder name from [A-Za-z0-9._-])",
        source.string(), name, problem));
}

std::uint64_t read_seed(ParameterTable& root) {
    return static_cast<std::uint64_t>(
        root.integer("seed", static_cast<long>(kDefaultSeed), 0, 1L << 62, "random seed"));
}

namespace {

// The grid as the file writes it, for every message about it: "first_nm = 300, last_nm = 300,
// step_nm = 50" (a key left out shows its default).
std::string given_grid(const ParameterTable& table, const WavelengthRule& rule) {
    const auto one = [&](std::string_view key, double default_nm) {
        const std::string written = table.written(key);
        return written.empty() ? fmt::format("{} = {} (default)", key, default_nm)
                               : fmt::format("{} = {}", key, written);
    };
    return fmt::format("the grid given: {}, {}, {}", one("first_nm", rule.first_nm),
                       one("last_nm", rule.last_nm), one("step_nm", rule.step_nm));
}

}  // namespace

std::vector<double> read_wavelengths(ParameterTable& table, const WavelengthRule& rule) {
    const std::string given = given_grid(table, rule);
    const std::string range =
        fmt::format("{}-{} nm: {}", rule.min_nm, rule.max_nm, rule.range_reason);
    double first = 0.0, last = 0.0, step = 0.0;
    try {
        first = table.number("first_nm", rule.first_nm, between(rule.min_nm, rule.max_nm),
                             fmt::format("first wavelength, nm; {}", range));
        last = table.number("last_nm", rule.last_nm, between(rule.min_nm, rule.max_nm),
                            fmt::format("last wavelength, nm; {}", range));
        step = table.number("step_nm", rule.step_nm, positive(), "wavelength step, nm");
    } catch (const InputError& e) {
        throw InputError(fmt::format("{}; {}", e.what(), given));
    }
    if (!(last > first)) {
        throw InputError(fmt::format("{}: {}.last_nm = {} is not above first_nm = {} ({})",
                                     table.location("last_nm"), table.path(), last, first, given));
    }
    const double count = optics::WavelengthGrid::uniform_count(first, last, step);
    const auto max_count = optics::WavelengthGrid::kMaxWavelengths;
    if (count > static_cast<double>(max_count)) {
        throw InputError(fmt::format(
            "{}: {}.step_nm = {} gives {:.3g} wavelengths over {}-{} nm: expected at most {} "
            "(step_nm >= {:.4g}; {})",
            table.location("step_nm"), table.path(), step, count, first, last, max_count,
            (last - first) / static_cast<double>(max_count - 1), given));
    }
    if (count < 2.0) {
        throw InputError(fmt::format(
            "{}: [{}] gives 1 wavelength ({} nm; step_nm = {} exceeds last_nm - first_nm): "
            "expected at least 2 for colour ({})",
            table.location(), table.path(), first, step, given));
    }
    const optics::WavelengthGrid grid = optics::WavelengthGrid::uniform(first, last, step);
    return {grid.nm().begin(), grid.nm().end()};
}

Range film_thickness_range(bool zero_allowed) {
    return {0.0, kMaxFilmThicknessUm, !zero_allowed, false};
}

namespace {

std::string film_what(std::string_view what) {
    return fmt::format("{}, um; the films that colour feathers are well under {} um", what,
                       kMaxFilmThicknessUm);
}

}  // namespace

double read_film_thickness_um(ParameterTable& table, std::string_view key, double default_um,
                              std::string_view what) {
    return table.number(key, default_um, film_thickness_range(), film_what(what));
}

double read_required_film_thickness_um(ParameterTable& table, std::string_view key,
                                       std::string_view what) {
    return table.required_number(key, film_thickness_range(false), film_what(what));
}

geometry::TessellationTolerance read_tolerance(ParameterTable t) {
    geometry::TessellationTolerance tol;
    tol.max_chord_um =
        t.number("max_chord_um", 0.01, positive(), "largest facet-to-surface distance, um");
    tol.max_normal_error_rad = t.angle_deg("max_normal_error_deg", 0.02, {0.0, 28.0, true, false},
                                           "largest facet-normal error, degrees");
    return tol;
}

geometry::MeshImportOptions read_mesh_import_options(ParameterTable& m) {
    geometry::MeshImportOptions options;
    // From picometres to metres per file unit: beyond either, a feather's micrometre features
    // would be below double's resolution of the file's numbers or above any scanner's field.
    options.scale_to_um =
        m.number("scale_to_um", 1.0, between(1e-6, 1e6), "micrometres per file unit");
    options.require_closed = m.boolean("require_closed", true, "reject open meshes");
    options.repair = m.boolean("repair", true, "repair what is safe to repair");
    return options;
}

geometry::BarbuleRowParams read_barbule_row_params(ParameterTable& geometry) {
    geometry::BarbuleRowParams p;
    ParameterTable cell = geometry.table("cell");
    p.cell.b = cell.number("b", p.cell.b, between(1e-3, 1.0), "semi-minor / semi-major axis");
    p.cell.phi0 = cell.angle_deg("phi0_deg", p.cell.phi0, between(-360.0, 360.0),
                                 "arc start, normal azimuth");
    p.cell.phi1 =
        cell.angle_deg("phi1_deg", p.cell.phi1, between(-360.0, 360.0), "arc end, normal azimuth");
    p.cell.theta_d = cell.angle_deg("theta_d_deg", p.cell.theta_d, between(0.0, 45.0),
                                    "longitudinal half-opening");
    p.cell.semi_major_um = cell.number("semi_major_um", p.cell.semi_major_um, positive(),
                                       "ellipse semi-major axis, um");
    p.cell.cell_length_um = cell.number("cell_length_um", p.cell.cell_length_um, positive(),
                                        "cell length along the barbule, um");
    p.cell.profile =
        cell.string("profile", "saddle", {"saddle", "convex"}, "longitudinal arc") == "convex"
            ? geometry::LongitudinalProfile::convex
            : geometry::LongitudinalProfile::saddle;
    p.cell.film_thickness_um = read_film_thickness_um(
        cell, "film_thickness_um", p.cell.film_thickness_um, "keratin cortex film");
    p.cell.melanin_depth_um = cell.number("melanin_depth_um", p.cell.melanin_depth_um, positive(),
                                          "depth of the melanin layer, um");
    ParameterTable row = geometry.table("row");
    p.H = row.number("H", p.H, positive(), "barbule spacing, in units of the semi-major axis");
    p.mu = row.angle_deg("mu_deg", p.mu, {-90.0, 90.0, true, true}, "barb-plane tilt");
    p.barbules =
        static_cast<int>(row.integer("barbules", p.barbules, 1, 100000, "barbules in the row"));
    p.cells_per_barbule = static_cast<int>(row.integer("cells_per_barbule", p.cells_per_barbule, 1,
                                                       100000, "cells along each barbule"));
    p.jitter_phi_rad = row.angle_deg("jitter_phi_deg", 0.0, between(0.0, 28.0),
                                     "per-cell azimuthal tilt, standard deviation");
    p.jitter_theta_rad = row.angle_deg("jitter_theta_deg", 0.0, between(0.0, 28.0),
                                       "per-cell longitudinal tilt, standard deviation");
    p.seed = static_cast<std::uint64_t>(row.integer("seed", 1, 0, 1L << 62, "random seed"));
    return p;
}

geometry::BarbulePatchParams read_barb_patch_params(ParameterTable& geometry) {
    // The sections of the earlier meanings: refused, never reinterpreted.
    for (const char* old : {"barb", "barbules"}) {
        if (geometry.has(old)) {
            throw InputError(fmt::format(
                "{}: {}.{}: the barb and barbule keys moved to [{}.vane] and now mean what "
                "Padrón-Griffe et al. 2024's code means (barb and barbule 'eccentricity' became "
                "axis ratios, barbule length counts half barb widths, separation is the gap "
                "between barbules, rotation is the barbules' direction in the vane); the mapping "
                "from the old keys is in studies/README.md, \"Padrón-Griffe parameters\"",
                geometry.location(old), geometry.path(), old, geometry.path()));
        }
    }
    geometry::BarbulePatchParams p;
    ParameterTable vane = geometry.table("vane");
    p.barb.barb_width_um = vane.number("barb_width_um", p.barb.barb_width_um, positive(),
                                       "barb width across the vane (horizontal diameter), um");
    p.barb.barb_axis_ratio =
        vane.number("barb_axis_ratio", p.barb.barb_axis_ratio, between(0.05, 20.0),
                    "barb height / width (Padrón-Griffe's barb excentricity)");
    p.barb.barb_rotation_rad = vane.angle_deg("barb_rotation_deg", 0.0, between(-180.0, 180.0),
                                              "barb cross-section turned from +z towards +y");
    p.barb.medulla_scale = vane.number("medulla_scale", 0.0, between(0.0, 0.95),
                                       "medulla size relative to the cortex, 0 = none");
    p.barb.medulla_offset_y_um =
        vane.number("medulla_offset_y_um", 0.0, {}, "medulla offset along y, um");
    p.barb.medulla_offset_z_um =
        vane.number("medulla_offset_z_um", 0.0, {}, "medulla offset along z, um");
    p.barbule_width_um = vane.number("barbule_width_um", p.barbule_width_um, positive(),
                                     "barbule width across the row of barbules, um");
    p.barbule_axis_ratio =
        vane.number("barbule_axis_ratio", p.barbule_axis_ratio, between(0.05, 20.0),
                    "barbule thickness / width (Padrón-Griffe's barbule excentricity)");
    p.barbule_rotation_rad =
        vane.angle_deg("barbule_rotation_deg", p.barbule_rotation_rad, between(0.0, 180.0),
                       "barbules' direction in the vane, from the barb axis");
    p.barbule_inclination_rad =
        vane.angle_deg("barbule_inclination_deg", p.barbule_inclination_rad,
                       {-90.0, 90.0, true, true}, "barbule rise out of the vane");
    p.barbule_length = vane.number("barbule_length", p.barbule_length, between(1e-6, 1000.0),
                                   "barbule length, in half barb widths (Padrón-Griffe)");
    p.barbule_separation =
        vane.number("barbule_separation", p.barbule_separation, between(0.0, 1e6),
                    "gap between neighbouring barbules, in barbule widths");
    p.barb_spacing = vane.number("barb_spacing", 0.0, non_negative(),
                                 "barb pitch in barb widths, 0 = barbules meet");
    return p;
}

}  // namespace plumage::studies
