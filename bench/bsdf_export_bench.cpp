// How well an exported .bsdf follows its model between the table's nodes (issue 41,
// acceptance 7), today's NDF against the model's own, in one run: for each source, the export
// at the given grid with the retro-reflection NDF estimate (what every export had before) and
// with the model's own NDF mixed in at each --share (default: the export's; Huang 2022's arc of
// barbule normals; a Filip model has none, so its exports are the same), each file read back
// through our reader (which follows Mitsuba 3's `measured`) and compared with the model at 3000
// seeded random pairs, θ ≤ 75°: median and 95th percentile of |f_file/f − 1|, Σ|Δf| cos θ / Σ f cos
// θ, the worst pair, the file's size and its tabulation time. Not a Google Benchmark program: the
// figures are a table, not a rate.
//
//   build-h/bench/plumage_bench_bsdf_export [SOURCE …] [--theta-nodes N] [--phi-nodes N]
//       [--resolution N] [--first-nm A] [--last-nm B] [--step-nm S] [--share X …]
//
// SOURCE as for `plumage export-bsdf` (default: huang2022); the grid defaults are the export's
// (10 θ × 25 φ × 32², 400–700 nm every 20 nm).
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include <fmt/core.h>

#include "studies/bsdf_export.h"

namespace {

namespace fs = std::filesystem;
using plumage::studies::BsdfExportOptions;

int run(int argc, char** argv) {
    BsdfExportOptions base;
    std::vector<std::string> sources;
    std::vector<double> shares;
    for (int k = 1; k < argc; ++k) {
        const std::string arg = argv[k];
        const auto next = [&] {
            if (k + 1 >= argc) throw std::runtime_error(arg + ": expected a value");
            return std::atof(argv[++k]);
        };
        if (arg == "--theta-nodes") {
            base.theta_nodes = static_cast<int>(next());
        } else if (arg == "--phi-nodes") {
            base.phi_nodes = static_cast<int>(next());
        } else if (arg == "--resolution") {
            base.resolution = static_cast<int>(next());
        } else if (arg == "--step-nm") {
            base.step_nm = next();
        } else if (arg == "--first-nm") {
            base.first_nm = next();
        } else if (arg == "--last-nm") {
            base.last_nm = next();
        } else if (arg == "--share") {
            shares.push_back(next());
        } else {
            sources.push_back(arg);
        }
    }
    if (sources.empty()) sources = {"huang2022"};
    if (shares.empty()) shares = {0.0, BsdfExportOptions{}.model_ndf_share};
    const fs::path folder =
        fs::temp_directory_path() / ("plumage_bsdf_export_bench_" + std::to_string(::getpid()));
    fs::create_directories(folder);
    std::printf(
        "| source | NDF | grid | median | 95th pct | Σ f cos θ-weighted | worst | size (MB) | "
        "tabulation (s) |\n|---|---|---|---|---|---|---|---|---|\n");
    for (const std::string& source : sources) {
        for (const double share : shares) {
            BsdfExportOptions o = base;
            o.source = source;
            o.model_ndf_share = share;
            o.output =
                folder / fmt::format("{}_{}.bsdf", share, fs::path(source).filename().string());
            const auto result = plumage::studies::export_bsdf(o);
            for (const auto& r : result.reports) {
                std::printf(
                    "| %s | %s | %d θ × %d φ × %d², %.0f–%.0f nm every %.0f | %.2f %% | "
                    "%.1f %% | %.1f %% | %.3g× | %.1f | %.1f |\n",
                    r.model.c_str(),
                    share == 0.0 ? "retro estimate"
                                 : fmt::format("model's {:.2g} + retro", share).c_str(),
                    o.theta_nodes, o.phi_nodes, o.resolution, o.first_nm, o.last_nm, o.step_nm,
                    100 * r.error.median, 100 * r.error.p95, 100 * r.error.weighted, r.error.worst,
                    static_cast<double>(r.bytes) / 1e6, r.tabulate_seconds);
                std::fflush(stdout);
            }
        }
    }
    std::error_code ignored;
    fs::remove_all(folder, ignored);
    return 0;
}

}  // namespace

int main(int argc, char** argv) {
    try {
        return run(argc, argv);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "plumage_bench_bsdf_export: %s\n", e.what());
        return 1;
    }
}
