// The user's measured data, read for the fits (analysis/fits/huang2022_fit.h,
// analysis/fits/filip2024_fit.h). The layouts are documented for users in docs/user_data.md; in
// short:
//
//  BRDF table (CSV, `.csv`): one row per (light, view, wavelength or channel); lines starting with
//  '#' and blank lines are skipped; the first other line is the header, naming the columns (any
//  order, names exact):
//    theta_i_deg, phi_i_deg   the light direction: polar angle from the patch normal +z, [0, 90),
//                             and azimuth from +x (the barb axis) towards +y, degrees
//    theta_o_deg, phi_o_deg   the view direction, the same way
//    wavelength_nm            the wavelength, nm (> 0)   — or —   channel: R, G or B (camera RGB,
//                             as Filip 2024's own data)
//    value_per_sr             the BRDF, 1/sr (finite)
//    sigma_per_sr             optional: its standard error, 1/sr (> 0); without it every row
//                             weighs the same
//  BRDF record (HDF5, a goniometer record of virtual_gonio/RECORD.md):
//  /instrument/light_directions, /instrument/view_directions [pairs, 3], /wavelength_nm [λ],
//  /brdf/value and /brdf/standard_error [pairs, λ]. Cells whose standard error is 0 (no quantum
//  counted, so no error estimate) are left out and counted. Scatterogram record (HDF5, an
//  imaging-scatterometer record of RECORD.md): /instrument
//  @illumination, @beam_direction ("x y z"), @cone_aperture_deg; /wavelength_nm [λ];
//  /image/intensity and /image/standard_error [rows, rows, λ]; /image/solid_angle_sr [rows, rows].
//
// Every error is an InputError naming the file and, for a CSV, the line and column.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "analysis/fits/filip2024_fit.h"
#include "common/error.h"
#include "virtual_gonio/scatterometer.h"

namespace plumage::analysis {

struct BrdfData {
    std::vector<BrdfObservation> observations;  // in file order (pairs of a record: pair-major)
    std::string format;                         // "csv" or "brdf_record"
    bool has_standard_errors = false;
    std::size_t left_out = 0;  // record cells without a standard error
};

BrdfData read_brdf_csv(const std::filesystem::path& path);
BrdfData read_brdf_record(const std::filesystem::path& path);
// By the file's extension: .csv, or .h5/.hdf5 (a goniometer record).
BrdfData read_brdf_data(const std::filesystem::path& path);

gonio::Scatterogram read_scatterogram_record(const std::filesystem::path& path);

// "goniometer", "imaging_scatterometer", ... : /instrument@kind of an HDF5 record ("csv" for a
// .csv file); InputError if the file is neither.
std::string data_kind(const std::filesystem::path& path);

// `e` with "<file>: " in front, unless its message names the file already: a fit's own checks
// ("0 observations with signal") do not know which file the observations came from. `file`
// empty (observations not from a file): `e` as it is.
InputError naming_data_file(const InputError& e, const std::string& file);

// Unit vector from polar θ and azimuth φ in degrees (the CSV's convention).
Vec3d direction_from_degrees(double theta_deg, double phi_deg);

}  // namespace plumage::analysis
