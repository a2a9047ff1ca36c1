// `plumage fit --model huang2022|filip2024 DATA`: a model fitted to the user's measured data
// (layouts: analysis/fits/user_data.h, docs/user_data.md), written into <results root>/<name>/
// (staged, replaced atomically like a study's folder):
//   parameters.json   the fitted parameters with σ, units, ranges; fit quality; provenance
//                     (analysis/fits/fit_summary.h; documented in docs/user_data.md)
//   residuals.h5      the residual map's data: (model − data)/σ per panel, with the axes
//   residuals.png     the map (plots.py `fit_residuals`), one panel per wavelength
//   residuals.csv     filip2024: every observation with its model value, σ and residual
//   report.md         the parameters' table, χ²/dof, the figure, the command line
//
// A subcommand rather than a study kind: a fit takes one data file and a handful of choices
// (model, start, fixed parameters), as `plumage geometry` takes one file; it has no instrument,
// no seed, nothing to measure or resume, so a study file would only restate the command line.
//
// huang2022 fits a scatterogram (an imaging-scatterometer record): its forward model is the
// pixel's integral over the R band's hard edges (analysis/fits/huang2022_fit.h); point BRDF samples
// of Huang's R lobe are a box in the parameters and are refused with that reason. filip2024 fits
// BRDF data: a CSV table or a goniometer record.
#pragma once

#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "analysis/fits/fit_summary.h"

namespace plumage::studies {

struct FitCommand {
    std::string model;                    // "huang2022" or "filip2024"
    std::filesystem::path data;           // the data file
    std::string name;                     // results folder; empty: fit_<model>_<data stem>
    std::string preset;                   // filip2024: start from this preset (default parrot)
    std::map<std::string, double> start;  // parameter name → starting value (table units)
    std::vector<std::string> fixed;       // held at their starting value
    std::vector<std::string> free;        // freed (filip2024: theta_max, brdf_scale are fixed)
    int pixel_stride = 1;                 // huang2022: fit every n-th pixel on the diagonals
};

struct FitCommandResult {
    std::filesystem::path output_dir;
    analysis::FitSummary summary;
};

// InputError (nothing written) for bad data, an unknown parameter or model.
FitCommandResult run_fit_command(const FitCommand& command,
                                 const std::filesystem::path& results_root);

}  // namespace plumage::studies
