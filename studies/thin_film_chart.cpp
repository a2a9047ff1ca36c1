#include "studies/thin_film_chart.h"

#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <iostream>
#include <numbers>

#include <fmt/format.h>

#include "common/error.h"
#include "common/interrupt.h"
#include "common/version.h"
#include "sim/optics/material.h"
#include "sim/optics/thin_film.h"
#include "studies/plots.h"
#include "studies/staged_directory.h"
#include "virtual_gonio/exr_image.h"
#include "virtual_gonio/record/hdf5_file.h"
#include "virtual_gonio/record/png_image.h"

namespace plumage::studies {
namespace {

using optics::Complex;

constexpr double kChartFirstNm = 380.0;
constexpr double kChartLastNm = 780.0;
constexpr double kFilmsNm[] = {530.0, 595.0};

std::vector<double> axis(double first, double last, double step) {
    std::vector<double> values;
    const auto count = static_cast<std::size_t>(std::floor((last - first) / step + 1e-9)) + 1;
    for (std::size_t i = 0; i < count; ++i) values.push_back(first + static_cast<double>(i) * step);
    return values;
}

void require_positive(double value, const char* key) {
    if (!std::isfinite(value) || !(value > 0.0)) {
        throw InputError(
            fmt::format("thin-film study: {} = {}: expected a finite value > 0", key, value));
    }
}

struct NormalIncidenceSpectra {
    std::vector<double> wavelength_nm;
    // [film][wavelength]
    std::vector<std::vector<double>> film_only, with_background;
};

// Huang Eqs. 1–3 at normal incidence, where s and p coincide.
NormalIncidenceSpectra normal_incidence_spectra(const optics::WavelengthGrid& grid) {
    const auto keratin = optics::keratin();
    const auto melanin = optics::melanin();
    NormalIncidenceSpectra out;
    out.wavelength_nm.assign(grid.nm().begin(), grid.nm().end());
    for (double d : kFilmsNm) {
        std::vector<double> r(grid.size()), total(grid.size());
        for (std::size_t k = 0; k < grid.size(); ++k) {
            const double lambda = grid[k];
            const optics::FilmMedia film{1.0, keratin->index(lambda), Complex(1.0)};
            const auto i = optics::airy_film_intensities(film, d / 1000.0, lambda, 1.0,
                                                         optics::Polarisation::s);
            const double r_am = optics::fresnel_intensities(1.0, melanin->index(lambda), 1.0,
                                                            optics::Polarisation::s)
                                    .reflectance;
            r[k] = i.reflectance;
            total[k] = i.reflectance + i.transmittance * r_am * i.transmittance;
        }
        out.film_only.push_back(std::move(r));
        out.with_background.push_back(std::move(total));
    }
    return out;
}

std::uint8_t to_byte(double encoded) {
    return static_cast<std::uint8_t>(std::lround(std::clamp(encoded, 0.0, 1.0) * 255.0));
}

// Display: exposure scale, negative (out-of-gamut) components clipped to 0, and values
// above 1 brought down by the largest component so the hue is kept.
optics::Rgb display_rgb(const optics::Xyz& xyz, double exposure) {
    optics::Rgb rgb =
        optics::linear_srgb_from_xyz({xyz.x * exposure, xyz.y * exposure, xyz.z * exposure});
    for (double& c : rgb) c = std::max(c, 0.0);
    const double peak = std::max({rgb[0], rgb[1], rgb[2]});
    if (peak > 1.0) {
        for (double& c : rgb) c /= peak;
    }
    return rgb;
}

std::string hex(const optics::Rgb& display) {
    return fmt::format("#{:02x}{:02x}{:02x}", to_byte(optics::srgb_encode(display[0])),
                       to_byte(optics::srgb_encode(display[1])),
                       to_byte(optics::srgb_encode(display[2])));
}

namespace fs = std::filesystem;

// The chart: Airy reflectance of air|keratin|air [angle][thickness][wavelength] and its colours.
struct Chart {
    std::vector<double> thickness, angle;
    optics::WavelengthGrid grid;
    std::vector<float> reflectance;
    std::vector<double> xyz;  // [angle][thickness][3]
    std::size_t nt = 0, na = 0, nl = 0;
};

Chart compute_chart(const ThinFilmChartOptions& options, const optics::WavelengthGrid& grid,
                    const optics::ReflectanceToXyz& chart_xyz) {
    Chart c{axis(0.0, options.max_thickness_nm, options.thickness_step_nm),
            axis(0.0, 90.0, options.angle_step_deg),
            grid,
            {},
            {}};
    c.nt = c.thickness.size(), c.na = c.angle.size(), c.nl = c.grid.size();
    std::vector<Complex> keratin_n(c.nl);
    for (std::size_t k = 0; k < c.nl; ++k) keratin_n[k] = optics::keratin()->index(c.grid[k]);
    c.reflectance.resize(c.na * c.nt * c.nl);
    c.xyz.resize(c.na * c.nt * 3);
    std::size_t rows_done = 0;
#pragma omp parallel for schedule(dynamic, 1)
    for (std::size_t a = 0; a < c.na; ++a) {
        if (interrupt_requested()) continue;  // Ctrl-C: the remaining rows are skipped, then thrown
        // cos(π/2) is 6e-17 in floating point; 90° means exactly grazing.
        const double cos_i =
            c.angle[a] == 90.0 ? 0.0 : std::cos(c.angle[a] * std::numbers::pi / 180.0);
        std::vector<double> spectrum(c.nl);
        for (std::size_t t = 0; t < c.nt; ++t) {
            for (std::size_t k = 0; k < c.nl; ++k) {
                const optics::FilmMedia film{1.0, keratin_n[k], Complex(1.0)};
                spectrum[k] = optics::airy_film_intensities_unpolarised(
                                  film, c.thickness[t] / 1000.0, c.grid[k], cos_i)
                                  .reflectance;
                c.reflectance[(a * c.nt + t) * c.nl + k] = static_cast<float>(spectrum[k]);
            }
            const optics::Xyz colour = chart_xyz(spectrum);
            c.xyz[(a * c.nt + t) * 3] = colour.x;
            c.xyz[(a * c.nt + t) * 3 + 1] = colour.y;
            c.xyz[(a * c.nt + t) * 3 + 2] = colour.z;
        }
#pragma omp critical(progress)
        {
            ++rows_done;
            if (options.progress &&
                (rows_done % std::max<std::size_t>(1, c.na / 10) == 0 || rows_done == c.na)) {
                std::cerr << fmt::format("  thin-film chart: {:3d} % ({} of {} angles)\n",
                                         100 * rows_done / c.na, rows_done, c.na);
            }
        }
    }
    throw_if_interrupted("the thin-film chart's colours");
    return c;
}

// The display exposure: the largest linear sRGB component of the whole chart maps to 1, so no
// colour is over range and display_rgb never rescales one. Why the whole chart: an exposure
// anchored below grazing (it was the brightest Y at ≤ 60°) sends the colours above the anchor
// over range, and display_rgb's rescaling by the largest component is a kink in the colour
// against angle. At one angle the luminance varies little with thickness, so much of every row
// went over range within a degree or two of the anchor (14 % of a row at 58°, 37 % at 60°) and
// the kinks lined up into a seam at 60°, which the reflectance itself (smooth in angle) lacks.
double chart_exposure(const Chart& c) {
    double max_component = 0.0;
    for (std::size_t i = 0; i < c.na * c.nt; ++i) {
        const optics::Rgb rgb =
            optics::linear_srgb_from_xyz({c.xyz[3 * i], c.xyz[3 * i + 1], c.xyz[3 * i + 2]});
        max_component = std::max({max_component, rgb[0], rgb[1], rgb[2]});
    }
    return 1.0 / max_component;
}

// Image rows: incidence 90° at the top, 0° at the bottom, as in a plot.
struct ChartImage {
    record::RgbImage image;
    std::vector<std::uint8_t> srgb8;
    std::vector<double> srgb_linear;
};
ChartImage chart_image(const Chart& c, double exposure) {
    ChartImage out{record::RgbImage(static_cast<int>(c.nt), static_cast<int>(c.na)),
                   std::vector<std::uint8_t>(c.na * c.nt * 3),
                   std::vector<double>(c.na * c.nt * 3)};
    for (std::size_t a = 0; a < c.na; ++a) {
        for (std::size_t t = 0; t < c.nt; ++t) {
            const std::size_t i = (a * c.nt + t) * 3;
            const optics::Xyz colour{c.xyz[i], c.xyz[i + 1], c.xyz[i + 2]};
            const optics::Rgb linear = optics::linear_srgb_from_xyz(colour);
            const optics::Rgb display = display_rgb(colour, exposure);
            for (int ch = 0; ch < 3; ++ch) {
                out.srgb_linear[i + ch] = linear[ch];
                out.srgb8[i + ch] = to_byte(optics::srgb_encode(display[ch]));
            }
            out.image.set(static_cast<int>(t), static_cast<int>(c.na - 1 - a), out.srgb8[i],
                          out.srgb8[i + 1], out.srgb8[i + 2]);
        }
    }
    return out;
}

// The chart's spectra as the pixel PNG lays them out (thickness across, 90° at the top).
gonio::SpectralImage chart_exr_image(const Chart& c) {
    gonio::SpectralImage image;
    image.name = "thin_film_chart";
    image.width = static_cast<int>(c.nt);
    image.height = static_cast<int>(c.na);
    image.wavelengths_nm.assign(c.grid.nm().begin(), c.grid.nm().end());
    image.quantity = gonio::SpectralImage::Quantity::reflective;
    image.units = std::string("1");  // move, not assign: GCC 12 -Wrestrict false positive
    image.quantity_description = "unpolarised Airy reflectance of air|keratin|air";
    image.description = fmt::format(
        "thin-film chart: keratin film thickness {} to {} nm left to right (column c: {} nm * "
        "c), incidence angle 90 deg at the top row to 0 deg at the bottom (row r: 90 deg - {} "
        "deg * r)",
        c.thickness.front(), c.thickness.back(), c.nt > 1 ? c.thickness[1] - c.thickness[0] : 0.0,
        c.na > 1 ? c.angle[1] - c.angle[0] : 0.0);
    image.values.resize(c.na * c.nt * c.nl);
    for (std::size_t a = 0; a < c.na; ++a) {
        const std::size_t row = c.na - 1 - a;
        for (std::size_t t = 0; t < c.nt; ++t) {
            for (std::size_t k = 0; k < c.nl; ++k)
                image.values[(row * c.nt + t) * c.nl + k] =
                    c.reflectance[(a * c.nt + t) * c.nl + k];
        }
    }
    return image;
}

// The named films' colours at normal incidence, with the chart grid's colour error.
std::vector<FilmColour> film_colours(const NormalIncidenceSpectra& spectra,
                                     const optics::ReflectanceToXyz& spectra_xyz,
                                     const optics::WavelengthGrid& chart_grid,
                                     const optics::ReflectanceToXyz& chart_xyz) {
    const NormalIncidenceSpectra on_chart_grid = normal_incidence_spectra(chart_grid);
    std::vector<FilmColour> colours;
    for (std::size_t f = 0; f < std::size(kFilmsNm); ++f) {
        for (bool background : {false, true}) {
            const auto& fine = background ? spectra.with_background[f] : spectra.film_only[f];
            const auto& coarse =
                background ? on_chart_grid.with_background[f] : on_chart_grid.film_only[f];
            FilmColour colour{};
            colour.thickness_nm = kFilmsNm[f];
            colour.with_melanin_background = background;
            colour.xyz = spectra_xyz(fine);
            colour.lab = optics::lab_from_xyz(colour.xyz, spectra_xyz.white());
            colour.hue_deg = optics::hue_angle_deg(colour.lab);
            colour.chroma = optics::chroma(colour.lab);
            colour.delta_e00_chart_grid = optics::ciede2000(
                colour.lab, optics::lab_from_xyz(chart_xyz(coarse), chart_xyz.white()));
            colours.push_back(colour);
        }
    }
    return colours;
}

void write_chart_datasets(record::Hdf5Writer& h5, const Chart& c, const ChartImage& img,
                          double exposure) {
    using Dims = std::vector<std::uint64_t>;
    h5.write("chart/thickness_nm", std::span<const double>(c.thickness), Dims{c.nt},
             {{"units", "nm"}, {"description", "keratin film thickness"}});
    h5.write("chart/incidence_deg", std::span<const double>(c.angle), Dims{c.na},
             {{"units", "deg"}, {"description", "incidence angle in air, from the film normal"}});
    h5.write("chart/wavelength_nm", c.grid.nm(), Dims{c.nl},
             {{"units", "nm"}, {"description", "vacuum wavelengths of the reflectance spectra"}});
    h5.write(
        "chart/reflectance", std::span<const float>(c.reflectance), Dims{c.na, c.nt, c.nl},
        {{"units", "1"},
         {"description",
          "unpolarised Airy reflectance of air|keratin|air, [incidence, thickness, wavelength]"}});
    h5.write("chart/xyz", std::span<const double>(c.xyz), Dims{c.na, c.nt, 3},
             {{"units", "1"},
              {"description", "CIE 1931 2-degree XYZ under D65, perfect reflector Y = 1"}});
    h5.write("chart/srgb_linear", std::span<const double>(img.srgb_linear), Dims{c.na, c.nt, 3},
             {{"units", "1"}, {"description", "linear sRGB of xyz, no exposure, not clipped"}});
    h5.write("chart/srgb8", std::span<const std::uint8_t>(img.srgb8), Dims{c.na, c.nt, 3},
             {{"units", "1/255"},
              {"description",
               "display sRGB (8 bit): exposure applied, negatives clipped, "
               "over-range scaled by the largest component"}});
    h5.set_attribute("/chart", "exposure", exposure);
    h5.set_attribute("/chart", "exposure_rule",
                     "the largest linear sRGB component of the chart maps to 1: no colour is "
                     "over range");
    h5.set_attribute("/chart", "illuminant", "D65");
    h5.set_attribute("/chart", "observer", "CIE 1931 2 degree");
}

void write_spectra_datasets(record::Hdf5Writer& h5, const NormalIncidenceSpectra& spectra) {
    using Dims = std::vector<std::uint64_t>;
    const std::uint64_t n = spectra.wavelength_nm.size();
    h5.write("spectra/wavelength_nm", std::span<const double>(spectra.wavelength_nm), Dims{n},
             {{"units", "nm"}, {"description", "vacuum wavelengths of the spectra"}});
    for (std::size_t f = 0; f < std::size(kFilmsNm); ++f) {
        const int d = static_cast<int>(kFilmsNm[f]);
        h5.write(fmt::format("spectra/R_{}nm", d), std::span<const double>(spectra.film_only[f]),
                 Dims{n},
                 {{"units", "1"},
                  {"description", "film reflectance I_R (Huang Eq. 2), normal incidence"}});
        h5.write(
            fmt::format("spectra/R_plus_TRT_{}nm", d),
            std::span<const double>(spectra.with_background[f]), Dims{n},
            {{"units", "1"}, {"description", "I_R + I_TRT (Huang Eqs. 2-3), melanin background"}});
    }
}

void write_spectra_csv(const fs::path& path, const NormalIncidenceSpectra& spectra) {
    std::ofstream csv(path);
    csv << "wavelength_nm";
    for (double d : kFilmsNm) csv << fmt::format(",R_{0}nm,R_plus_TRT_{0}nm", static_cast<int>(d));
    csv << '\n';
    for (std::size_t k = 0; k < spectra.wavelength_nm.size(); ++k) {
        csv << fmt::format("{}", spectra.wavelength_nm[k]);
        for (std::size_t f = 0; f < std::size(kFilmsNm); ++f) {
            csv << fmt::format(",{:.8f},{:.8f}", spectra.film_only[f][k],
                               spectra.with_background[f][k]);
        }
        csv << '\n';
    }
    if (!csv) throw IoError(fmt::format("cannot write {}", path.string()));
}

void write_report(const fs::path& path, const ThinFilmChartOptions& options, const Chart& c,
                  const ThinFilmChartResult& result, bool plotted) {
    std::ofstream md(path);
    md << "# Thin keratin films: colour chart and rock-dove spectra\n\n"
       << "Reproduces Huang et al. 2022, Fig. 3 (colour of a keratin film in air against "
          "thickness and incidence angle, D65) and Fig. 5 (normal-incidence reflectance of "
          "the rock dove's 530 nm and 595 nm keratin films, with and without the melanin "
          "background TRT).\n\n"
       << "Keratin n(λ) = 1.532 + 5890/λ², melanin n(λ) = 1.648 + 23700/λ² + "
          "0.56i·exp(−λ/270); unpolarised light; CIE 1931 2° observer.\n\n";
    if (plotted) {
        md << "![thin-film chart](thin_film_chart.png)\n\n"
           << "![normal-incidence spectra](spectra_normal_incidence.png)\n\n";
    } else {
        md << "![thin-film chart, one pixel per cell](thin_film_chart_pixels.png)\n\n";
    }
    md << fmt::format(
        "Chart: {} thicknesses (0–{} nm, step {} nm) × {} angles (step {}°), "
        "{} wavelengths ({}–{} nm, step {} nm). Display exposure ×{:.3f}, one for the whole "
        "chart: its largest linear sRGB component → 1, so no colour is clipped and brightness "
        "compares across the chart (at normal incidence films of 100 nm or more reflect "
        "1–16 % of D65's luminance, at grazing all of it).\n\n",
        c.nt, options.max_thickness_nm, options.thickness_step_nm, c.na, options.angle_step_deg,
        c.nl, kChartFirstNm, kChartLastNm, options.chart_wavelength_step_nm, result.exposure);
    md << "## Colours at normal incidence\n\n"
       << "| film | spectrum | L* | a* | b* | hue h_ab (°) | chroma | display sRGB | ΔE00 chart "
          "grid vs 1 nm |\n"
       << "|---|---|---|---|---|---|---|---|---|\n";
    for (const FilmColour& f : result.normal_incidence) {
        md << fmt::format(
            "| {} nm | {} | {:.2f} | {:.2f} | {:.2f} | {:.1f} | {:.2f} | {} | {:.3f} |\n",
            f.thickness_nm, f.with_melanin_background ? "R + TRT" : "R", f.lab.l, f.lab.a, f.lab.b,
            f.hue_deg, f.chroma, hex(display_rgb(f.xyz, result.exposure)), f.delta_e00_chart_grid);
    }
    md << fmt::format(
        "\nRun time {:.2f} s on {} threads (plumage {}). Files: "
        "thin_film_chart.h5 (all numbers, h5py/MATLAB), "
        "thin_film_chart_pixels.png (one pixel per cell, 90° at the top) and "
        "thin_film_chart_pixels.exr (its reflectance spectra, OpenEXR), "
        "spectra_normal_incidence.csv.\n",
        result.wall_seconds, omp_get_max_threads(), kVersion);
    if (!md) throw IoError(fmt::format("cannot write {}", path.string()));
}

std::string options_text(const ThinFilmChartOptions& options) {
    return fmt::format(
        "max_thickness_nm={} thickness_step_nm={} angle_step_deg={} chart_wavelength_step_nm={} "
        "spectra_wavelength_step_nm={}",
        options.max_thickness_nm, options.thickness_step_nm, options.angle_step_deg,
        options.chart_wavelength_step_nm, options.spectra_wavelength_step_nm);
}

}  // namespace

ThinFilmChartResult run_thin_film_chart(const ThinFilmChartOptions& options) {
    require_positive(options.max_thickness_nm, "max_thickness_nm");
    require_positive(options.thickness_step_nm, "thickness_step_nm");
    require_positive(options.angle_step_deg, "angle_step_deg");
    require_positive(options.chart_wavelength_step_nm, "chart_wavelength_step_nm");
    require_positive(options.spectra_wavelength_step_nm, "spectra_wavelength_step_nm");
    const auto start = std::chrono::steady_clock::now();
    const auto chart_grid = optics::WavelengthGrid::uniform(kChartFirstNm, kChartLastNm,
                                                            options.chart_wavelength_step_nm);
    const optics::ReflectanceToXyz chart_xyz(chart_grid, optics::Illuminant::d65);
    const Chart chart = compute_chart(options, chart_grid, chart_xyz);
    ThinFilmChartResult result;
    result.exposure = chart_exposure(chart);
    const ChartImage image = chart_image(chart, result.exposure);
    const auto spectra_grid = optics::WavelengthGrid::uniform(kChartFirstNm, kChartLastNm,
                                                              options.spectra_wavelength_step_nm);
    const optics::ReflectanceToXyz spectra_xyz(spectra_grid, optics::Illuminant::d65);
    const NormalIncidenceSpectra spectra = normal_incidence_spectra(spectra_grid);
    result.normal_incidence = film_colours(spectra, spectra_xyz, chart_grid, chart_xyz);

    StagedDirectory out(options.output_dir);
    const auto& dir = out.path();
    record::Hdf5Writer h5(dir / "thin_film_chart.h5");
    write_chart_datasets(h5, chart, image, result.exposure);
    write_spectra_datasets(h5, spectra);
    h5.set_attribute("/", "study", "thin_film");
    h5.set_attribute("/", "plumage_version", kVersion);
    h5.set_attribute("/", "threads", static_cast<double>(omp_get_max_threads()));
    h5.set_attribute(
        "/", "compute_wall_time_s",
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
    h5.set_attribute("/", "config", options_text(options));
    h5.commit();
    record::write_png(dir / "thin_film_chart_pixels.png", image.image);
    gonio::write_spectral_exr(dir / "thin_film_chart_pixels.exr", {chart_exr_image(chart)},
                              "thin_film");
    write_spectra_csv(dir / "spectra_normal_incidence.csv", spectra);
    bool plotted = false;  // a failed plot is a warning: the report then shows the pixel chart
    if (options.plots) {
        plotted = run_plot("chart", dir / "thin_film_chart.h5", dir / "thin_film_chart.png");
        plotted = run_plot("spectra", dir / "spectra_normal_incidence.csv",
                           dir / "spectra_normal_incidence.png") &&
                  plotted;
    }
    result.wall_seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    write_report(dir / "report.md", options, chart, result, plotted);
    out.commit();
    result.output_dir = out.final_path();
    return result;
}

}  // namespace plumage::studies
