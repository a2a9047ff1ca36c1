#include "sim/wave/compare/full_wave_reference.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

#include <fmt/format.h>

#include "common/constants.h"
#include "common/error.h"

namespace plumage::sim::wave {
namespace {

namespace fs = std::filesystem;

// far_field.csv's grid: θ_s = −179.5° + 0.5° m, m = 0 … 719.
constexpr int kAngles = 720;
constexpr double kFirstDeg = -179.5, kStepDeg = 0.5;

std::vector<std::string> split(std::string line) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    std::vector<std::string> out;
    std::stringstream s(line);
    std::string cell;
    while (std::getline(s, cell, ',')) out.push_back(cell);
    if (!line.empty() && line.back() == ',') out.emplace_back();
    return out;
}

std::string key_text(const FullWaveKey& k) {
    return fmt::format("{} {} θ_i = {}° λ = {} nm", k.shape, k.polarisation, k.theta_i_deg,
                       k.lambda_nm);
}

}  // namespace

std::size_t ReferenceCsv::column(const std::string& name) const {
    const auto it = std::find(header.begin(), header.end(), name);
    if (it == header.end())
        throw InputError(fmt::format("{}:1: expected a column '{}' in the header ({})",
                                     path.string(), name, fmt::join(header, ",")));
    return static_cast<std::size_t>(it - header.begin());
}

const std::string& ReferenceCsv::text(std::size_t r, const std::string& name) const {
    return rows.at(r)[column(name)];
}

double ReferenceCsv::number(std::size_t r, const std::string& name) const {
    const std::string& cell = text(r, name);
    std::size_t used = 0;
    double v = 0.0;
    try {
        v = std::stod(cell, &used);
    } catch (const std::exception&) {
        used = 0;
    }
    if (used == 0 || used != cell.size() || !std::isfinite(v))
        throw InputError(fmt::format("{}:{}: column '{}' = '{}': expected a finite number",
                                     path.string(), lines.at(r), name, cell));
    return v;
}

int ReferenceCsv::integer(std::size_t r, const std::string& name) const {
    const double v = number(r, name);
    if (v != std::round(v) || std::abs(v) > 1e9)
        throw InputError(fmt::format("{}:{}: column '{}' = '{}': expected an integer",
                                     path.string(), lines.at(r), name, text(r, name)));
    return static_cast<int>(v);
}

FullWaveKey ReferenceCsv::key(std::size_t r) const {
    return {text(r, "case"), text(r, "polarisation"), integer(r, "theta_i_deg"),
            integer(r, "lambda_nm")};
}

ReferenceCsv read_reference_csv(const fs::path& path,
                                const std::vector<std::string>& required_columns) {
    std::ifstream in(path);
    if (!in)
        throw InputError(
            fmt::format("{}: cannot open the full-wave reference file", path.string()));
    ReferenceCsv t;
    t.path = path;
    std::string line;
    if (!std::getline(in, line) || split(line).empty())
        throw InputError(fmt::format("{}:1: expected a header line", path.string()));
    t.header = split(line);
    for (std::size_t n = 2; std::getline(in, line); ++n) {
        if (line.empty() || line == "\r") continue;
        std::vector<std::string> cells = split(line);
        if (cells.size() != t.header.size())
            throw InputError(fmt::format("{}:{}: expected {} cells as in the header, got {}",
                                         path.string(), n, t.header.size(), cells.size()));
        t.rows.push_back(std::move(cells));
        t.lines.push_back(n);
    }
    for (const std::string& c : required_columns) t.column(c);
    return t;
}

