// Full wave (issue 35, acceptance 4): the rock dove's barbule cross-section, converged, and a
// spongy cube in 3D.
//
//  - BM_FullWaveDispersion/fitted, BM_FullWaveStopRule: below.
//  - BM_FullWaveBarbule/threads: one barbule of studies/rock_dove.toml (outer ellipse A = 10 µm,
//    b = 0.25, so 20 µm across; 0.59 µm keratin film over a 0.3 µm air gap over the melanin core;
//    turned by μ = −20.05°), lit at θ_i = 0, seven wavelengths 400–700 nm, TE and TM, at 45 and
//    67.5 px/µm (45 is λ/(10 n) for melanin at 400 nm), Dispersion::fitted (one run per
//    polarisation and grid), stopped on the far field's convergence (kFarFieldTolerance).
//    `threads`: runs at once, longest first. Counters: the band-integrated
//    back-scattered power (∫ over 400–700 nm of the back-hemisphere width, TE + TM) on both
//    grids and their difference, the converged result being within 2 % (acceptance: ≤ 10 min on
//    2 cores); and the fine grid's difference from the per-wavelength reference committed in
//    tests/reference/fullwave_rock_dove (the exact indices, one run per wavelength: 81 minutes).
#include <array>
#include <cmath>
#include <fstream>
#include <map>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>
#include <fmt/format.h>

#include "geometry/spongy_volume.h"
#include "sim/fullwave/full_wave_2d.h"
#include "sim/fullwave/full_wave_slab.h"

