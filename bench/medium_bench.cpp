// The wave-optical spongy medium (issue 14, acceptance 4): scattering events per second in
// the medium, and the time to compute its tables from a 256³ volume.
//
//  - BM_MediumEvents: ScatteringMedium::fly + scatter alone (an unbounded medium, a
//    Born table of 181 nodes, two tables interpolated in λ), one thread: the medium's own
//    cost per scattering event.
//  - BM_SlabTracerEvents/threads: whole paths through a lossless 50 µm slab (μ_s = 1/µm,
//    n_eff = 1.3, Fresnel and TIR) by trace_many with 1 or 2 threads; "events/s" counts the
//    paths' medium scattering events (every event also costs one Embree query).
//  - BM_WaveTables256/threads: a channel volume of 256³ voxels (20 nm, box 5.12 µm; the
//    volume itself is generated once, untimed) → indicator (sim/wave/volume/index_field.h) →
//    3D power spectrum (FFTW, one thread) → born_medium at 31 wavelengths 400–700 nm,
//    the wavelengths spread over `threads` OpenMP threads.
//  - BM_StrongContrastTables256/threads: the same with strong_contrast_medium (self-consistent)
//    in place of born_medium (issue 37, acceptance 4: "whichever route").
#include <chrono>
#include <cmath>
#include <memory>
#include <numbers>
#include <vector>

#include <benchmark/benchmark.h>
#include <omp.h>

#include "geometry/spongy_volume.h"
#include "sim/scattering_medium.h"
#include "sim/scattering_slab.h"
#include "sim/tracer.h"
#include "sim/wave/volume/born_medium.h"
#include "sim/wave/volume/index_field.h"
#include "sim/wave/volume/power_spectrum.h"
#include "sim/wave/volume/strong_contrast.h"

