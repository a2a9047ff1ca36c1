// The plumage command line. With no arguments it runs the default study.
#include <omp.h>

#include <iostream>

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include "common/error.h"
#include "common/version.h"
#include "studies/geometry_study.h"
#include "studies/thin_film_chart.h"

namespace {

int run_thin_film(const plumage::studies::ThinFilmChartOptions& options) {
    std::cerr << fmt::format("plumage: thin-film study → {}\n", options.output_dir.string());
    const auto result = plumage::studies::run_thin_film_chart(options);
    std::cout << fmt::format("plumage: wrote {} in {:.1f} s (report: {})\n",
                             result.output_dir.string(), result.wall_seconds,
                             (result.output_dir / "report.md").string());
    for (const auto& c : result.normal_incidence) {
        std::cout << fmt::format("  {} nm film{}: L*a*b* = ({:.1f}, {:.1f}, {:.1f}), hue {:.0f}°\n",
                                 c.thickness_nm, c.with_melanin_background ? " + melanin" : "",
                                 c.lab.l, c.lab.a, c.lab.b, c.hue_deg);
    }
    return 0;
}

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"Plumage: light scattering by bird-feather microstructures.\n"
                 "With no subcommand, runs the default study (thin-film colour chart)."};
    app.set_version_flag("--version", std::string("plumage ") + plumage::kVersion);
    int threads = 0;
    app.add_option("--threads", threads, "worker threads (default: all cores)")
        ->check(CLI::NonNegativeNumber);

    plumage::studies::ThinFilmChartOptions thin_film;
    std::string output = "results";
    app.add_option("--out", output, "results root folder")->capture_default_str();

    auto* thin_film_cmd = app.add_subcommand(
        "thin-film", "Huang 2022 Figs. 3 and 5: keratin film colour chart and rock-dove spectra");
    thin_film_cmd->add_option("--thickness-step-nm", thin_film.thickness_step_nm)
        ->capture_default_str()->check(CLI::PositiveNumber);
    thin_film_cmd->add_option("--angle-step-deg", thin_film.angle_step_deg)
        ->capture_default_str()->check(CLI::PositiveNumber);
    thin_film_cmd->add_option("--max-thickness-nm", thin_film.max_thickness_nm)
        ->capture_default_str()->check(CLI::PositiveNumber);
    thin_film_cmd->add_flag("!--no-plots", thin_film.plots, "skip the matplotlib figures");

    std::string geometry_study;
    auto* geometry_cmd = app.add_subcommand(
        "geometry", "build the geometry of a study file; write PLY/VDB, a PNG preview and a report");
    geometry_cmd->add_option("STUDY", geometry_study, "study file (TOML), e.g. studies/geometry/rock_dove_row.toml")
        ->required();

    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        return app.exit(e);
    }
    if (threads > 0) omp_set_num_threads(threads);

    try {
        if (geometry_cmd->parsed()) {
            const auto result = plumage::studies::run_geometry_study(geometry_study, output);
            std::cout << fmt::format("plumage: wrote {} ({}: {} triangles, {} instances, {:.2f} MB) in {:.1f} s\n",
                                     result.output_dir.string(), result.kind, result.triangles, result.instances,
                                     static_cast<double>(result.memory_bytes) / 1e6, result.wall_seconds);
            return 0;
        }
        thin_film.output_dir = std::filesystem::path(output) / "thin_film";
        // thin-film is also the default study until the rock-dove study arrives.
        return run_thin_film(thin_film);
    } catch (const plumage::InputError& e) {
        std::cerr << "plumage: error: " << e.what() << '\n';
        return 2;
    } catch (const std::exception& e) {
        std::cerr << "plumage: failed: " << e.what() << '\n';
        return 1;
    }
}
