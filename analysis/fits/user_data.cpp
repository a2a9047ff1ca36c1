#include "analysis/fits/user_data.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <fstream>
#include <map>
#include <numbers>
#include <optional>
#include <sstream>

#include <fmt/format.h>

#include "analysis/models/filip2024.h"
#include "common/error.h"
#include "sim/optics/spectrum.h"
#include "virtual_gonio/record/hdf5_reader.h"

namespace plumage::analysis {
namespace {

namespace fs = std::filesystem;

// The longest name-like string attribute read (kind, illumination, a direction).
constexpr std::size_t kMaxNameBytes = 256;

std::string trim(std::string_view s) {
    const auto first = s.find_first_not_of(" \t\r");
    if (first == std::string_view::npos) return {};
    const auto last = s.find_last_not_of(" \t\r");
    return std::string(s.substr(first, last - first + 1));
}

std::vector<std::string> split(const std::string& line) {
    std::vector<std::string> out;
    std::stringstream ss(line);
    std::string cell;
    while (std::getline(ss, cell, ',')) out.push_back(trim(cell));
    if (!line.empty() && line.back() == ',') out.emplace_back();
    return out;
}

// The columns of the CSV by name; −1 for an absent optional one.
struct Columns {
    int theta_i = -1, phi_i = -1, theta_o = -1, phi_o = -1, wavelength = -1, channel = -1,
        value = -1, sigma = -1;
};

Columns read_header(const std::vector<std::string>& names, const std::string& where) {
    Columns c;
    const std::map<std::string, int*> known = {
        {"theta_i_deg", &c.theta_i}, {"phi_i_deg", &c.phi_i},          {"theta_o_deg", &c.theta_o},
        {"phi_o_deg", &c.phi_o},     {"wavelength_nm", &c.wavelength}, {"channel", &c.channel},
        {"value_per_sr", &c.value},  {"sigma_per_sr", &c.sigma}};
    for (std::size_t i = 0; i < names.size(); ++i) {
        const auto it = known.find(names[i]);
        if (it == known.end() || *it->second >= 0) {
            throw InputError(fmt::format(
                "{}:{}: column '{}': {}; expected theta_i_deg, phi_i_deg, theta_o_deg, "
                "phi_o_deg, wavelength_nm (or channel), value_per_sr and optionally sigma_per_sr "
                "(docs/user_data.md)",
                where, i + 1, names[i], it == known.end() ? "unknown" : "given twice"));
        }
        *it->second = static_cast<int>(i);
    }
    for (const auto& [name, index] : known) {
        const bool optional =
            name == "sigma_per_sr" || name == "wavelength_nm" || name == "channel";
        if (*index < 0 && !optional)
            throw InputError(fmt::format("{}: header: the column '{}' is missing", where, name));
    }
    if ((c.wavelength < 0) == (c.channel < 0)) {
        throw InputError(fmt::format(
            "{}: header: expected exactly one of the columns wavelength_nm and channel", where));
    }
    return c;
}

double number_at(const std::vector<std::string>& cells, int column, const std::string& where,
                 std::string_view name) {
    const std::string& text = cells[static_cast<std::size_t>(column)];
    double v = 0.0;
    const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), v);
    if (error != std::errc() || end != text.data() + text.size() || !std::isfinite(v)) {
        throw InputError(fmt::format("{}:{}: {} = '{}': expected a finite number", where,
                                     column + 1, name, text));
    }
    return v;
}

// The wavelengths of BRDF data: Filip 2024's R, G and B bands, the only model fitted to them.
bool filip_wavelength(double v) {
    return v >= kFilip2024MinWavelengthNm && v <= kFilip2024MaxWavelengthNm;
}

