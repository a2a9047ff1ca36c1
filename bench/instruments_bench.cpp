// Time to 1 % relative RMS error on the 61 × 60 = 3660-pair Filip BRDF set (issue 5):
//  - the Lambertian plate through the photon estimator (detector half-angle 5°);
//  - the rock-dove R lobe of the Huang model through the photon estimator (projection
//    from two passes, as below);
//  - the explicit rock-dove patch (tracer): two passes of the photon estimator, and the
//    projection t(1 %) = t · (ε / 1 %)² from the measured 1/√t convergence.
// Each runs once (Iterations(1)); the counters carry the figures.
#include <omp.h>

#include <cmath>
#include <cstdlib>
#include <fstream>

#include <benchmark/benchmark.h>
#include <fmt/format.h>

#include "analysis/models/huang2022.h"
#include "analysis/models/lambertian.h"
#include "common/constants.h"
#include "geometry/barbule.h"
#include "sim/tracer.h"
#include "virtual_gonio/goniometer.h"

namespace plumage::gonio {
namespace {

void BM_TimeTo1PercentLambertian3660(benchmark::State& state) {
    const analysis::LambertianScatterer plate(0.6);
    GoniometerConfig c;
    c.direction_set = "filip2024_btf";
    c.pairs = filip2024_btf_pairs();
    c.detector_half_angle_rad = 5.0 * kDeg;
    c.estimator = Estimator::photon;
    c.quanta_per_pass = 500000;
    c.max_passes = 40;
    c.target_relative_error = 0.01;
    BrdfRecord r;
    for (auto _ : state) r = measure_brdf(plate, c);
    state.counters["wall_s"] = r.wall_time_s;
    state.counters["error"] = r.convergence.back().estimated_relative_rms_error;
    state.counters["quanta_per_light"] = static_cast<double>(r.quanta);
}
BENCHMARK(BM_TimeTo1PercentLambertian3660)->Iterations(1)->Unit(benchmark::kSecond);

void BM_TimeTo1PercentHuangRLobe3660(benchmark::State& state) {
    // The R lobe is narrow with sharp edges: a cone cubature of eval() converges slowly
    // where an edge crosses a detector (64 rings still leave ~7 %), so the photon
    // estimator is the efficient one here too. Two passes, then t(1 %) = t · (ε/1 %)²
    // with ε the R lobe's relative RMS standard error over the cells it reaches.
    const analysis::Huang2022Bsdf model({});
    GoniometerConfig c;
    c.direction_set = "filip2024_btf";
    c.pairs = filip2024_btf_pairs();
    c.detector_half_angle_rad = 5.0 * kDeg;
    c.estimator = Estimator::photon;
    c.quanta_per_pass = 50000;
    c.max_passes = 2;
    BrdfRecord r;
    for (auto _ : state) r = measure_brdf(model, c);
    double acc = 0.0;
    int n = 0;
    for (std::size_t p = 0; p < c.pairs.size(); ++p) {
        const double v = r.lobe_values[p];  // lobe 0 = R, one wavelength
        if (v <= 0.0) continue;
        acc += std::pow(r.lobe_standard_error[p] / v, 2);
        ++n;
    }
    const double error = n > 0 ? std::sqrt(acc / n) : 0.0;
    state.counters["wall_s"] = r.wall_time_s;
    state.counters["error"] = error;
    state.counters["projected_s_to_1pct"] = r.wall_time_s * std::pow(error / 0.01, 2);
}
BENCHMARK(BM_TimeTo1PercentHuangRLobe3660)->Iterations(1)->Unit(benchmark::kSecond);

// The explicit rock-dove patch of the cases below (48 barbules × 30 cells, 0.01 µm / 0.02 rad)
// and its goniometer: the 3660-pair set, detector 5°, beam radius 60 µm, photon estimator.
sim::ExplicitScatterer rock_dove_patch() {
    geometry::BarbuleRowParams row;
    row.barbules = 48;
    row.cells_per_barbule = 30;
    return sim::ExplicitScatterer(
        sim::barbule_row_scene(geometry::build_barbule_row(row, {0.01, 0.02})));
}

GoniometerConfig rock_dove_config() {
    GoniometerConfig c;
    c.direction_set = "filip2024_btf";
    c.pairs = filip2024_btf_pairs();
    c.detector_half_angle_rad = 5.0 * kDeg;
    c.beam_radius_um = 60.0;
    c.estimator = Estimator::photon;
    return c;
}

void BM_ProjectedTimeTo1PercentExplicitRockDove3660(benchmark::State& state) {
    const sim::ExplicitScatterer patch = rock_dove_patch();
    GoniometerConfig c = rock_dove_config();
    c.quanta_per_pass = 20000;
    c.max_passes = 2;
    BrdfRecord r;
    for (auto _ : state) r = measure_brdf(patch, c);
    const double error = r.convergence.back().estimated_relative_rms_error;
    state.counters["wall_s"] = r.wall_time_s;
    state.counters["error"] = error;
    state.counters["projected_s_to_1pct"] = r.wall_time_s * std::pow(error / 0.01, 2);
}
BENCHMARK(BM_ProjectedTimeTo1PercentExplicitRockDove3660)->Iterations(1)->Unit(benchmark::kSecond);

// Issue 15's case: the explicit rock-dove patch, full spectral (7 wavelengths, 400–700 nm, all
// lobes), the 3660-pair set, detector 5° (view cone); one path per quantum and
// wavelength (separate, arg 0) against one path per quantum for all seven (shared, arg 1),
// shared and split at the first film (arg 2), split with guided diffuse reflection, f = 0.5
// (arg 3) or 0.8 (arg 4), split with 1 or 2 guided diffuse branches at the first diffuse
// event (args 5, 6) (sim/tracer.h), and split with the lights connected to detector-side walks
// (arg 7: GoniometerConfig::connect_lights, 320 walks per view a pass, weighed against the quanta
// by the balance heuristic), and those with the reflected branch split again at its next film
// (arg 8: GoniometerConfig::split_reflections), on 1 or 2 threads (second arg). Each runs passes of
// 2000 quanta per light direction for a budget of kBudgetS, then projects t(1 %) = t · (ε / 1 %)²
// from the last pass. ε is the relative RMS standard error over the cells that carry signal: value
// ≥ 10 % of the mean of the cells at its wavelength (GoniometerConfig::signal_fraction; the record
// stores the set). With PLUMAGE_BENCH_CSV set, every pass's (wall time, error) is appended to that
// file for the error-against-time figure (bench/plot_error_vs_time.py).
void BM_RockDoveSpectral3660(benchmark::State& state) {
    constexpr double kBudgetS = 40.0;
    const bool shared = state.range(0) != 0, split = state.range(0) >= 2;
    const double guided = state.range(0) == 3 ? 0.5 : state.range(0) == 4 ? 0.8 : 0.0;
    const bool connect = state.range(0) >= 7;
    const std::size_t branches =
        state.range(0) >= 5 && !connect ? static_cast<std::size_t>(state.range(0) - 4) : 0;
    const int threads = static_cast<int>(state.range(1));
    const sim::ExplicitScatterer patch = rock_dove_patch();
    GoniometerConfig c = rock_dove_config();
    c.wavelengths_nm = {400.0, 450.0, 500.0, 550.0, 600.0, 650.0, 700.0};
    c.share_wavelength_paths = shared;
    c.split_paths = split;
    c.guided_fraction = guided;
    c.guided_branches = branches;
    c.connect_lights = connect;
    c.split_reflections = state.range(0) == 8;
    // A sixth as many walks per view as quanta per light: the split that minimises (Σ over the
    // halves of √(variance per quantum × cost per quantum))², from a run with 2000 of each
    // (bench/README.md).
    c.connected_quanta_per_pass = 320;
    c.signal_fraction = 0.1;
    c.quanta_per_pass = 2000;
    c.max_passes = 100000;
    c.time_budget_s = kBudgetS;
    const int before = omp_get_max_threads();
    omp_set_num_threads(threads);
    BrdfRecord r;
    for (auto _ : state) r = measure_brdf(patch, c);
    omp_set_num_threads(before);
    const double error = r.convergence.back().estimated_relative_rms_error;
    const std::string kind = c.split_reflections ? std::string("connected_split_reflections")
                             : connect           ? std::string("connected")
                             : branches > 0      ? fmt::format("branches{}", branches)
                             : guided > 0.0      ? fmt::format("guided{:.0f}", 100 * guided)
                             : split             ? std::string("split")
                             : shared            ? std::string("shared")
                                                 : std::string("separate");
    std::size_t signal = 0;
    for (std::uint8_t m : r.signal_cells) signal += m;
    state.counters["wall_s"] = r.wall_time_s;
    state.counters["cpu_s"] = r.cpu_time_s;
    state.counters["passes"] = r.passes;
    state.counters["error"] = error;
    state.counters["signal_cells"] = static_cast<double>(signal);
    state.counters["projected_s_to_1pct"] = r.wall_time_s * std::pow(error / 0.01, 2);
    if (const char* csv = std::getenv("PLUMAGE_BENCH_CSV")) {
        std::ofstream out(csv, std::ios::app);
        for (const ConvergenceRow& row_ : r.convergence) {
            out << kind << ',' << threads << ',' << row_.pass << ',' << row_.wall_time_s << ','
                << row_.quanta << ',' << row_.estimated_relative_rms_error << ',' << signal << ','
                << r.signal_cells.size() << '\n';
        }
    }
    if (const char* h5 = std::getenv("PLUMAGE_BENCH_RECORD")) {
        write_brdf_record(r, fmt::format("{}_{}_{}t.h5", h5, kind, threads));
    }
}
BENCHMARK(BM_RockDoveSpectral3660)
    ->Args({0, 1})
    ->Args({1, 1})
    ->Args({0, 2})
    ->Args({1, 2})
    ->Args({2, 1})
    ->Args({2, 2})
    ->Args({3, 2})
    ->Args({4, 2})
    ->Args({5, 2})
    ->Args({5, 1})
    ->Args({6, 2})
    ->Args({7, 1})
    ->Args({7, 2})
    ->Args({8, 1})
    ->Args({8, 2})
    ->Iterations(1)
    ->Unit(benchmark::kSecond)
    ->UseRealTime();

}  // namespace
}  // namespace plumage::gonio

BENCHMARK_MAIN();
