// `plumage export-bsdf`: an analytic model of a study, with the parameters the study fitted,
// tabulated as an RGL tensor ".bsdf" (virtual_gonio/rgl_bsdf.h) for Mitsuba 3's `measured`
// BSDF and pbrt-v4's "measured" material. Glue only: the tabulation lives in virtual_gonio/.
//
// Sources:
//   <results>/<rock dove study>/fit/huang2022_fit.h5   Huang 2022 with fit/values
//                                                        → huang2022_fit.bsdf beside it
//   <results>/<species study>/species.h5               Filip 2024 with /<species>/fit/values
//                                                        → <species>_filip2024.bsdf beside it
//     (fitted in the instrument frame, where the barb axis lies at /<species>@mount_deg: the
//     model is turned by that angle so that every file is in the patch frame, barb axis +x)
//   huang2022                                           the published rock-dove parameters
//   filip2024:<preset>                                  a Table 1 preset (parrot, rooster, …)
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "virtual_gonio/rgl_bsdf.h"

namespace plumage::studies {

struct BsdfExportOptions {
    std::string source;
    std::filesystem::path output;  // file or (species.h5) folder; empty: beside the source
    // θ_i nodes over [0°, 85°] and φ_i nodes over [−180°, 180°] (1: isotropic); 0: the model's
    // own grid (model_grid below), chosen for the stated between-node error kTargetMedianError.
    int theta_nodes = 0;
    int phi_nodes = 0;
    int resolution = 32;  // N × N sample square
    double first_nm = 400.0, last_nm = 700.0, step_nm = 20.0;
    // Replace an existing regular file that plumage did not write (never a device, folder or
    // link: those are always refused).
    bool force = false;
    // The NDF that places the sample square's nodes, for a model that has its own (Huang
    // 2022's arc of barbule normals): the share of the model's NDF in a mixture with Dupuy &
    // Jakob's retro-reflection estimate (RglBsdfSettings::model_ndf_share). 0, the estimate
    // alone, as every export had: the model's own NDF was measured worse between the nodes
    // (Huang at the default grid, 550 nm: median 3.2 % → 4.0 % at share 0.25; 400–500 nm:
    // 2.8 % → 4.5 % at 0.5; bench/README.md), as it crowds the nodes into the R band and leaves
    // the TRT lobe, most of the pairs, fewer. Filip 2024 has the estimate alone.
    double model_ndf_share = 0.0;
    // Each file is read back and compared with its model at this many seeded random pairs
    // (θ ≤ 75°, kCheckSeed): median, 95th percentile and Σ f cos θ-weighted error printed.
    int check_pairs = 3000;
    // The energy check: each model's directional albedo (analysis/metrics/energy.h) at 21
    // directions θ_i ≤ 75° and up to 3 of the wavelengths, by quadrature over this many polar cells
    // per hemisphere (its cost: 2 × 2n² × 9 evaluations per direction and wavelength).
    int albedo_polar_cells = 16;
    bool progress = true;  // progress lines on stderr, "plumage: [  12.3 s] what"
};

// The stated between-node accuracy of an export: a file whose median relative error at the
// check's pairs exceeds it gets a warning naming the options that refine its grid.
constexpr double kTargetMedianError = 0.02;

// The angular grid a model is exported on when the options leave it to the model (0 nodes).
// Filip 2024's broad lobes: 10 θ_i × 25 φ_i nodes (15°) give medians of 0.7–0.8 % between nodes
// (parrot, flamingo). Huang 2022's R band is narrow and moves with ω_i, so the incident grid,
// not the sample square or the wavelength step, sets its error: 10 × 25 gives 2.6 % (95th
// percentile 68 %), 19 × 49 gives 1.4 % (bench/README.md, plumage_bench_bsdf_export), at 3.7
// times the file size (80 MB over 400–700 nm in 20 nm steps) and tabulation time.
struct AngularGrid {
    int theta_nodes, phi_nodes;
};
constexpr AngularGrid kFilipGrid{10, 25}, kHuangGrid{19, 49};
constexpr double kCheckMaxThetaDeg = 75.0;
constexpr std::uint64_t kCheckSeed = 41;

struct BsdfFileReport {
    std::filesystem::path file;
    std::string model;  // the source (source:species for a species study)
    double tabulate_seconds = 0.0;
    std::uintmax_t bytes = 0;
    gonio::InterpolationError error;  // read back against the model
    // Directional albedo (reflection and transmission, analysis/metrics/energy.h) at 21 directions
    // θ_i ≤ 75°, the largest over the checked wavelengths; directions above 1 beyond the
    // quadrature's error.
    double max_albedo = 0.0;
    int albedo_directions = 0, directions_above_one = 0;
    std::vector<std::string> warnings;  // also printed, and the albedo one is in the file
};

struct BsdfExportResult {
    std::vector<std::filesystem::path> files;
    std::vector<BsdfFileReport> reports;  // one per file, in the same order
    double wall_seconds = 0.0;
};

// InputError (before anything is written) for an unknown source, a file without the fit's
// datasets or one HDF5 cannot read, bad options, tables over the memory limit
// (common/memory_limit.h), an output that is not a new path or a .bsdf plumage wrote (see
// `force`) or in a folder where no file can be created; each file is written atomically.
// Warnings (albedo above 1, between-node error above the target) are printed and reported,
// never fatal.
BsdfExportResult export_bsdf(const BsdfExportOptions& options);

}  // namespace plumage::studies
