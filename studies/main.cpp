// The plumage command line. With no arguments it runs the default study.
#include <omp.h>

#include <fstream>
#include <iostream>
#include <sstream>

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include "common/error.h"
#include "common/version.h"
#include "studies/default_study.h"
#include "virtual_gonio/interrupt.h"
#include "studies/geometry_study.h"
#include "studies/ablation_study.h"
#include "studies/extremes_study.h"
#include "studies/masking_study.h"
#include "studies/rock_dove_study.h"
#include "studies/species_study.h"
#include "studies/study_file.h"
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
                 "With no subcommand, runs the default study: explicit rock-dove barbules against\n"
                 "Huang et al. 2022 (studies/rock_dove.toml), into results/rock_dove/."};
    app.set_version_flag("--version", std::string("plumage ") + plumage::kVersion);
    int threads = 0;
    app.add_option("--threads", threads, "worker threads (default: all cores)")
        ->check(CLI::NonNegativeNumber);

    plumage::studies::ThinFilmChartOptions thin_film;
    std::string output = "results";
    plumage::studies::RunLimits limits;
    app.add_option("--time-budget", limits.time_budget_s,
                   "wall-time budget in seconds for each progressive measurement of a study")
        ->check(CLI::PositiveNumber);
    app.add_option("--target-error", limits.target_relative_error,
                   "stop each measurement once its estimated relative RMS error is below this (e.g. 0.05)")
        ->check(CLI::Range(0.0, 1.0));
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

    std::string run_study;
    auto* run_cmd = app.add_subcommand("run", "run a study file (TOML; studies/*.toml)");
    run_cmd->add_option("STUDY", run_study, "study file, e.g. studies/rock_dove_quick.toml")->required();
    run_cmd->fallthrough();  // `plumage run FILE --out DIR` as well as `plumage --out DIR run FILE`

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
        if (thin_film_cmd->parsed()) {
            thin_film.output_dir = std::filesystem::path(output) / "thin_film";
            return run_thin_film(thin_film);
        }
        std::string text = plumage::studies::kDefaultStudy;
        std::filesystem::path source = "rock_dove.toml (built in)";
        if (run_cmd->parsed()) {
            std::ifstream in(run_study);
            if (!in) throw plumage::InputError(run_study + ": cannot open the study file (does it exist?)");
            std::ostringstream buffer;
            buffer << in.rdbuf();
            text = buffer.str();
            source = run_study;
            // Which study: the top-level `study` key (geometry files use `plumage geometry`).
            auto file = plumage::studies::StudyFile::parse(text, source);
            auto root = file->root();
            const std::string kind = root.required_string("study", {"rock_dove", "ablation", "extremes", "species", "masking"},
                                                          "which study this file describes");
            if (kind == "ablation") {
                const auto r = plumage::studies::run_ablation_study(text, source, output);
                std::cout << fmt::format("plumage: wrote {} in {:.0f} s ({} values skipped; open report.md)\n",
                                         r.output_dir.string(), r.wall_seconds, r.skipped);
                return 0;
            }
            if (kind == "species") {
                const plumage::gonio::ScopedInterruptHandler interrupt;
                limits.interrupt = &interrupt.flag();
                const auto r = plumage::studies::run_species_study(text, source, output, true, limits);
                std::cout << fmt::format("plumage: wrote {} in {:.0f} s (open report.md)\n", r.output_dir.string(),
                                         r.wall_seconds);
                for (const auto& o : r.species) {
                    std::cout << fmt::format("  {}: Filip fit reduced chi2 {:.2f}, relative L1 {:.1f} % (Table 1: {:.1f} %), "
                                             "reciprocity chi2/dof {:.2f}\n",
                                             o.species, o.reduced_chi_square, 100.0 * o.fit_relative_l1,
                                             100.0 * o.table1_relative_l1,
                                             o.reciprocity_chi_square / std::max(1, o.reciprocity_dof));
                }
                return 0;
            }
            if (kind == "masking") {
                const auto r = plumage::studies::run_masking_study(text, source, output);
                std::cout << fmt::format(
                    "plumage: wrote {} in {:.0f} s: {} configuration(s) x {} angles, max "
                    "|analytic - MC| {:.2e}, max |z| {:.3f} (Sidak bound {:.2f}): {} (open "
                    "report.md)\n",
                    r.output_dir.string(), r.wall_seconds, r.configurations.size(),
                    r.angles_deg.size(), r.max_abs_difference, r.max_abs_z, r.z_bound,
                    r.agrees ? "agrees" : "DISAGREES");
                return 0;
            }
            if (kind == "extremes") {
                const auto r = plumage::studies::run_extremes_study(text, source, output);
                std::cout << fmt::format("plumage: wrote {} in {:.0f} s: numerical violations {}, energy > 1 {}, "
                                         "energy > 1 by the published model's construction {} (open report.md)\n",
                                         r.output_dir.string(), r.wall_seconds, r.numerical_violations,
                                         r.energy_violations, r.by_construction);
                return 0;
            }
        }
        const plumage::gonio::ScopedInterruptHandler interrupt;
        limits.interrupt = &interrupt.flag();
        const auto result = plumage::studies::run_rock_dove_study(text, source, output, true, limits);
        std::cout << fmt::format("plumage: wrote {} in {:.0f} s (open report.md)\n", result.output_dir.string(),
                                 result.wall_seconds);
        return 0;
    } catch (const plumage::studies::Interrupted& e) {
        std::cerr << "plumage: " << e.what() << '\n';
        return 130;
    } catch (const plumage::InputError& e) {
        std::cerr << "plumage: error: " << e.what() << '\n';
        return 2;
    } catch (const std::exception& e) {
        std::cerr << "plumage: failed: " << e.what() << '\n';
        return 1;
    }
}