namespace plumage::sim::fullwave {
namespace {

constexpr std::array<double, 7> kLambdas{400.0, 450.0, 500.0, 550.0, 600.0, 650.0, 700.0};

// ∫ over the band of the back-hemisphere width (trapezoid on the 50 nm grid), µm · nm.
double band_power(const std::vector<double>& widths) {
    double sum = 0.0;
    for (std::size_t k = 0; k + 1 < widths.size(); ++k) sum += 25.0 * (widths[k] + widths[k + 1]);
    return sum;
}

// The committed per-wavelength reference's back widths at one grid, TE + TM per wavelength.
std::vector<double> reference_back_widths(double resolution) {
    std::ifstream in(std::string(PLUMAGE_SOURCE_DIR) +
                     "/tests/reference/fullwave_rock_dove/totals.csv");
    std::map<double, double> by_lambda;
    std::string line;
    std::getline(in, line);
    while (std::getline(in, line)) {
        std::stringstream row(line);
        std::vector<std::string> f;
        for (std::string cell; std::getline(row, cell, ',');) f.push_back(cell);
        if (f.size() > 5 && std::stod(f[4]) == resolution)
            by_lambda[std::stod(f[3])] += std::stod(f[5]);
    }
    std::vector<double> out;
    for (const double l : kLambdas) out.push_back(by_lambda[l]);
    return out;
}

// The far-field stop rule's tolerance for the benchmarks (FullWave2dOptions::far_field_tolerance):
// on the 5 µm barbule (BM_FullWaveStopRule) it ends the TE run 38 % sooner than the probe's 1e-7
// decay and the TM run 3 % later, the band's back power within 0.24 % of the probe rule's, inside
// the drift the cortex's ringing leaves in either (bench/README.md, "Full wave").
constexpr double kFarFieldTolerance = 3e-3;

struct BarbuleRun {
    double resolution = 0.0;
    Polarisation2d pol = Polarisation2d::te;
    FullWave2dResult result;
};

// The four runs (two grids × two polarisations), longest first so that `threads` threads finish
// together (a fine run costs about 3.4 coarse ones; TM rings longer than TE).
std::vector<BarbuleRun> run_barbule(const CrossSection2d& section, int threads) {
    std::vector<BarbuleRun> runs{{67.5, Polarisation2d::tm, {}},
                                 {67.5, Polarisation2d::te, {}},
                                 {45.0, Polarisation2d::tm, {}},
                                 {45.0, Polarisation2d::te, {}}};
    const std::vector<double> theta{0.0};
#pragma omp parallel for num_threads(threads) schedule(dynamic, 1)
    for (std::size_t i = 0; i < runs.size(); ++i) {
        FullWave2dOptions o;
        o.resolution_px_per_um = runs[i].resolution;
        o.dispersion = Dispersion::fitted;
        o.far_field_tolerance = kFarFieldTolerance;
        o.threads = 1;
        runs[i].result = full_wave_far_field(section, runs[i].pol, 0.0, kLambdas, theta, o);
    }
    return runs;
}

void BM_FullWaveBarbule(benchmark::State& state) {
    const int threads = static_cast<int>(state.range(0));
    constexpr double kDeg = std::numbers::pi / 180.0;
    const CrossSection2d section = barbule_row(10.0, 0.25, 0.59, 0.3, 12.5, -20.05 * kDeg, 1);
    std::array<double, 2> power{};
    double index_error = 0.0;
    for (auto _ : state) {
        const std::vector<BarbuleRun> runs = run_barbule(section, threads);
        for (std::size_t g = 0; g < 2; ++g) {
            const double res = g == 0 ? 45.0 : 67.5;
            std::vector<double> both(kLambdas.size(), 0.0);
            for (const BarbuleRun& r : runs) {
                if (r.resolution != res) continue;
                fmt::print("{} px/µm, {}: {} cells, {} steps, {:.0f} s\n", res,
                           r.pol == Polarisation2d::te ? "TE" : "TM", r.result.grid_cells,
                           r.result.wavelengths[0].time_steps, r.result.seconds);
                for (std::size_t k = 0; k < both.size(); ++k)
                    both[k] += r.result.wavelengths[k].back_scattering_width_um;
                for (const LorentzFit& fit : r.result.dispersion_fits)
                    index_error = std::max(index_error, fit.max_index_error);
            }
            power[g] = band_power(both);
            const std::vector<double> reference = reference_back_widths(res);
            for (std::size_t k = 0; k < both.size(); ++k)
                fmt::print(
                    "{} px/µm, {} nm: back width TE + TM {:.4f} µm (per-wavelength "
                    "reference {:.4f})\n",
                    res, kLambdas[k], both[k], reference[k]);
            state.counters[g == 0 ? "band_power_45" : "band_power_67_5"] = power[g];
            state.counters[g == 0 ? "vs_reference_45_pct" : "vs_reference_67_5_pct"] =
                100.0 * (power[g] / band_power(reference) - 1.0);
        }
    }
    state.counters["convergence_pct"] = 100.0 * (power[1] / power[0] - 1.0);
    state.counters["fit_index_error"] = index_error;
}

// The stop rules on the 5 µm barbule (BM_FullWaveDispersion's), fitted, 45 px/µm, TE and TM at
// once on two threads: arg 0 the probe's 1e-7 decay, arg 1 the far field's convergence
// (kFarFieldTolerance). Counters: each run's time steps and the band's back power (TE + TM).
void BM_FullWaveStopRule(benchmark::State& state) {
    constexpr double kDeg = std::numbers::pi / 180.0;
    const CrossSection2d section = barbule_row(5.0, 0.25, 0.59, 0.3, 6.25, -20.05 * kDeg, 1);
    const std::vector<double> theta{0.0};
    for (auto _ : state) {
        std::array<FullWave2dResult, 2> r;
#pragma omp parallel for num_threads(2)
        for (int p = 0; p < 2; ++p) {
            FullWave2dOptions o;
            o.resolution_px_per_um = 45.0;
            o.threads = 1;
            o.dispersion = Dispersion::fitted;
            o.far_field_tolerance = state.range(0) == 0 ? 0.0 : kFarFieldTolerance;
            r[static_cast<std::size_t>(p)] = full_wave_far_field(
                section, p == 0 ? Polarisation2d::te : Polarisation2d::tm, 0.0, kLambdas, theta, o);
        }
        std::vector<double> both(kLambdas.size());
        for (std::size_t k = 0; k < both.size(); ++k)
            both[k] = r[0].wavelengths[k].back_scattering_width_um +
                      r[1].wavelengths[k].back_scattering_width_um;
        state.counters["band_power"] = band_power(both);
        state.counters["steps_te"] = r[0].wavelengths[0].time_steps;
        state.counters["steps_tm"] = r[1].wavelengths[0].time_steps;
    }
}

// What Dispersion::fitted buys, on a smaller barbule (A = 5 µm, the rest as above, 250 884
// cells), TE, 45 px/µm, seven wavelengths, one thread: per_wavelength (arg 0: seven runs, each
// material exact) against fitted (arg 1: one run with Lorentz poles). Counters: the back widths
// at 400 and 550 nm, which the two must give within the fit's and the grid's error.
void BM_FullWaveDispersion(benchmark::State& state) {
    constexpr double kDeg = std::numbers::pi / 180.0;
    const CrossSection2d section = barbule_row(5.0, 0.25, 0.59, 0.3, 6.25, -20.05 * kDeg, 1);
    FullWave2dOptions o;
    o.resolution_px_per_um = 45.0;
    o.threads = 1;
    o.dispersion = state.range(0) == 0 ? Dispersion::per_wavelength : Dispersion::fitted;
    const std::vector<double> theta{0.0};
    for (auto _ : state) {
        const FullWave2dResult r =
            full_wave_far_field(section, Polarisation2d::te, 0.0, kLambdas, theta, o);
        state.counters["back_400"] = r.wavelengths[0].back_scattering_width_um;
        state.counters["back_550"] = r.wavelengths[3].back_scattering_width_um;
        state.counters["time_steps"] = r.wavelengths[0].time_steps;
    }
}

// The spongy cube (acceptance 4): a channel-type volume 3 µm on a side (length scale 0.2 µm,
// keratin fraction 0.5, seed 1), as a slab 3 µm thick repeated every 3 µm, in air, lit at normal
// incidence; keratin fitted as Lorentz poles, one run per polarisation and grid for 13
// wavelengths 400–700 nm; at 40 and 60 px/µm (40 is λ/(10 n) at 400 nm and two cells across the
// smallest feature, stated as a quarter of the length scale). `threads`: runs at once.
// Counters: the band means of the specular and diffuse reflectance on both grids and the
// relative difference of the total (acceptance: both grids within 60 min on 2 cores).
void BM_FullWaveSpongyCube(benchmark::State& state) {
    geometry::ChannelVolumeParams params;
    params.box_um = 3.0;
    params.voxel_um = 0.02;
    const geometry::SpongyVolume volume = geometry::make_channel_volume(params);
    Slab3d slab;
    slab.period_um = 3.0;
    slab.thickness_um = 3.0;
    slab.thinnest_um = 0.25 * params.length_scale_um;
    slab.inside = geometry::periodic_keratin_test(*volume.level_set);
    slab.material = optics::keratin();
    std::vector<double> lambdas;
    for (double l = 400.0; l <= 700.0; l += 25.0) lambdas.push_back(l);
    std::array<double, 2> total{};
    for (auto _ : state) {
        for (std::size_t g = 0; g < 2; ++g) {
            FullWave2dOptions o;
            o.resolution_px_per_um = g == 0 ? 40.0 : 60.0;
            o.dispersion = Dispersion::fitted;
            o.threads = static_cast<int>(state.range(0));
            const FullWaveSlabResult r = full_wave_slab(slab, lambdas, o);
            double specular = 0.0, diffuse = 0.0;
            for (const SlabSpectrum& w : r.wavelengths) {
                fmt::print(
                    "{} px/µm, {} nm: R specular {:.4f}, diffuse {:.4f}; T {:.4f} + {:.4f}\n",
                    o.resolution_px_per_um, w.lambda_nm, w.specular_reflectance,
                    w.diffuse_reflectance, w.specular_transmittance, w.diffuse_transmittance);
                specular += w.specular_reflectance / static_cast<double>(lambdas.size());
                diffuse += w.diffuse_reflectance / static_cast<double>(lambdas.size());
            }
            fmt::print("{} px/µm: {:.0f} s, {} cells\n", o.resolution_px_per_um, r.seconds,
                       r.grid_cells);
            total[g] = specular + diffuse;
            state.counters[g == 0 ? "specular_40" : "specular_60"] = specular;
            state.counters[g == 0 ? "diffuse_40" : "diffuse_60"] = diffuse;
            state.counters[g == 0 ? "seconds_40" : "seconds_60"] = r.seconds;
        }
    }
    state.counters["convergence_pct"] = 100.0 * (total[0] / total[1] - 1.0);
}

BENCHMARK(BM_FullWaveSpongyCube)->Arg(2)->Iterations(1)->Unit(benchmark::kSecond)->UseRealTime();
BENCHMARK(BM_FullWaveDispersion)
    ->Arg(0)
    ->Arg(1)
    ->Iterations(1)
    ->Unit(benchmark::kSecond)
    ->UseRealTime();
BENCHMARK(BM_FullWaveStopRule)
    ->Arg(0)
    ->Arg(1)
    ->Iterations(1)
    ->Unit(benchmark::kSecond)
    ->UseRealTime();
BENCHMARK(BM_FullWaveBarbule)->Arg(2)->Iterations(1)->Unit(benchmark::kSecond)->UseRealTime();

}  // namespace
}  // namespace plumage::sim::fullwave

BENCHMARK_MAIN();
