#include "analysis/user_data.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <fstream>
#include <map>
#include <numbers>
#include <optional>
#include <sstream>

#include <fmt/format.h>

#include "common/error.h"
#include "virtual_gonio/hdf5_file.h"

namespace plumage::analysis {
namespace {

namespace fs = std::filesystem;

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
        if (!(l > 0.0)) {
            throw InputError(fmt::format("{}:{}: wavelength_nm = {}: expected > 0 nm", where,
                                         c.wavelength + 1, l));
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

record::Dataset dataset(const fs::path& path, const std::string& name, std::size_t rank) {
    record::Dataset d;
    try {
        d = record::read_dataset(path, name);
    } catch (const Error& e) {
        throw InputError(fmt::format("{}: cannot read the dataset /{} ({}); docs/user_data.md",
                                     path.string(), name, e.what()));
    }
    if (d.dims.size() != rank) {
        throw InputError(fmt::format("{}: /{} has {} dimensions, expected {}", path.string(), name,
                                     d.dims.size(), rank));
    }
    return d;
}

void require_file(const fs::path& path) {
    if (!fs::is_regular_file(path))
        throw InputError(fmt::format("{}: no such file", path.string()));
}

}  // namespace

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
    require_file(path);
    const record::Dataset lights = dataset(path, "instrument/light_directions", 2);
    const record::Dataset views = dataset(path, "instrument/view_directions", 2);
    const record::Dataset wavelengths = dataset(path, "wavelength_nm", 1);
    const record::Dataset value = dataset(path, "brdf/value", 2);
    const record::Dataset error = dataset(path, "brdf/standard_error", 2);
    const std::size_t pairs = lights.dims[0], nl = wavelengths.dims[0];
    if (lights.dims[1] != 3 || views.dims != lights.dims || value.dims[0] != pairs ||
        value.dims[1] != nl || error.dims != value.dims) {
        throw InputError(
            fmt::format("{}: expected light and view directions [pairs, 3], /brdf/value and "
                        "/brdf/standard_error [pairs, wavelengths]: the shapes do not match",
                        path.string()));
    }
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
            data.observations.push_back(
                {wi, wo, std::nullopt, wavelengths.values[l], value.values[p * nl + l], sigma});
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
    try {
        return record::read_string_attribute(path, "/instrument", "kind");
    } catch (const Error& e) {
        throw InputError(fmt::format("{}: not a plumage record (no /instrument@kind: {})",
                                     path.string(), e.what()));
    }
}

BrdfData read_brdf_data(const fs::path& path) {
    const std::string kind = data_kind(path);
    if (kind == "csv") return read_brdf_csv(path);
    if (kind == "goniometer") return read_brdf_record(path);
    throw InputError(
        fmt::format("{}: a {} record; expected BRDF data (a goniometer record or a "
                    "CSV table)",
                    path.string(), kind));
}

gonio::Scatterogram read_scatterogram_record(const fs::path& path) {
    const std::string kind = data_kind(path);
    if (kind != "imaging_scatterometer") {
        throw InputError(
            fmt::format("{}: a {} {}; expected a scatterogram (an imaging-scatterometer record)",
                        path.string(), kind, kind == "csv" ? "table" : "record"));
    }
    gonio::Scatterogram s;
    gonio::ScatterometerConfig& c = s.config;
    const std::string illumination =
        record::read_string_attribute(path, "/instrument", "illumination");
    if (illumination == "beam")
        c.illumination = gonio::Illumination::beam;
    else if (illumination == "cone")
        c.illumination = gonio::Illumination::cone;
    else if (illumination == "hemisphere")
        c.illumination = gonio::Illumination::hemisphere;
    else {
        throw InputError(
            fmt::format("{}: /instrument@illumination = '{}': expected beam, cone or "
                        "hemisphere",
                        path.string(), illumination));
    }
    // The beam's (and the cone's axis) direction; the hemisphere needs none.
    if (c.illumination != gonio::Illumination::hemisphere) {
        std::istringstream beam(
            record::read_string_attribute(path, "/instrument", "beam_direction"));
        double x = 0, y = 0, z = 0;
        if (!(beam >> x >> y >> z) || !(z > 0.0)) {
            throw InputError(fmt::format(
                "{}: /instrument@beam_direction: expected \"x y z\" towards the light, z > 0",
                path.string()));
        }
        c.beam_direction = Vec3d(x, y, z).normalized();
    }
    if (c.illumination == gonio::Illumination::cone) {
        c.cone_aperture_rad =
            record::read_number_attribute(path, "/instrument", "cone_aperture_deg") *
            std::numbers::pi / 180.0;
    }
    const record::Dataset wavelengths = dataset(path, "wavelength_nm", 1);
    const record::Dataset intensity = dataset(path, "image/intensity", 3);
    const record::Dataset error = dataset(path, "image/standard_error", 3);
    const record::Dataset omega = dataset(path, "image/solid_angle_sr", 2);
    const std::uint64_t n = intensity.dims[0];
    if (intensity.dims[1] != n || intensity.dims[2] != wavelengths.dims[0] ||
        error.dims != intensity.dims || omega.dims[0] != n || omega.dims[1] != n) {
        throw InputError(
            fmt::format("{}: expected /image/intensity and /image/standard_error "
                        "[rows, rows, wavelengths], /image/solid_angle_sr [rows, "
                        "rows]: the shapes do not match",
                        path.string()));
    }
    c.image_size = static_cast<int>(n);
    c.wavelengths_nm = wavelengths.values;
    s.scatterer = "record " + path.filename().string();
    s.intensity = intensity.values;
    s.standard_error = error.values;
    s.solid_angle_sr = omega.values;
    return s;
}

}  // namespace plumage::analysis