FullWaveReference read_full_wave_reference(const fs::path& folder) {
    FullWaveReference ref;
    ref.folder = folder;
    const ReferenceCsv ff = read_reference_csv(
        folder / "far_field.csv", {"case", "polarisation", "theta_i_deg", "lambda_nm",
                                   "resolution_px_per_um", "theta_s_deg", "sigma_um_per_rad"});
    for (std::size_t r = 0; r < ff.rows.size(); ++r) {
        const FullWaveKey key = ff.key(r);
        try {
            full_wave_shape(key.shape);
        } catch (const InputError&) {
            // Named here, with its line: the shape is otherwise first looked up by the study,
            // which knows only the folder.
            throw InputError(
                fmt::format("{}:{}: case = '{}': expected single, small or row3 (the "
                            "contract's shapes)",
                            ff.path.string(), ff.lines[r], key.shape));
        }
        if (key.polarisation != "TE" && key.polarisation != "TM")
            throw InputError(fmt::format("{}:{}: polarisation = '{}': expected TE or TM",
                                         ff.path.string(), ff.lines[r], key.polarisation));
        FullWaveCurve& curve = ref.far_field[key];
        const double theta = ff.number(r, "theta_s_deg");
        const double expected =
            kFirstDeg + kStepDeg * static_cast<double>(curve.theta_s_rad.size());
        if (curve.theta_s_rad.size() >= kAngles || std::abs(theta - expected) > 1e-6)
            throw InputError(fmt::format(
                "{}:{}: theta_s_deg = {}: expected {} (the curve {} runs −179.5° to 180° in "
                "0.5° steps, in order)",
                ff.path.string(), ff.lines[r], theta, expected, key_text(key)));
        curve.resolution_px_per_um = ff.number(r, "resolution_px_per_um");
        curve.theta_s_rad.push_back(theta * kDeg);
        curve.sigma_um_per_rad.push_back(ff.number(r, "sigma_um_per_rad"));
    }
    if (ref.far_field.empty())
        throw InputError(fmt::format("{}: expected at least one curve", ff.path.string()));
    for (const auto& [key, curve] : ref.far_field)
        if (curve.theta_s_rad.size() != kAngles)
            throw InputError(fmt::format("{}: the curve {} has {} points: expected {}",
                                         ff.path.string(), key_text(key), curve.theta_s_rad.size(),
                                         kAngles));

    const ReferenceCsv cv =
        read_reference_csv(folder / "convergence.csv",
                           {"case", "polarisation", "theta_i_deg", "lambda_nm", "coarse_px_per_um",
                            "fine_px_per_um", "sigma_max_rel_diff", "sigma_rms_rel_diff",
                            "scattering_width_rel_diff", "absorption_width_rel_diff"});
    for (std::size_t r = 0; r < cv.rows.size(); ++r)
        ref.convergence[cv.key(r)] = {
            cv.number(r, "coarse_px_per_um"),          cv.number(r, "fine_px_per_um"),
            cv.number(r, "sigma_max_rel_diff"),        cv.number(r, "sigma_rms_rel_diff"),
            cv.number(r, "scattering_width_rel_diff"), cv.number(r, "absorption_width_rel_diff")};
    for (const auto& [key, curve] : ref.far_field)
        if (!ref.convergence.contains(key))
            throw InputError(fmt::format("{}: expected a row for the far-field curve {}",
                                         cv.path.string(), key_text(key)));
    return ref;
}

FullWaveShape full_wave_shape(const std::string& name) {
    if (name == "single") return {5.0, 2.0, 0.3, 1, 11.0};
    if (name == "small") return {1.0, 0.4, 0.3, 1, 11.0};
    if (name == "row3") return {5.0, 2.0, 0.3, 3, 11.0};
    throw InputError(fmt::format(
        "full-wave reference: shape '{}': expected single, small or row3 (the contract's)", name));
}

Row2d full_wave_row(const std::string& name) {
    const FullWaveShape s = full_wave_shape(name);
    Row2d row;
    row.cell = coated_ellipse(s.a_x_um, s.a_z_um, s.shell_um);
    row.count = s.count;
    row.spacing_um = s.spacing_um;
    return row;
}

double full_wave_projected_width(const std::string& name, double theta_i_rad) {
    const FullWaveShape s = full_wave_shape(name);
    const double ux = std::cos(theta_i_rad), uz = -std::sin(theta_i_rad);
    return s.count * 2.0 *
           (std::sqrt(s.a_x_um * s.a_x_um * ux * ux + s.a_z_um * s.a_z_um * uz * uz) + s.shell_um);
}

}  // namespace plumage::sim::wave
