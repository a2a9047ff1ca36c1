// Readers of the keys and sections that several studies share, one rule each, so that a
// key means the same and is checked the same in every study file. Each reader checks its
// values when the file is read (before any work) and names file:line:column in its errors.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "geometry/barb.h"
#include "geometry/barbule.h"
#include "geometry/mesh_import.h"
#include "geometry/tessellation.h"
#include "studies/study_file.h"

namespace plumage::studies {

// `name`: the results folder, <results root>/<name>. One plain folder name: 1 to
// kMaxStudyNameLength characters from [A-Za-z0-9._-], not "." or "..", so that a name can
// never reach outside the results root, and none that plumage's own entries in the root could
// take (staging_name_problem, studies/staged_directory.h: ".partial-", ".previous-", ...).
// Defaults to the study file's stem (which must obey the same rule, or the file must set
// `name`).
inline constexpr std::size_t kMaxStudyNameLength = 100;
std::string read_study_name(ParameterTable& root, const std::filesystem::path& source);
// The rule itself: empty when `name` is a valid study name, else what is wrong with it.
std::string study_name_problem(std::string_view name);

// `seed`: the integer every random stream of the study derives from.
std::uint64_t read_seed(ParameterTable& root);

// A uniform wavelength grid from first_nm, last_nm, step_nm of `table` ([spectrum], [btf]):
// first < last within [min_nm, max_nm], at least 2 and at most
// optics::WavelengthGrid::kMaxWavelengths wavelengths.
struct WavelengthRule {
    double first_nm = 400.0;  // defaults
    double last_nm = 700.0;
    double step_nm = 50.0;
    double min_nm = 300.0;  // the range a study accepts, and why
    double max_nm = 800.0;
    std::string_view range_reason =
        "the range of keratin and melanin dispersion (sim/optics/material.h; CIE colour weighs "
        "light below 360 nm 0)";
};
std::vector<double> read_wavelengths(ParameterTable& table, const WavelengthRule& rule);
// Studies that compare against Filip 2024, whose colour bands are defined on 380-780 nm.
inline constexpr WavelengthRule kFilipWavelengths{
    .first_nm = 450.0,
    .last_nm = 650.0,
    .step_nm = 100.0,
    .min_nm = 380.0,
    .max_nm = 780.0,
    .range_reason = "Filip 2024's colour bands cover 380-780 nm"};

// A keratin film's thickness, in µm (geometry.cell.film_thickness_um, the species' cortex_film_um,
// a measured sample's film, the ablation's sweep of it): one range for every study file. The
// films that colour feathers are well under a few micrometres (the rock dove's 0.59 µm, the
// rooster's 0.174 µm), so [0, kMaxFilmThicknessUm]; a value that fits in nanometres instead
// (590 for 0.59 µm) is refused with that hint when the file is read (study_file.h).
inline constexpr double kMaxFilmThicknessUm = 5.0;
// [0, kMaxFilmThicknessUm], or (0, kMaxFilmThicknessUm] where a film must be present.
Range film_thickness_range(bool zero_allowed = true);
// `key` of `table` within film_thickness_range; `what` names the film ("keratin cortex film").
double read_film_thickness_um(ParameterTable& table, std::string_view key, double default_um,
                              std::string_view what);
double read_required_film_thickness_um(ParameterTable& table, std::string_view key,
                                       std::string_view what);

// [geometry.cell] and [geometry.row] of a barbule row (Huang 2022's parameters), in the units
// the geometry library takes (angles in radians).
geometry::BarbuleRowParams read_barbule_row_params(ParameterTable& geometry);
// [<table>.vane] of a barb patch: Padrón-Griffe 2024's parameters with the authors' meanings
// (geometry/barb.h); the old [<table>.barb] and [<table>.barbules] are refused with the mapping.
geometry::BarbulePatchParams read_barb_patch_params(ParameterTable& geometry);
// [tessellation]: how finely curved surfaces are faceted.
geometry::TessellationTolerance read_tolerance(ParameterTable tessellation);
// How an imported mesh is read (`geometry` and `measure` studies): scale_to_um, require_closed,
// repair of `table` (geometry/mesh_import.h).
geometry::MeshImportOptions read_mesh_import_options(ParameterTable& table);

}  // namespace plumage::studies
