#include "studies/figure_data.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <span>

#include <fmt/format.h>

#include "common/constants.h"
#include "common/error.h"
#include "virtual_gonio/display_colour.h"

namespace plumage::studies {
namespace {

using Dims = std::vector<std::uint64_t>;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

double degrees(double radians) { return radians / kDeg; }

// Colour and luminance of a run of spectra (each `nl` values), and the largest luminance.
struct Colours {
    std::vector<optics::Xyz> xyz;
    double peak = 0.0;
};
Colours colours_of(const std::vector<double>& wavelengths_nm, const double* spectra,
                   std::size_t count, const std::vector<bool>& inside = {}) {
    const gonio::SpectrumToDisplay display(wavelengths_nm);
    const std::size_t nl = wavelengths_nm.size();
    Colours c;
    c.xyz.assign(count, optics::Xyz{0.0, 0.0, 0.0});
    for (std::size_t i = 0; i < count; ++i) {
        if (!inside.empty() && !inside[i]) continue;
        c.xyz[i] = display.xyz(std::span<const double>(spectra + i * nl, nl));
        c.peak = std::max(c.peak, c.xyz[i].y);
    }
    return c;
}

// Display sRGB (count × 3 floats) and luminance (count doubles; NaN where not `inside`).
void display_images(const Colours& c, double exposure, const std::vector<bool>& inside,
                    std::vector<float>& srgb, std::vector<double>& luminance) {
    srgb.assign(c.xyz.size() * 3, 0.0f);
    luminance.assign(c.xyz.size(), kNaN);
    for (std::size_t i = 0; i < c.xyz.size(); ++i) {
        if (!inside.empty() && !inside[i]) continue;
        const auto rgb = display_srgb(c.xyz[i], exposure);
        std::copy(rgb.begin(), rgb.end(), srgb.begin() + static_cast<std::ptrdiff_t>(3 * i));
        luminance[i] = c.xyz[i].y;
    }
}

double exposure_for(double white) { return white > 0.0 ? 1.0 / white : 1.0; }

const char* kSrgbDescription =
    "display sRGB in [0, 1] (D65, CIE 1931; exposure: /@white_luminance_per_sr maps to white; "
    "over-range colours scaled by their largest component), [row, column, rgb]";

// Which pixels of a scatterogram lie on the hemisphere's disc, and their directions' polar
// angle and azimuth in degrees (NaN outside).
struct PixelDirections {
    std::vector<bool> inside;
    std::vector<double> theta_deg, phi_deg;
};

PixelDirections pixel_directions(const gonio::Scatterogram& s) {
    const int n = s.config.image_size;
    PixelDirections d{std::vector<bool>(s.pixels()), std::vector<double>(s.pixels(), kNaN),
                      std::vector<double>(s.pixels(), kNaN)};
    for (int row = 0; row < n; ++row) {
        for (int column = 0; column < n; ++column) {
            const std::size_t p = static_cast<std::size_t>(row) * n + column;
            const auto w = s.direction(column, row);
            d.inside[p] = w.has_value() && s.solid_angle_sr[p] > 0.0;
            if (!d.inside[p]) continue;
            d.theta_deg[p] = degrees(std::acos(std::clamp(w->z(), -1.0, 1.0)));
            d.phi_deg[p] = degrees(std::atan2(w->y(), w->x()));
        }
    }
    return d;
}

// The `figure/` group's map attributes: title, exposure, the mapping and the beam's direction.
void write_map_frame(record::Hdf5Writer& h5, const gonio::Scatterogram& s, const std::string& title,
                     double white, const std::string& exposure_rule) {
    h5.create_group("figure");
    h5.set_attribute("/figure", "title", title);
    h5.set_attribute("/figure", "white_luminance_per_sr", white);
    h5.set_attribute("/figure", "exposure_rule", exposure_rule);
    h5.set_attribute("/figure", "mapping",
                     "azimuthal equidistant: u right, v up in [-1, 1], theta = 90 deg * hypot(u, "
                     "v), phi = atan2(v, u) from +x (the barb axis) towards +y; row 0 at the top");
    h5.set_attribute("/figure", "beam_theta_deg",
                     degrees(std::acos(std::clamp(s.config.beam_direction.z(), -1.0, 1.0))));
    h5.set_attribute("/figure", "beam_phi_deg",
                     degrees(std::atan2(s.config.beam_direction.y(), s.config.beam_direction.x())));
}

// Each pixel's ϑ and φ (degrees, NaN outside the disc) into `figure/`.
void write_pixel_directions(record::Hdf5Writer& h5, const PixelDirections& grid, int n) {
    const std::uint64_t un = static_cast<std::uint64_t>(n);
    h5.write("figure/theta_deg", std::span<const double>(grid.theta_deg), Dims{un, un},
             {{"units", "deg"},
              {"description", "polar angle of each pixel centre, [row, column]; NaN outside"}});
    h5.write("figure/phi_deg", std::span<const double>(grid.phi_deg), Dims{un, un},
             {{"units", "deg"},
              {"description",
               "azimuth of each pixel centre from +x (barb axis) towards +y, [row, column]; NaN "
               "outside"}});
}

}  // namespace

std::array<float, 3> display_srgb(const optics::Xyz& xyz, double exposure) {
    const optics::Rgb c = gonio::display_linear(xyz, exposure);
    return {static_cast<float>(optics::srgb_encode(c[0])),
            static_cast<float>(optics::srgb_encode(c[1])),
            static_cast<float>(optics::srgb_encode(c[2]))};
}

void write_scatterogram_figure(record::Hdf5Writer& h5, const gonio::Scatterogram& simulation,
                               const gonio::Scatterogram& model, const std::string& title) {
    PLUMAGE_CHECK(simulation.pixels() == model.pixels() &&
                      simulation.config.wavelengths_nm == model.config.wavelengths_nm,
                  "scatterograms differ in size or wavelengths");
    const int n = simulation.config.image_size;
    const std::size_t pixels = simulation.pixels();
    const PixelDirections grid = pixel_directions(simulation);
    const std::vector<bool>& inside = grid.inside;
    const auto& wl = simulation.config.wavelengths_nm;
    const Colours cs = colours_of(wl, simulation.intensity.data(), pixels, inside);
    const Colours cm = colours_of(wl, model.intensity.data(), pixels, inside);
    const double white = std::max(cs.peak, cm.peak);
    std::vector<float> srgb_s, srgb_m;
    std::vector<double> y_s, y_m;
    display_images(cs, exposure_for(white), inside, srgb_s, y_s);
    display_images(cm, exposure_for(white), inside, srgb_m, y_m);
    std::vector<double> difference(pixels, kNaN);
    for (std::size_t p = 0; p < pixels; ++p)
        if (inside[p]) difference[p] = y_s[p] - y_m[p];

    write_map_frame(h5, simulation, title, white,
                    "one exposure for both images: the brighter of the two peak luminances maps "
                    "to white");
    const std::uint64_t un = static_cast<std::uint64_t>(n);
    const std::string source =
        fmt::format("simulation ({}) and model ({})", simulation.scatterer, model.scatterer);
    h5.write("figure/simulation_srgb", std::span<const float>(srgb_s), Dims{un, un, 3},
             {{"units", "1"}, {"description", std::string("simulation: ") + kSrgbDescription}});
    h5.write("figure/model_srgb", std::span<const float>(srgb_m), Dims{un, un, 3},
             {{"units", "1"}, {"description", std::string("model: ") + kSrgbDescription}});
    h5.write("figure/simulation_luminance", std::span<const double>(y_s), Dims{un, un},
             {{"units", "1/sr"},
              {"description",
               "simulation: luminance Y (D65) of the radiant intensity per unit incident power, "
               "[row, column]; NaN outside the disc"}});
    h5.write("figure/model_luminance", std::span<const double>(y_m), Dims{un, un},
             {{"units", "1/sr"},
              {"description",
               "model: luminance Y (D65) of the radiant intensity per unit incident power, "
               "[row, column]; NaN outside the disc"}});
    h5.write("figure/difference_luminance", std::span<const double>(difference), Dims{un, un},
             {{"units", "1/sr"},
              {"description", "signed luminance difference Y_simulation - Y_model of " + source +
                                  ", [row, column]; NaN outside the disc"}});
    write_pixel_directions(h5, grid, n);
}

void write_scatterogram_panels(record::Hdf5Writer& h5, const std::string& title,
                               const std::vector<ScatterogramPanel>& panels) {
    PLUMAGE_CHECK(!panels.empty(), "a scatterogram figure needs a panel");
    const gonio::Scatterogram& first = *panels.front().scatterogram;
    const std::size_t pixels = first.pixels();
    const PixelDirections grid = pixel_directions(first);
    std::vector<Colours> colours;
    double white = 0.0;
    for (const ScatterogramPanel& p : panels) {
        const gonio::Scatterogram& s = *p.scatterogram;
        PLUMAGE_CHECK(
            s.pixels() == pixels && s.config.wavelengths_nm == first.config.wavelengths_nm,
            "scatterograms differ in size or wavelengths");
        colours.push_back(
            colours_of(s.config.wavelengths_nm, s.intensity.data(), pixels, grid.inside));
        white = std::max(white, colours.back().peak);
    }
    write_map_frame(h5, first, title, white,
                    "one exposure for every panel: the brightest panel's peak luminance maps to "
                    "white");
    h5.set_integer_attribute("/figure", "panels", static_cast<std::int64_t>(panels.size()));
    const std::uint64_t un = static_cast<std::uint64_t>(first.config.image_size);
    for (std::size_t k = 0; k < panels.size(); ++k) {
        std::vector<float> srgb;
        std::vector<double> y;
        display_images(colours[k], exposure_for(white), grid.inside, srgb, y);
        const std::string group = fmt::format("figure/panel{}", k);
        h5.create_group(group);
        h5.set_attribute("/" + group, "title", panels[k].title);
        h5.set_attribute("/" + group, "scatterer", panels[k].scatterogram->scatterer);
        h5.set_attribute("/" + group, "peak_luminance_per_sr", colours[k].peak);
        h5.write(group + "/srgb", std::span<const float>(srgb), Dims{un, un, 3},
                 {{"units", "1"}, {"description", panels[k].title + ": " + kSrgbDescription}});
        h5.write(group + "/luminance", std::span<const double>(y), Dims{un, un},
                 {{"units", "1/sr"},
                  {"description", panels[k].title +
                                      ": luminance Y (D65) of the radiant intensity per unit "
                                      "incident power, [row, column]; NaN outside the disc"}});
    }
    write_pixel_directions(h5, grid, first.config.image_size);
}

void write_fingerprint_figure(const std::filesystem::path& path, const std::string& title,
                              const std::vector<FingerprintPanel>& panels, int lights, int views) {
    PLUMAGE_CHECK(!panels.empty(), "a fingerprint figure needs a panel");
    const auto& pairs = panels.front().record->config.pairs;
    const std::size_t cells = static_cast<std::size_t>(lights) * static_cast<std::size_t>(views);
    std::vector<Colours> colours;
    double white = 0.0;
    for (const FingerprintPanel& p : panels) {
        PLUMAGE_CHECK(p.record->config.pairs.size() == cells,
                      fmt::format("fingerprint {} x {} of {} pairs", lights, views,
                                  p.record->config.pairs.size()));
        colours.push_back(
            colours_of(p.record->config.wavelengths_nm, p.record->value.data(), cells));
        white = std::max(white, colours.back().peak);
    }
    record::Hdf5Writer h5(path);
    std::vector<double> light_angles, view_angles;
    auto angles = [](const Vec3d& w) {
        return std::array<double, 2>{degrees(std::acos(std::clamp(w.z(), -1.0, 1.0))),
                                     degrees(std::atan2(w.y(), w.x()))};
    };
    for (int l = 0; l < lights; ++l) {
        const auto a = angles(pairs[static_cast<std::size_t>(l) * views].wi);
        light_angles.insert(light_angles.end(), a.begin(), a.end());
    }
    for (int v = 0; v < views; ++v) {
        const auto a = angles(pairs[static_cast<std::size_t>(v)].wo);
        view_angles.insert(view_angles.end(), a.begin(), a.end());
    }
    const auto ul = static_cast<std::uint64_t>(lights), uv = static_cast<std::uint64_t>(views);
    h5.write("light_angles_deg", std::span<const double>(light_angles), Dims{ul, 2},
             {{"units", "deg"},
              {"description",
               "theta and phi (from +x, the barb axis) of each fingerprint row's "
               "light direction"}});
    h5.write("view_angles_deg", std::span<const double>(view_angles), Dims{uv, 2},
             {{"units", "deg"},
              {"description", "theta and phi of each fingerprint column's view direction"}});
    for (std::size_t k = 0; k < panels.size(); ++k) {
        std::vector<float> srgb;
        std::vector<double> y;
        display_images(colours[k], exposure_for(white), {}, srgb, y);
        const std::string g = fmt::format("panel{}", k);
        h5.write(g + "/srgb", std::span<const float>(srgb), Dims{ul, uv, 3},
                 {{"units", "1"}, {"description", kSrgbDescription}});
        h5.write(g + "/luminance", std::span<const double>(y), Dims{ul, uv},
                 {{"units", "1/sr"},
                  {"description",
                   "luminance Y (D65) of the BRDF averaged over each detector cone, [light, "
                   "view]"}});
        h5.set_attribute("/" + g, "title", panels[k].title);
        h5.set_attribute("/" + g, "scatterer", panels[k].record->scatterer);
        h5.set_attribute("/" + g, "peak_luminance_per_sr", colours[k].peak);
    }
    h5.set_integer_attribute("/", "panels", static_cast<std::int64_t>(panels.size()));
    h5.set_attribute("/", "title", title);
    h5.set_attribute("/", "white_luminance_per_sr", white);
    h5.set_attribute("/", "exposure_rule",
                     "one exposure for every panel: the brightest cell of any panel maps to white");
    h5.commit();
}

void write_btf_figure(const std::filesystem::path& path, const std::string& title,
                      const gonio::BtfRecord& btf, const std::vector<std::size_t>& pairs) {
    const int n = btf.config.pixels;
    const std::size_t per_tile = static_cast<std::size_t>(n) * static_cast<std::size_t>(n);
    std::vector<Colours> colours;
    double white = 0.0;
    for (const std::size_t p : pairs) {
        colours.push_back(colours_of(btf.config.wavelengths_nm,
                                     btf.value.data() + btf.index(p, 0, 0, 0), per_tile));
        white = std::max(white, colours.back().peak);
    }
    std::vector<float> srgb;
    std::vector<double> luminance, angles;
    for (std::size_t k = 0; k < pairs.size(); ++k) {
        std::vector<float> s;
        std::vector<double> y;
        display_images(colours[k], exposure_for(white), {}, s, y);
        srgb.insert(srgb.end(), s.begin(), s.end());
        luminance.insert(luminance.end(), y.begin(), y.end());
        const auto& pair = btf.config.pairs[pairs[k]];
        for (const Vec3d& w : {pair.wi, pair.wo}) {
            angles.push_back(degrees(std::acos(std::clamp(w.z(), -1.0, 1.0))));
            angles.push_back(degrees(std::atan2(w.y(), w.x())));
        }
    }
    const auto nt = static_cast<std::uint64_t>(pairs.size()), un = static_cast<std::uint64_t>(n);
    record::Hdf5Writer h5(path);
    h5.write("srgb", std::span<const float>(srgb), Dims{nt, un, un, 3},
             {{"units", "1"},
              {"description", std::string("[tile, row, column, rgb]: ") + kSrgbDescription +
                                  "; x right, y up (virtual_gonio/btf.h), row 0 at the top"}});
    h5.write("luminance", std::span<const double>(luminance), Dims{nt, un, un},
             {{"units", "1/sr"},
              {"description", "luminance Y (D65) of each pixel's BRDF, [tile, row, column]"}});
    h5.write("angles_deg", std::span<const double>(angles), Dims{nt, 4},
             {{"units", "deg"},
              {"description",
               "theta_light, phi_light, theta_view, phi_view of each tile (phi "
               "from +x, the barb axis)"}});
    h5.set_attribute("/", "title", title);
    h5.set_attribute("/", "patch_size_um", btf.config.patch_size_um);
    h5.set_integer_attribute("/", "pixels", n);
    h5.set_attribute("/", "white_luminance_per_sr", white);
    h5.set_attribute("/", "exposure_rule",
                     "one exposure for every tile: the brightest pixel of any tile maps to white");
    h5.commit();
}

void write_instrument_curves_figure(const std::filesystem::path& path,
                                    const std::vector<double>& wavelengths,
                                    const gonio::InstrumentResult& result) {
    const Dims n{wavelengths.size()};
    record::Hdf5Writer h5(path);
    h5.write("wavelength_nm", std::span<const double>(wavelengths), n,
             {{"units", "nm"}, {"description", "vacuum wavelength"}});
    for (std::size_t k = 0; k < result.curves.size(); ++k) {
        const auto& c = result.curves[k];
        PLUMAGE_CHECK(
            c.value.size() == wavelengths.size() && c.standard_error.size() == wavelengths.size(),
            "a curve's length differs from the wavelengths'");
        const std::string group = fmt::format("curves/{}", k);
        h5.write(group + "/value", std::span<const double>(c.value), n,
                 {{"units", "1"}, {"description", c.label}});
        h5.write(group + "/standard_error", std::span<const double>(c.standard_error), n,
                 {{"units", "1"}, {"description", "Monte Carlo standard error of " + c.label}});
        h5.set_attribute("/" + group, "label", c.label);
    }
    h5.set_attribute("/", "title", result.curves_title);
    h5.set_attribute("/", "quantity", result.curves_quantity);
    h5.set_attribute("/", "curves", static_cast<double>(result.curves.size()));
    h5.commit();
}

}  // namespace plumage::studies
