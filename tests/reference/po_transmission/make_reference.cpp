// Writes the full-wave reference for physical optics' transmission (README.md beside this
// file): σ(θ_s) and the widths of the cross-sections of structures.h at θ_i = 30°, from the
// suite's own full-wave level (sim/fullwave). Not run in CI (about an hour on one core for the
// two main cases); the committed CSVs are what the tests read.
//   plumage_po_transmission_reference --out DIR --case CASE [--resolution PX_PER_UM]
//       [--lateral-scale S] [--tilt DEG] [--raise UM] [--lambda NM ...] [--single-grid]
// CASE: film_over_melanin, semi_transparent_body, free_arc, free_flat_film or
// flat_film_over_melanin (the last three, any --lateral-scale other than 1, which stretches the
// case along x, --tilt, which turns flat_film_over_melanin's film, and --raise, which lifts that
// film or film_over_melanin's arc, are the widths study's; such a case is written as CASE_xS,
// CASE_tiltT, CASE_raiseR or their combination, in that order). By default the run takes
// 450/550/650 nm on two grids, RESOLUTION and 1.5 × RESOLUTION; --single-grid keeps RESOLUTION
// only. The files are written whole at the end.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include "sim/fullwave/full_wave_2d.h"
#include "tests/reference/po_transmission/structures.h"

namespace fw = plumage::sim::fullwave;
namespace ref = plumage::reference::po_transmission;

struct Options {
    std::filesystem::path out;
    std::string name;
    double coarse = 40.0, lateral = 1.0, tilt = 0.0, raise = 0.0;
    std::vector<double> lambdas = ref::kLambdasNm;
    bool single_grid = false;
};

void add_options(CLI::App& app, Options& o) {
    app.add_option("--out", o.out, "output folder")->required();
    app.add_option("--case", o.name, "cross-section")
        ->required()
        ->check(CLI::IsMember({"film_over_melanin", "semi_transparent_body", "free_arc",
                               "free_flat_film", "flat_film_over_melanin"}));
    app.add_option("--resolution", o.coarse, "px/µm of the coarser grid")
        ->check(CLI::Range(10.0, 400.0));
    app.add_option("--lateral-scale", o.lateral, "stretch along x (structures.h)")
        ->check(CLI::Range(1.0, 10.0));
    app.add_option("--tilt", o.tilt, "flat_film_over_melanin's film turned, degrees")
        ->check(CLI::Range(-20.0, 20.0));
    app.add_option("--raise", o.raise, "the film (or film_over_melanin's arc) lifted, µm")
        ->check(CLI::Range(0.0, 5.0));
    app.add_option("--lambda", o.lambdas, "wavelengths, nm")->check(CLI::Range(380.0, 780.0));
    app.add_flag("--single-grid", o.single_grid, "one grid, --resolution");
}

// The case's full-wave cross-section; nullopt (after saying why) for --tilt or --raise on a case
// that has none.
std::optional<fw::CrossSection2d> cross_section(const Options& o) {
    if ((o.tilt != 0.0 && o.name != "flat_film_over_melanin") ||
        (o.raise != 0.0 && o.name != "flat_film_over_melanin" && o.name != "film_over_melanin")) {
        std::fprintf(stderr,
                     "--tilt applies to flat_film_over_melanin only, --raise also to "
                     "film_over_melanin\n");
        return std::nullopt;
    }
    if (o.name == "film_over_melanin") return ref::film_over_melanin_fullwave(o.lateral, o.raise);
    if (o.name == "semi_transparent_body") return ref::semi_transparent_body_fullwave(o.lateral);
    if (o.name == "free_arc") return ref::free_arc_fullwave(o.lateral);
    if (o.name == "free_flat_film") return ref::free_flat_film_fullwave(o.lateral);
    return ref::flat_film_over_melanin_fullwave(o.lateral, o.tilt, o.raise);
}

// CASE_xS, CASE_tiltT, CASE_raiseR or their combination (header).
std::string case_key(const Options& o) {
    std::string key = o.lateral == 1.0 ? o.name : fmt::format("{}_x{:g}", o.name, o.lateral);
    if (o.tilt != 0.0) key += fmt::format("_tilt{:g}", o.tilt);
    if (o.raise != 0.0) key += fmt::format("_raise{:g}", o.raise);
    return key;
}

// Every grid and polarisation: the rows of far_field_KEY.csv and totals_KEY.csv.
std::pair<std::string, std::string> run(const fw::CrossSection2d& section, const Options& o,
                                        const std::string& key) {
    constexpr double kDeg = std::numbers::pi / 180.0;
    std::vector<double> theta;
    for (int m = 0; m < 720; ++m) theta.push_back((-179.5 + 0.5 * m) * kDeg);
    std::vector<double> grids{o.coarse};
    if (!o.single_grid) grids.push_back(1.5 * o.coarse);
    std::ostringstream far, totals;
    for (const double res : grids) {
        for (const auto pol : {fw::Polarisation2d::te, fw::Polarisation2d::tm}) {
            fw::FullWave2dOptions options;
            options.resolution_px_per_um = res;
            options.threads = 1;
            const fw::FullWave2dResult r = fw::full_wave_far_field(
                section, pol, ref::kThetaIDeg * kDeg, o.lambdas, theta, options);
            const std::string p(plumage::sim::wave::polarisation_name(pol));
            for (const fw::FarField2d& f : r.wavelengths) {
                for (std::size_t m = 0; m < theta.size(); ++m)
                    far << fmt::format(
                        "{},{},{:g},{:g},{:g},{:g},{:.6g}\n", key, p, ref::kThetaIDeg, f.lambda_nm,
                        res, -179.5 + 0.5 * static_cast<double>(m), f.sigma_um_per_rad[m]);
                totals << fmt::format(
                    "{},{},{:g},{:g},{:g},{:.6g},{:.6g},{:.6g},{:.6g},{:g},{:.1f}\n", key, p,
                    ref::kThetaIDeg, f.lambda_nm, res, f.back_scattering_width_um,
                    f.scattering_width_um, f.absorption_width_um, f.extinction_width_um,
                    f.time_steps, r.seconds);
            }
            std::fprintf(stderr, "%s %s at %g px/um: %.0f s (%zu cells)\n", key.c_str(), p.c_str(),
                         res, r.seconds, r.grid_cells);
        }
    }
    return {far.str(), totals.str()};
}

void write(const std::filesystem::path& out, const std::string& key, const std::string& far,
           const std::string& totals) {
    std::filesystem::create_directories(out);
    std::ofstream(out / ("far_field_" + key + ".csv"))
        << "case,polarisation,theta_i_deg,lambda_nm,resolution_px_per_um,theta_s_deg,"
           "sigma_um_per_rad\n"
        << far;
    std::ofstream(out / ("totals_" + key + ".csv"))
        << "case,polarisation,theta_i_deg,lambda_nm,resolution_px_per_um,back_scattering_width_um,"
           "scattering_width_um,absorption_width_um,extinction_width_um,time_steps,run_wall_s\n"
        << totals;
}

int main(int argc, char** argv) {
    CLI::App app{"Full-wave reference for physical optics through transparent interfaces"};
    Options o;
    add_options(app, o);
    CLI11_PARSE(app, argc, argv);
    const std::optional<fw::CrossSection2d> section = cross_section(o);
    if (!section) return 2;
    const std::string key = case_key(o);
    const auto [far, totals] = run(*section, o, key);
    write(o.out, key, far, totals);
    return 0;
}
