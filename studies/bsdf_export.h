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

#include <filesystem>
#include <string>
#include <vector>

namespace plumage::studies {

struct BsdfExportOptions {
    std::string source;
    std::filesystem::path output;  // file or (species.h5) folder; empty: beside the source
    int theta_nodes = 10;          // θ_i nodes over [0°, 85°]
    int phi_nodes = 25;            // φ_i nodes over [−180°, 180°] (15°); 1: isotropic
    int resolution = 32;           // N × N sample square
    double first_nm = 400.0, last_nm = 700.0, step_nm = 20.0;
    // Replace an existing regular file that plumage did not write (never a device, folder or
    // link: those are always refused).
    bool force = false;
};

struct BsdfExportResult {
    std::vector<std::filesystem::path> files;
    double wall_seconds = 0.0;
};

// InputError (before anything is written) for an unknown source, a file without the fit's
// datasets, bad options, tables over the memory limit (common/memory_limit.h) or an output that
// is not a new path or a .bsdf plumage wrote (see `force`); each file is written atomically.
BsdfExportResult export_bsdf(const BsdfExportOptions& options);

}  // namespace plumage::studies
