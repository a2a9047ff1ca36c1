// The full-wave (Meep) reference of tests/reference/barbule_2d read into memory, and the shapes
// of its contract (that folder's README.md, "Shape") as physical-optics cross-sections, so that
// physical optics, geometric optics and full wave are compared on the same bodies by tests
// (physical_optics_fullwave_test.cpp) and by the wave-validity study ("full-wave check").
//
// Files (written by Python's csv module, CRLF line ends accepted; a header line, then rows):
//  - far_field.csv: case, polarisation, theta_i_deg, lambda_nm, resolution_px_per_um,
//    theta_s_deg, sigma_um_per_rad: σ(θ_s) of the scattered field, per curve the grid
//    θ_s = −179.5° + 0.5° m, m = 0 … 719, in order.
//  - convergence.csv: case, polarisation, theta_i_deg, lambda_nm, coarse_px_per_um,
//    fine_px_per_um, sigma_max_rel_diff, sigma_rms_rel_diff, scattering_width_rel_diff,
//    absorption_width_rel_diff: Meep's 40 vs 60 px/µm differences (σ where σ(60) > 1 % of its
//    peak).
// Any other CSV of the folder (totals.csv, materials.csv) through read_reference_csv.
// A missing or unreadable file, a missing column, a non-numeric or non-finite value, a row with
// the wrong number of cells or a curve off the grid: InputError naming the file, the line and
// what was expected.
//
// Units: lengths µm, wavelengths nm, angles as in the files (degrees) in the keys and radians in
// the curves' θ_s (physical_optics_2d.h's frame: θ from +z towards +x, away from the object).
#pragma once

#include <compare>
#include <cstddef>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "sim/wave/surface/physical_optics_2d.h"

namespace plumage::sim::wave {

// One curve of the reference: shape ("single", "small", "row3"), polarisation ("TE", "TM"),
// θ_i and λ as the files write them.
struct FullWaveKey {
    std::string shape, polarisation;
    int theta_i_deg = 0, lambda_nm = 0;
    auto operator<=>(const FullWaveKey&) const = default;
};

struct FullWaveCurve {
    double resolution_px_per_um = 0.0;
    std::vector<double> theta_s_rad;  // −179.5° … 180°, 0.5° apart
    std::vector<double> sigma_um_per_rad;
};

struct FullWaveConvergence {
    double coarse_px_per_um = 0.0, fine_px_per_um = 0.0;
    double sigma_max_rel_diff = 0.0, sigma_rms_rel_diff = 0.0;
    double scattering_width_rel_diff = 0.0, absorption_width_rel_diff = 0.0;
};

struct FullWaveReference {
    std::filesystem::path folder;
    std::map<FullWaveKey, FullWaveCurve> far_field;
    std::map<FullWaveKey, FullWaveConvergence> convergence;  // one per far-field curve
};

// A CSV of the reference folder: header and cells, each row with its 1-based line number.
class ReferenceCsv {
public:
    std::filesystem::path path;
    std::vector<std::string> header;
    std::vector<std::vector<std::string>> rows;
    std::vector<std::size_t> lines;
    // Index of a column; InputError naming the file and the header line when absent.
    std::size_t column(const std::string& name) const;
    // Cell of row r (index into rows) as a finite number / an integer / text; InputError
    // "file:line: column 'name' = 'x': expected a number" otherwise.
    double number(std::size_t r, const std::string& name) const;
    int integer(std::size_t r, const std::string& name) const;
    const std::string& text(std::size_t r, const std::string& name) const;
    // The key columns case, polarisation, theta_i_deg, lambda_nm of row r.
    FullWaveKey key(std::size_t r) const;
};

// Reads one CSV; InputError when the file is missing or empty, or a row's cell count differs
// from the header's (naming file and line), or a required column is absent.
ReferenceCsv read_reference_csv(const std::filesystem::path& path,
                                const std::vector<std::string>& required_columns = {});

// far_field.csv and convergence.csv of the folder; InputError as above, and when a curve is not
// the 720-point grid or has no convergence row.
FullWaveReference read_full_wave_reference(const std::filesystem::path& folder);

// The contract's shapes: melanin core ellipse (semi-axes a_x, a_z) in a keratin shell d, the
// outer boundary the core's offset (coated_ellipse); row3: three cells 11 µm apart along x.
struct FullWaveShape {
    double a_x_um, a_z_um, shell_um;
    int count;
    double spacing_um;
};
// InputError naming the shape when it is not one of the contract's.
FullWaveShape full_wave_shape(const std::string& name);
Row2d full_wave_row(const std::string& name);
// Projected width seen from θ_i: count × 2 (h_core(u) + d), u ⟂ ω_i (the cells of row3 do not
// overlap in projection at these incidences), µm.
double full_wave_projected_width(const std::string& name, double theta_i_rad);

}  // namespace plumage::sim::wave
