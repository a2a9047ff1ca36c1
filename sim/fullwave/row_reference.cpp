#include "sim/fullwave/row_reference.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>

#include "common/error.h"
#include "common/require.h"
#include "sim/fullwave/full_wave_2d.h"
#include "sim/fullwave/meep_solver.h"

namespace plumage::sim::fullwave {
namespace {

constexpr double kFineOverCoarse = 1.5;

// The options of one grid's runs: fitted dispersion at normal incidence (one run for every
// wavelength), exact indices per wavelength otherwise (full_wave_row refuses fitted there).
FullWave2dOptions grid_options(const RowReferenceRequest& request, double theta_i_rad,
                               double factor) {
    FullWave2dOptions o;
    o.resolution_px_per_um = factor * request.resolution_px_per_um;
    o.decay = request.decay;
    o.stop = request.stop;
    o.threads = 1;
    o.dispersion = theta_i_rad == 0.0 ? Dispersion::fitted : Dispersion::per_wavelength;
    return o;
}

}  // namespace

RowReferenceCost row_reference_cost(const CrossSection2d& period, double period_um,
                                    double theta_i_rad, std::span<const double> lambdas_nm,
                                    const RowReferenceRequest& request) {
    require(!lambdas_nm.empty(), "full-wave row reference", "no wavelengths");
    RowReferenceCost cost;
    cost.runs_per_grid = theta_i_rad == 0.0 ? 1 : lambdas_nm.size();
    for (const double factor : {1.0, kFineOverCoarse}) {
        const FullWave2dOptions o = grid_options(request, theta_i_rad, factor);
        detail::check_options(period, lambdas_nm, o);
        const std::size_t cells = full_wave_row_cells(period, period_um, o);
        (factor == 1.0 ? cost.coarse_cells : cost.fine_cells) = cells;
        cost.cell_runs += 2.0 * static_cast<double>(cells * cost.runs_per_grid);
    }
    return cost;
}

RowReference row_reference(const CrossSection2d& period, double period_um, double theta_i_rad,
                           std::span<const double> lambdas_nm, const RowReferenceRequest& request) {
    RowReference out;
    out.cost = row_reference_cost(period, period_um, theta_i_rad, lambdas_nm, request);
    // Largest first (fine TM rings longest), so that two threads finish together.
    struct Job {
        Polarisation2d pol;
        double factor;
    };
    const std::array<Job, 4> jobs{{{Polarisation2d::tm, kFineOverCoarse},
                                   {Polarisation2d::te, kFineOverCoarse},
                                   {Polarisation2d::tm, 1.0},
                                   {Polarisation2d::te, 1.0}}};
    FullWave2dOptions outer;
    outer.threads = request.threads;
    const auto started = std::chrono::steady_clock::now();
    // Meep's verbosity is one global: held at 0 around all four runs, so that a run ending first
    // cannot restore it under another's (each run's own Quiet then saves and restores 0).
    const detail::Quiet quiet;
    const std::vector<FullWaveRowResult> runs =
        detail::run_all(jobs.size(), outer, [&](std::size_t j) {
            return full_wave_row(period, period_um, jobs[j].pol, theta_i_rad, lambdas_nm,
                                 grid_options(request, theta_i_rad, jobs[j].factor));
        });
    out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    out.reflectance.resize(lambdas_nm.size());
    for (std::size_t j = 0; j < jobs.size(); ++j) {
        const FullWaveRowResult& r = runs[j];
        const std::size_t pol = jobs[j].pol == Polarisation2d::te ? 0 : 1;
        const bool fine = jobs[j].factor != 1.0;
        (fine ? out.fine_px_per_um : out.coarse_px_per_um) = r.resolution_px_per_um;
        for (const LorentzFit& f : r.dispersion_fits)
            out.max_fit_index_error = std::max(out.max_fit_index_error, f.max_index_error);
        for (std::size_t k = 0; k < lambdas_nm.size(); ++k) {
            wave::RowReflectanceFullWave& w = out.reflectance[k];
            w.lambda_nm = lambdas_nm[k];
            (fine ? w.fine : w.coarse)[pol] = r.wavelengths[k].reflectance;
            out.max_time_steps = std::max(out.max_time_steps, r.wavelengths[k].time_steps);
        }
    }
    return out;
}

}  // namespace plumage::sim::fullwave
