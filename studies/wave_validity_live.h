// The wave-validity study's live full-wave judge (`[full_wave] live = true`): each scene of the
// maps (a barbule with one parameter changed, a width, an incidence) judged by full wave computed
// in the run, as far as a time budget allows.
//
// Per scene, the endless periodic row of its barbule (Huang's cell, spacing H·A, tilt μ; no
// jitter: a periodic row's light leaves in discrete orders, so the reflectance R(λ) into the
// upper half-space, all orders, unpolarised, is what the levels share):
//  - full wave: sim/fullwave/row_reference.h (fullwave::barbule_row's closed body: melanin core
//    under a uniform air shell g and keratin shell d), TE and TM on two grids; its resolution
//    error is the coarse band mean over the fine one's, minus 1;
//  - physical optics and ray optics + film: sim/wave/compare/levels_against_full_wave.h
//    (judge_row_against_full_wave: rows of 12 and 4 barbules, their ends cancelled);
//  - the GO–PO hybrid (physical_optics_hybrid_2d.h) on the same rows of the barbule with its gap
//    as separate curves (barbule_with_gap: full wave's body), after physical optics in cost;
//    where it refuses the row (curves closer than its sampling step), the reason is reported;
//  - errors: band mean over full wave's, minus 1, and the largest |R_level(λ)/R_FW(λ) − 1|.
// Verdict: the cheapest level whose band-mean error is within the threshold, else "full wave";
// no verdict when |resolution error| exceeds `tolerance` ("unconverged").
//
// Cost: before any run, each scene's cells (row_reference_cost) and a predicted time, cells ×
// a rate in seconds per cell-run over the threads used (4 runs at most at once): before the
// first run, the rate of the committed rock-dove row reference
// (fullwave::kReferenceSecondsPerCellRun), then the largest rate measured in this run. Scenes run
// cheapest first while the time spent plus the next prediction stays within the budget; the others
// are listed with their prediction.
#pragma once

#include <string>
#include <vector>

#include "studies/wave_validity_study.h"

namespace plumage::record {
class Hdf5Writer;
}

namespace plumage::studies {

class StudyProgress;

struct LiveFullWaveSettings {
    bool on = false;
    double resolution_px_per_um = 45.0;  // the coarse grid; the fine one is 1.5 times finer
    double decay = 1e-5;
    double budget_minutes = 30.0;
    double tolerance = 0.02;  // the largest |resolution error| of a reference that judges
};

struct LiveScene {
    std::string scene;  // "base" or "<axis> = <value>"
    double a_um = 0.0, b = 0.0, phi0 = 0.0, phi1 = 0.0, d = 0.0, g = 0.0, H = 0.0, mu = 0.0;
    double theta_i_deg = 0.0;
    std::string map_verdict;  // the map's PO − GO verdict at this point (jittered rows)
};

// Judges what the budget affords (header); the rate used last goes to `rate`.
std::vector<WaveValidityLivePoint> judge_live(const std::vector<LiveScene>& scenes,
                                              const std::vector<double>& lambdas_nm,
                                              const LiveFullWaveSettings& settings,
                                              double threshold, const StudyProgress& clock,
                                              double& rate);

// The report's verdict sentences, its section ("## Judged by full wave, live"), the record's
// group `full_wave_live/` and its CSV, and the figure data of the scene where physical optics
// misses most (nothing written when no scene was judged).
std::string live_verdict(const WaveValidityResult& r);
std::string live_section(const WaveValidityResult& r, const LiveFullWaveSettings& settings);
void write_live(record::Hdf5Writer& h5, const WaveValidityResult& r,
                const LiveFullWaveSettings& settings);
void write_live_csv(const std::filesystem::path& path, const WaveValidityResult& r);
// The judged scene with the largest |PO band error| (index into r.live), or −1 when none.
int worst_physical_optics_scene(const WaveValidityResult& r);
void write_live_figure(const std::filesystem::path& path, const WaveValidityLivePoint& p,
                       double threshold);

}  // namespace plumage::studies