BrdfObservation observation_of(const std::vector<std::string>& cells, const Columns& c,
                               const std::string& where) {
    BrdfObservation o;
    const double ti = number_at(cells, c.theta_i, where, "theta_i_deg");
    const double to = number_at(cells, c.theta_o, where, "theta_o_deg");
    for (const auto& [theta, column, name] :
         {std::tuple{ti, c.theta_i, "theta_i_deg"}, std::tuple{to, c.theta_o, "theta_o_deg"}}) {
        if (!(theta >= 0.0 && theta < 90.0)) {
            throw InputError(
                fmt::format("{}:{}: {} = {}: expected a polar angle in [0, 90) deg "
                            "(both directions above the patch)",
                            where, column + 1, name, theta));
        }
    }
    o.wi = direction_from_degrees(ti, number_at(cells, c.phi_i, where, "phi_i_deg"));
    o.wo = direction_from_degrees(to, number_at(cells, c.phi_o, where, "phi_o_deg"));
    if (c.wavelength >= 0) {
        const double l = number_at(cells, c.wavelength, where, "wavelength_nm");
        // The only model fitted to these rows (Filip 2024) maps a wavelength to its R, G or B
        // band; one outside them would otherwise reach the fit, which knows no line.
        if (!filip_wavelength(l)) {
            throw InputError(fmt::format(
                "{}:{}: wavelength_nm = {}: expected a wavelength in [{}, {}] nm (Filip 2024's "
                "R, G and B bands; or give a channel column)",
                where, c.wavelength + 1, l, kFilip2024MinWavelengthNm, kFilip2024MaxWavelengthNm));
        }
        o.lambda_nm = l;
    } else {
        const std::string& ch = cells[static_cast<std::size_t>(c.channel)];
        if (ch != "R" && ch != "G" && ch != "B") {
            throw InputError(
                fmt::format("{}:{}: channel = '{}': expected R, G or B", where, c.channel + 1, ch));
        }
        o.channel = ch == "R"   ? RgbChannel::kRed
                    : ch == "G" ? RgbChannel::kGreen
                                : RgbChannel::kBlue;
    }
    o.value = number_at(cells, c.value, where, "value_per_sr");
    if (c.sigma >= 0) {
        const double s = number_at(cells, c.sigma, where, "sigma_per_sr");
        if (!(s > 0.0)) {
            throw InputError(fmt::format("{}:{}: sigma_per_sr = {}: expected a standard error > 0",
                                         where, c.sigma + 1, s));
        }
        o.standard_error = s;
    }
    return o;
}

// A record's numeric dataset whose values must all satisfy `valid` ("finite", ...), named in the
// error with the first offending value.
void require_values(const record::Hdf5Reader& file, const std::string& name,
                    const record::Dataset& d, bool (*valid)(double), std::string_view expected) {
    for (std::size_t i = 0; i < d.values.size(); ++i) {
        if (!valid(d.values[i])) {
            throw InputError(
                fmt::format("HDF5 file '{}': /{}: the value at flat index {} is {}; expected {}",
                            file.file().string(), name, i, d.values[i], expected));
        }
    }
}

bool finite(double v) { return std::isfinite(v); }
bool finite_non_negative(double v) { return std::isfinite(v) && v >= 0.0; }
// The wavelengths a Huang fit evaluates: the range of the keratin and melanin dispersion the
// model uses (sim/optics/material.h), as a study file's [spectrum] accepts.
bool huang_wavelength(double v) { return v >= 300.0 && v <= 800.0; }

// Unit direction vectors above the patch, [n, 3] (float32 rounding allowed).
void require_directions(const record::Hdf5Reader& file, const std::string& name,
                        const record::Dataset& d) {
    for (std::size_t i = 0; i < d.dims[0]; ++i) {
        const Vec3d w(d.values[3 * i], d.values[3 * i + 1], d.values[3 * i + 2]);
        if (!(w.allFinite() && std::abs(w.norm() - 1.0) <= 1e-5 && w.z() > 0.0)) {
            throw InputError(fmt::format(
                "HDF5 file '{}': /{}: row {} = ({}, {}, {}); expected a unit vector (to 1e-5) "
                "above the patch (z > 0)",
                file.file().string(), name, i, w.x(), w.y(), w.z()));
        }
    }
}

