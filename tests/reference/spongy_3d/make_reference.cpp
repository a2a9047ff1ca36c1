// Writes one structure's rows of the 3D spongy full-wave reference (README.md beside this file):
// the normal-incidence specular and diffuse reflectance and transmittance of a 2 µm slab of the
// structure (structures.h), periodic laterally, in air, at two resolutions, from the suite's own
// full-wave level (sim/fullwave/full_wave_slab.h, Meep's C++ library). Not run in CI (minutes to
// tens of minutes per structure on one core); the committed CSV is what the test reads.
//   plumage_spongy3d_reference OUT_CSV KIND N_KERATIN SEED COARSE_PX_PER_UM STOP [GRIDS]
// KIND: channel | air_spheres | keratin_spheres; keratin a constant index N_KERATIN (no
// dispersion, no loss), so that the media routes compare on the structure alone; E_x only
// (Slab3d::e_x_only: the mean over seeds is the unpolarised mean); 400–700 nm every 10 nm in one
// run per grid; grids COARSE and 1.5 × COARSE px/µm, or (GRIDS = coarse) COARSE alone, or
// (GRIDS = only=R) R px/µm alone; STOP: decay=D, stop when the field under the slab has fallen
// to D of its peak, or decay=D,max_time=T, also stop T time units (µm/c) after the source has
// ended (full_wave_slab.h, "Stop").
#include <algorithm>
#include <atomic>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "sim/fullwave/full_wave_slab.h"
#include "structures.h"

namespace fw = plumage::sim::fullwave;
namespace s3 = plumage::reference::spongy3d;

namespace {
std::atomic<bool> g_stop{false};
extern "C" void on_signal(int) { g_stop = true; }

// STOP: decay=D or decay=D,max_time=T; the CSV's stop_rule cell is the same text without a comma.
struct StopRule {
    double decay = 0.0, max_time = 0.0;
    std::string csv_cell;
};

std::optional<StopRule> parse_stop(const std::string& stop) {
    if (stop.rfind("decay=", 0) != 0) return std::nullopt;
    const std::size_t comma = stop.find(",max_time=");
    StopRule r;
    r.decay = std::stod(stop.substr(6, comma == std::string::npos ? std::string::npos : comma - 6));
    r.max_time = comma == std::string::npos ? 0.0 : std::stod(stop.substr(comma + 10));
    r.csv_cell = stop;
    std::replace(r.csv_cell.begin(), r.csv_cell.end(), ',', ' ');
    return r;
}
}  // namespace

int main(int argc, char** argv) {
    if (argc != 7 && argc != 8) {
        std::fprintf(stderr,
                     "usage: %s OUT_CSV channel|air_spheres|keratin_spheres N_KERATIN SEED "
                     "COARSE_PX_PER_UM decay=D[,max_time=T] [coarse|only=R]\n",
                     argv[0]);
        return 2;
    }
    std::signal(SIGINT, on_signal);
    std::signal(SIGTERM, on_signal);
    const std::filesystem::path out = argv[1];
    const s3::Kind kind = s3::kind_from(argv[2]);
    const double n_keratin = std::stod(argv[3]);
    const auto seed = static_cast<std::uint64_t>(std::stoull(argv[4]));
    const double coarse = std::stod(argv[5]);
    const std::string stop = argv[6];
    const std::optional<StopRule> rule = parse_stop(stop);
    if (!rule) {
        std::fprintf(stderr, "STOP: expected decay=D or decay=D,max_time=T, got %s\n",
                     stop.c_str());
        return 2;
    }
    const std::string grids_arg = argc == 8 ? argv[7] : "";
    const s3::Structure structure = s3::make_structure(kind, seed);

    fw::Slab3d slab;
    slab.period_um = s3::kPeriodUm;
    slab.thickness_um = s3::kThicknessUm;
    slab.thinnest_um = structure.thinnest_um;
    slab.inside = structure.keratin;
    slab.material = std::make_shared<plumage::optics::ConstantMaterial>(
        fmt::format("keratin n={:g}", n_keratin), n_keratin);
    slab.e_x_only = true;
    std::vector<double> lambdas;
    for (int l = 400; l <= 700; l += 10) lambdas.push_back(l);

    // each grid's rows are in the file (under a temporary name until the last) once it is done;
    // a run refused or stopped before its first grid leaves no file
    const std::filesystem::path tmp = out.string() + ".part";
    bool started = false;
    std::vector<double> grids{coarse, 1.5 * coarse};
    if (grids_arg == "coarse") grids = {coarse};
    if (grids_arg.rfind("only=", 0) == 0) grids = {std::stod(grids_arg.substr(5))};
    for (const double res : grids) {
        fw::FullWave2dOptions o;
        o.resolution_px_per_um = res;
        o.pml_um = 0.6;
        o.gap_um = 0.25;
        o.decay = rule->decay;
        o.max_time = rule->max_time;
        o.threads = 1;
        o.dispersion = fw::Dispersion::fitted;
        o.stop = &g_stop;
        const fw::FullWaveSlabResult r = fw::full_wave_slab(slab, lambdas, o);
        std::ofstream f(tmp, started ? std::ios::app : std::ios::trunc);
        if (!started)
            f << "structure,n_keratin,seed,resolution_px_per_um,keratin_fraction,lambda_nm,"
                 "specular_reflectance,diffuse_reflectance,specular_transmittance,"
                 "diffuse_transmittance,grid_cells,time_steps,run_wall_s,stop_rule\n";
        started = true;
        for (const fw::SlabSpectrum& w : r.wavelengths)
            f << fmt::format(
                "{},{:g},{},{:g},{:.4f},{:g},{:.6g},{:.6g},{:.6g},{:.6g},{},{:.0f},"
                "{:.0f},{}\n",
                s3::kind_name(kind), n_keratin, seed, res, structure.keratin_fraction, w.lambda_nm,
                w.specular_reflectance, w.diffuse_reflectance, w.specular_transmittance,
                w.diffuse_transmittance, r.grid_cells, r.time_steps, r.seconds, rule->csv_cell);
        std::fprintf(stderr, "%s n=%g seed %llu at %g px/um: %zu cells, %.0f steps, %.0f s\n",
                     std::string(s3::kind_name(kind)).c_str(), n_keratin,
                     static_cast<unsigned long long>(seed), res, r.grid_cells, r.time_steps,
                     r.seconds);
    }
    std::filesystem::rename(tmp, out);
    return 0;
}