namespace plumage::sim {
namespace {

MediumTable hg_table(double lambda_nm, double g, double mu_s, double n_eff) {
    MediumTable t;
    t.lambda_nm = lambda_nm;
    t.n_eff = n_eff;
    t.mu_s_per_um = mu_s;
    for (int i = 0; i < 181; ++i) {
        const double mu = std::cos(std::numbers::pi * i / 180.0);
        t.cos_theta.push_back(mu);
        t.phase_per_sr.push_back(
            (1.0 - g * g) / (4.0 * std::numbers::pi * std::pow(1.0 + g * g - 2.0 * g * mu, 1.5)));
    }
    return t;
}

void BM_MediumEvents(benchmark::State& state) {
    const ScatteringMedium medium(
        {hg_table(500.0, 0.5, 1.0, 1.3), hg_table(600.0, -0.2, 0.5, 1.3)});
    Rng rng(7, 0);
    Vec3d direction = Vec3d::UnitZ();
    double weight = 1.0;
    for (auto _ : state) {
        const MediumFlight f = medium.fly(1e30, 550.0, rng);
        const MediumScatter s = medium.scatter(direction, 550.0, rng);
        direction = s.direction;
        weight *= f.weight * s.weight;
        benchmark::DoNotOptimize(direction);
    }
    benchmark::DoNotOptimize(weight);
    state.counters["events/s"] =
        benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_MediumEvents);

void BM_SlabTracerEvents(benchmark::State& state) {
    const int threads = static_cast<int>(state.range(0));
    auto medium = std::make_shared<const ScatteringMedium>(
        std::vector<MediumTable>{hg_table(550.0, 0.5, 1.0, 1.3)});
    ScatteringSlabParams params;
    params.thickness_um = 50.0;
    params.half_width_um = 5000.0;
    const ExplicitScatterer tracer(scattering_slab_scene(medium, params));
    const Vec3d wi = Vec3d::UnitZ();
    constexpr std::size_t kBatch = 4000;
    const BeamFootprint footprint{{-10.0, -10.0}, {10.0, 10.0}};
    // The batch's events, counted once (identical for any thread count).
    double events = 0.0;
    for (std::size_t i = 0; i < kBatch; ++i) {
        Rng rng(11, i);
        const Vec2 p = footprint.min_um + Vec2(20.0 * rng.uniform(), 20.0 * rng.uniform());
        events += tracer.trace(wi, 550.0, p, rng).medium_scatters;
    }
    for (auto _ : state) {
        auto out = trace_many(tracer, wi, 550.0, footprint, 11, 0, kBatch, threads);
        benchmark::DoNotOptimize(out);
    }
    const double total = events * static_cast<double>(state.iterations());
    state.counters["events/s"] = benchmark::Counter(total, benchmark::Counter::kIsRate);
    state.counters["events/s/core"] =
        benchmark::Counter(total / threads, benchmark::Counter::kIsRate);
    state.counters["events/path"] = events / kBatch;
}
BENCHMARK(BM_SlabTracerEvents)->Arg(1)->Arg(2)->UseRealTime()->Unit(benchmark::kMillisecond);

const geometry::SpongyVolume& volume256() {
    static const geometry::SpongyVolume v = [] {
        geometry::ChannelVolumeParams p;
        p.length_scale_um = 0.2;
        p.keratin_fraction = 0.5;
        p.voxel_um = 0.02;
        p.box_um = 256 * 0.02;
        return geometry::make_channel_volume(p);
    }();
    return v;
}

// The 256³ volume's tables at 31 wavelengths by `route` (one wavelength's table), timed in
// steps: indicator, spectrum, tables, every step on the benchmark's thread count.
template <class Route>
void wave_tables_256(benchmark::State& state, Route route, const char* tables_counter) {
    const int threads = static_cast<int>(state.range(0));
    const geometry::SpongyVolume& v = volume256();
    const int default_threads = omp_get_max_threads();
    omp_set_num_threads(threads);
    using Clock = std::chrono::steady_clock;
    double indicator_s = 0.0, spectrum_s = 0.0, tables_s = 0.0;
    for (auto _ : state) {
        const auto t0 = Clock::now();
        const wave::IndicatorField field = wave::sample_indicator(*v.level_set);
        const auto t1 = Clock::now();
        const wave::PowerSpectrum spectrum = wave::PowerSpectrum::measure_3d(
            field.as_doubles(), field.voxels_per_side, field.voxel_um);
        const auto t2 = Clock::now();
        std::vector<MediumTable> tables(31);
#pragma omp parallel for num_threads(threads) schedule(dynamic, 1)
        for (int i = 0; i < 31; ++i)
            tables[static_cast<std::size_t>(i)] = medium_table(route(spectrum, 400.0 + 10.0 * i));
        const ScatteringMedium medium(std::move(tables));
        benchmark::DoNotOptimize(medium.scattering_coefficient_per_um(450.0));
        const auto t3 = Clock::now();
        indicator_s += std::chrono::duration<double>(t1 - t0).count();
        spectrum_s += std::chrono::duration<double>(t2 - t1).count();
        tables_s += std::chrono::duration<double>(t3 - t2).count();
    }
    omp_set_num_threads(default_threads);
    const auto n = static_cast<double>(state.iterations());
    state.counters["voxels_per_side"] = static_cast<double>(v.voxels_per_side);
    state.counters["indicator_s"] = indicator_s / n;
    state.counters["spectrum_s"] = spectrum_s / n;
    state.counters[tables_counter] = tables_s / n;
}

void BM_WaveTables256(benchmark::State& state) {
    const auto keratin = optics::keratin();
    const auto air = optics::air();
    wave_tables_256(
        state,
        [&](const wave::PowerSpectrum& s, double lambda) {
            return wave::born_medium(s, *keratin, *air, lambda);
        },
        "born31_s");
}
BENCHMARK(BM_WaveTables256)->Arg(1)->Arg(2)->Iterations(1)->UseRealTime()->Unit(benchmark::kSecond);

// The same volume through the strong-contrast medium, self-consistent (the form whose solve
// iterates: sim/wave/volume/strong_contrast.h).
void BM_StrongContrastTables256(benchmark::State& state) {
    const auto keratin = optics::keratin();
    const auto air = optics::air();
    wave_tables_256(
        state,
        [&](const wave::PowerSpectrum& s, double lambda) {
            return wave::strong_contrast_medium(s, *keratin, *air, lambda,
                                                wave::StrongContrastHost::bruggeman);
        },
        "strong31_s");
}
BENCHMARK(BM_StrongContrastTables256)
    ->Arg(1)
    ->Arg(2)
    ->Iterations(1)
    ->UseRealTime()
    ->Unit(benchmark::kSecond);

}  // namespace
}  // namespace plumage::sim

BENCHMARK_MAIN();