// A record's /instrument@illumination, @beam_direction and @cone_aperture_deg, range-checked as
// a study file's [scatterometer] keys are.
void read_illumination(const record::Hdf5Reader& file, gonio::ScatterometerConfig& c) {
    const std::string where = fmt::format("HDF5 file '{}': /instrument@", file.file().string());
    const std::string illumination =
        file.string_attribute("/instrument", "illumination", kMaxNameBytes);
    if (illumination == "beam")
        c.illumination = gonio::Illumination::beam;
    else if (illumination == "cone")
        c.illumination = gonio::Illumination::cone;
    else if (illumination == "hemisphere")
        c.illumination = gonio::Illumination::hemisphere;
    else {
        throw InputError(fmt::format("{}illumination = '{}': expected beam, cone or hemisphere",
                                     where, illumination));
    }
    // The beam's (and the cone's axis) direction; the hemisphere needs none.
    if (c.illumination != gonio::Illumination::hemisphere) {
        const std::string text =
            file.string_attribute("/instrument", "beam_direction", kMaxNameBytes);
        std::istringstream beam(text);
        double x = 0, y = 0, z = 0;
        std::string rest;
        const bool parsed = (beam >> x >> y >> z) && !(beam >> rest);
        const double length = std::hypot(x, y, z);
        if (!parsed || !std::isfinite(x) || !std::isfinite(y) || !(std::isfinite(z) && z > 0.0) ||
            !(length >= 1e-9 && z / length >= 1e-9)) {
            throw InputError(fmt::format(
                "{}beam_direction = '{}': expected \"x y z\", three finite numbers towards the "
                "light, of length >= 1e-9, z > 0",
                where, text.substr(0, 80)));
        }
        c.beam_direction = Vec3d(x, y, z).normalized();
    }
    if (c.illumination == gonio::Illumination::cone) {
        const double aperture_deg = file.number_attribute("/instrument", "cone_aperture_deg");
        const double axis_deg = std::acos(c.beam_direction.z()) * 180.0 / std::numbers::pi;
        if (!(aperture_deg > 0.0 && aperture_deg < 90.0 && axis_deg + 0.5 * aperture_deg < 90.0)) {
            throw InputError(fmt::format(
                "{}cone_aperture_deg = {}: expected a full aperture in (0, 90) deg whose cone "
                "stays above the patch (axis {:.4g} deg from the normal + half the aperture < 90)",
                where, aperture_deg, axis_deg));
        }
        c.cone_aperture_rad = aperture_deg * std::numbers::pi / 180.0;
    }
}

// "an" before a vowel ("an imaging_scatterometer record"), else "a".
const char* article(const std::string& word) {
    return !word.empty() && std::string_view("aeiou").find(word[0]) != std::string_view::npos ? "an"
                                                                                              : "a";
}

void require_file(const fs::path& path) {
    if (!fs::is_regular_file(path))
        throw InputError(fmt::format("{}: no such file", path.string()));
}

}  // namespace

InputError naming_data_file(const InputError& e, const std::string& file) {
    if (file.empty() || std::string_view(e.what()).find(file) != std::string_view::npos) return e;
    return InputError(fmt::format("{}: {}", file, e.what()));
}

Vec3d direction_from_degrees(double theta_deg, double phi_deg) {
    const double t = theta_deg * std::numbers::pi / 180.0, p = phi_deg * std::numbers::pi / 180.0;
    return {std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t)};
}

BrdfData read_brdf_csv(const fs::path& path) {
    require_file(path);
    std::ifstream in(path);
    if (!in) throw InputError(fmt::format("{}: cannot open", path.string()));
    BrdfData data;
    data.format = "csv";
    std::optional<Columns> columns;
    std::string line;
    for (int number = 1; std::getline(in, line); ++number) {
        // Excel's "CSV UTF-8" starts with a byte-order mark.
        if (number == 1 && line.rfind("\xEF\xBB\xBF", 0) == 0) line.erase(0, 3);
        const std::string text = trim(line);
        if (text.empty() || text[0] == '#') continue;
        const std::string where = fmt::format("{}:{}", path.string(), number);
        const std::vector<std::string> cells = split(text);
        if (!columns) {
            columns = read_header(cells, where);
            data.has_standard_errors = columns->sigma >= 0;
            continue;
        }
        const std::size_t expected = static_cast<std::size_t>(
            std::max({columns->theta_i, columns->phi_i, columns->theta_o, columns->phi_o,
                      columns->wavelength, columns->channel, columns->value, columns->sigma}) +
            1);
        if (cells.size() != expected) {
            throw InputError(fmt::format("{}: {} values, expected {} (one per header column)",
                                         where, cells.size(), expected));
        }
        data.observations.push_back(observation_of(cells, *columns, where));
    }
    if (data.observations.empty())
        throw InputError(fmt::format("{}: no data rows (docs/user_data.md)", path.string()));
    return data;
}

