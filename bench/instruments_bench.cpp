// Time to 1 % relative RMS error on the 61 × 60 = 3660-pair Filip BRDF set (issue 5):
//  - the Lambertian plate through the photon estimator (detector half-angle 5°);
//  - the rock-dove R lobe of the Huang model through the photon estimator (projection
//    from two passes, as below);
//  - the explicit rock-dove patch (tracer): two passes of the photon estimator, and the
//    projection t(1 %) = t · (ε / 1 %)² from the measured 1/√t convergence.
// Each runs once (Iterations(1)); the counters carry the figures.
#include <cmath>

#include <benchmark/benchmark.h>

#include "analysis/huang2022.h"
#include "analysis/lambertian.h"
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

void BM_ProjectedTimeTo1PercentExplicitRockDove3660(benchmark::State& state) {
    geometry::BarbuleRowParams row;
    row.barbules = 48;
    row.cells_per_barbule = 30;
    const sim::ExplicitScatterer patch(
        sim::barbule_row_scene(geometry::build_barbule_row(row, {0.01, 0.02})));
    GoniometerConfig c;
    c.direction_set = "filip2024_btf";
    c.pairs = filip2024_btf_pairs();
    c.detector_half_angle_rad = 5.0 * kDeg;
    c.beam_radius_um = 60.0;
    c.estimator = Estimator::photon;
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

}  // namespace
}  // namespace plumage::gonio

BENCHMARK_MAIN();
