// Full wave computed live as the judge of a periodic row: the reflectance R(λ) of one period's
// bodies (full_wave_row, full_wave_2d.h), TE and TM, on two grids, in the form the cheaper
// levels are judged by (wave::RowReflectanceFullWave, sim/wave/compare/levels_against_full_wave.h).
//
//  - Grids: r and 1.5 r (subpixel smoothing on), each refined to a whole, even number of cells
//    per period by full_wave_row. The resolution error is the coarse grid's band-mean R over
//    the fine one's, minus 1 (judge_row_against_full_wave states it); the fine run's own error is
//    at most about twice that for an error falling at least as fast as the grid step
//    (docs/full_wave.md). A reference whose |resolution error| exceeds the caller's tolerance is
//    unconverged: it must not judge anything (the caller says so).
//  - Normal incidence: one run per polarisation and grid for all wavelengths, the materials as
//    Lorentz poles fitted over the band (Dispersion::fitted; the largest index error of a fit
//    is in the result). Oblique: one run per wavelength with the indices exact there
//    (full_wave_row's rule: the Bloch wavenumber depends on the wavelength).
//  - The four (polarisation, grid) runs go on `threads` threads at once, largest first; each is
//    serial. Results do not depend on the thread count.
//  - Cost before any work: the cells of every run (row_reference_cost), from which a caller with
//    a time budget predicts the seconds at a rate it measures (seconds per cell-run: one
//    cell for one run to the decay rule, which sets the steps).
//
// Parameter table:
//  | name                 | unit | range                                                  |
//  |----------------------|------|--------------------------------------------------------|
//  | period_um            | µm   | >= four grid cells, <= 1000 (full_wave_row)            |
//  | theta_i_rad          | rad  | within ±80°                                            |
//  | resolution_px_per_um | 1/µm | >= the λ/(10 n) rule of the bodies (full_wave_2d.h)    |
//  | decay                | 1    | in (0, 1e-2]                                           |
#pragma once

#include <atomic>
#include <cstddef>
#include <span>
#include <vector>

#include "sim/fullwave/cross_section_2d.h"
#include "sim/wave/compare/levels_against_full_wave.h"

namespace plumage::sim::fullwave {

// One thread's seconds per cell-run (one grid cell taken through one run to the decay rule), the
// prior of callers that predict a run's time from row_reference_cost before running anything:
// the committed rock-dove row reference (tests/reference/fullwave_rock_dove_row), 5 995 s of
// runs over 2.12 M cell-runs (TE and TM at 45 and 67.5 px/µm, decay 1e-5, fitted dispersion),
// on 2 loaded cores. A row that rings longer costs more per cell.
inline constexpr double kReferenceSecondsPerCellRun = 2.83e-3;

struct RowReferenceRequest {
    double resolution_px_per_um = 45.0;  // the coarse grid; the fine one is 1.5 times finer
    double decay = 1e-5;                 // FullWave2dOptions::decay
    const std::atomic<bool>* stop = nullptr;
    int threads = 0;  // 0: OpenMP's default; at most the four runs are used
};

struct RowReferenceCost {
    std::size_t coarse_cells = 0, fine_cells = 0;  // one run's grid
    std::size_t runs_per_grid = 0;                 // per polarisation: 1, or one per wavelength
    double cell_runs = 0.0;  // Σ over every run of its cells (both polarisations, both grids)
};

// InputError as full_wave_row's checks (a grid coarser than λ/(10 n), a body thinner than two
// cells, an angle beyond 80°), raised before any run.
RowReferenceCost row_reference_cost(const CrossSection2d& period, double period_um,
                                    double theta_i_rad, std::span<const double> lambdas_nm,
                                    const RowReferenceRequest& request);

struct RowReference {
    std::vector<wave::RowReflectanceFullWave> reflectance;  // per wavelength, in increasing order
    double coarse_px_per_um = 0.0, fine_px_per_um = 0.0;    // the grids run (refined)
    double max_fit_index_error = 0.0;  // the fitted runs' worst |Δ(n + ik)|; 0 when exact
    double max_time_steps = 0.0;       // of the longest run
    double seconds = 0.0;              // wall time of the four runs
    RowReferenceCost cost;
};

// `lambdas_nm` increasing. Interrupted (common/interrupt.h) when the stop flag is set.
RowReference row_reference(const CrossSection2d& period, double period_um, double theta_i_rad,
                           std::span<const double> lambdas_nm, const RowReferenceRequest& request);

}  // namespace plumage::sim::fullwave