BrdfData read_brdf_record(const fs::path& path) {
    const record::Hdf5Reader file(path);
    // Shapes first, then data: nothing is read before every shape agrees.
    const auto wavelength_dims =
        file.shape("wavelength_nm", {1, optics::WavelengthGrid::kMaxWavelengths});
    const auto light_dims = file.shape("instrument/light_directions", {2});
    const auto view_dims = file.shape("instrument/view_directions", {2});
    const auto value_dims = file.shape("brdf/value", {2});
    const auto error_dims = file.shape("brdf/standard_error", {2});
    const std::size_t pairs = light_dims[0], nl = wavelength_dims[0];
    if (light_dims[1] != 3 || view_dims != light_dims || value_dims[0] != pairs ||
        value_dims[1] != nl || error_dims != value_dims || pairs == 0 || nl == 0) {
        throw InputError(fmt::format(
            "HDF5 file '{}': expected /instrument/light_directions and view_directions [pairs, "
            "3], /brdf/value and /brdf/standard_error [pairs, wavelengths] with /wavelength_nm "
            "[wavelengths]; found [{}], [{}], [{}], [{}] and [{}]",
            path.string(), fmt::join(light_dims, ", "), fmt::join(view_dims, ", "),
            fmt::join(value_dims, ", "), fmt::join(error_dims, ", "),
            fmt::join(wavelength_dims, ", ")));
    }
    const record::Dataset wavelengths = file.dataset("wavelength_nm");
    require_values(file, "wavelength_nm", wavelengths, filip_wavelength,
                   fmt::format("a wavelength in [{}, {}] nm (Filip 2024's R, G and B bands)",
                               kFilip2024MinWavelengthNm, kFilip2024MaxWavelengthNm));
    const record::Dataset lights = file.dataset("instrument/light_directions");
    const record::Dataset views = file.dataset("instrument/view_directions");
    require_directions(file, "instrument/light_directions", lights);
    require_directions(file, "instrument/view_directions", views);
    const record::Dataset value = file.dataset("brdf/value");
    require_values(file, "brdf/value", value, finite, "a finite BRDF value, 1/sr");
    const record::Dataset error = file.dataset("brdf/standard_error");
    require_values(file, "brdf/standard_error", error, finite_non_negative,
                   "a finite standard error >= 0, 1/sr (0: no estimate, the cell is left out)");
    BrdfData data;
    data.format = "brdf_record";
    data.has_standard_errors = true;
    for (std::size_t p = 0; p < pairs; ++p) {
        const Vec3d wi(lights.values[3 * p], lights.values[3 * p + 1], lights.values[3 * p + 2]);
        const Vec3d wo(views.values[3 * p], views.values[3 * p + 1], views.values[3 * p + 2]);
        for (std::size_t l = 0; l < nl; ++l) {
            const double sigma = error.values[p * nl + l];
            if (!(sigma > 0.0)) {
                ++data.left_out;
                continue;
            }
            data.observations.push_back({wi.normalized(), wo.normalized(), std::nullopt,
                                         wavelengths.values[l], value.values[p * nl + l], sigma});
        }
    }
    if (data.observations.empty()) {
        throw InputError(
            fmt::format("{}: no cell has a standard error > 0: nothing to fit", path.string()));
    }
    return data;
}

std::string data_kind(const fs::path& path) {
    require_file(path);
    const std::string ext = path.extension().string();
    if (ext == ".csv") return "csv";
    if (ext != ".h5" && ext != ".hdf5") {
        throw InputError(fmt::format(
            "{}: expected a .csv table or an HDF5 record (.h5, .hdf5); docs/user_data.md",
            path.string()));
    }
    const record::Hdf5Reader file(path);
    if (!file.has_object("/instrument") || !file.has_attribute("/instrument", "kind")) {
        throw InputError(
            fmt::format("HDF5 file '{}': /instrument@kind: missing; expected a plumage record "
                        "(virtual_gonio/RECORD.md, docs/user_data.md)",
                        path.string()));
    }
    return file.string_attribute("/instrument", "kind", kMaxNameBytes);
}

BrdfData read_brdf_data(const fs::path& path) {
    const std::string kind = data_kind(path);
    if (kind == "csv") return read_brdf_csv(path);
    if (kind == "goniometer") return read_brdf_record(path);
    throw InputError(
        fmt::format("{}: {} {} record; expected BRDF data (a goniometer record or a "
                    "CSV table)",
                    path.string(), article(kind), kind));
}

gonio::Scatterogram read_scatterogram_record(const fs::path& path) {
    const std::string kind = data_kind(path);
    if (kind != "imaging_scatterometer") {
        throw InputError(
            fmt::format("{}: {} {} {}; expected a scatterogram (an imaging-scatterometer record)",
                        path.string(), article(kind), kind, kind == "csv" ? "table" : "record"));
    }
    const record::Hdf5Reader file(path);
    gonio::Scatterogram s;
    gonio::ScatterometerConfig& c = s.config;
    read_illumination(file, c);
    // Shapes first, then data: nothing is read before every shape agrees.
    const auto wavelength_dims =
        file.shape("wavelength_nm", {1, optics::WavelengthGrid::kMaxWavelengths});
    const auto intensity_dims = file.shape("image/intensity", {3});
    const auto error_dims = file.shape("image/standard_error", {3});
    const auto omega_dims = file.shape("image/solid_angle_sr", {2});
    const std::uint64_t n = intensity_dims[0];
    if (intensity_dims[1] != n || intensity_dims[2] != wavelength_dims[0] ||
        error_dims != intensity_dims || omega_dims[0] != n || omega_dims[1] != n) {
        throw InputError(fmt::format(
            "HDF5 file '{}': expected /image/intensity and /image/standard_error [rows, rows, "
            "wavelengths], /image/solid_angle_sr [rows, rows] and /wavelength_nm [wavelengths]; "
            "found [{}], [{}], [{}] and [{}]",
            path.string(), fmt::join(intensity_dims, ", "), fmt::join(error_dims, ", "),
            fmt::join(omega_dims, ", "), fmt::join(wavelength_dims, ", ")));
    }
    if (n < 9 || n > 4096 || wavelength_dims[0] == 0) {
        throw InputError(fmt::format(
            "HDF5 file '{}': /image/intensity: {} x {} pixels, {} wavelengths; expected 9..4096 "
            "rows (an imaging scatterometer's range) and at least one wavelength",
            path.string(), n, n, wavelength_dims[0]));
    }
    const record::Dataset wavelengths = file.dataset("wavelength_nm");
    require_values(file, "wavelength_nm", wavelengths, huang_wavelength,
                   "a wavelength in 300..800 nm (the model's dispersion data)");
    const record::Dataset intensity = file.dataset("image/intensity");
    require_values(file, "image/intensity", intensity, finite,
                   "a finite intensity, 1/sr (negative ones: background-subtracted data)");
    const record::Dataset error = file.dataset("image/standard_error");
    require_values(file, "image/standard_error", error, finite_non_negative,
                   "a finite standard error >= 0, 1/sr");
    const record::Dataset omega = file.dataset("image/solid_angle_sr");
    require_values(file, "image/solid_angle_sr", omega, finite_non_negative,
                   "a finite solid angle >= 0, sr");
    c.image_size = static_cast<int>(n);
    c.wavelengths_nm = wavelengths.values;
    s.scatterer = "record " + path.filename().string();
    s.intensity = intensity.values;
    s.standard_error = error.values;
    s.solid_angle_sr = omega.values;
    return s;
}

}  // namespace plumage::analysis
