// Throughput of the analytic feather models: evaluations of f(ωi, ωo, λ), of pdf(), and sampled
// quanta per second. Directions and wavelengths come from a pre-drawn table of 1024 (fits in L1/L2)
// so that the timed loop is the model alone.
#include <array>
#include <cmath>
#include <vector>

#include <benchmark/benchmark.h>

#include "analysis/fits/huang2022_fit.h"
#include "analysis/models/huang2022.h"

#include "analysis/models/fibre_baseline.h"
#include "analysis/models/filip2024.h"
#include "analysis/models/padrongriffe2024.h"
#include "common/constants.h"
#include "sim/scatterer/random.h"

namespace plumage::analysis {
namespace {

struct Pairs {
    std::vector<Vec3d> wi, wo;
    std::vector<double> lambda;
};

// 1024 (ωi, ωo, λ) triples, uniform over the upper hemisphere and the 380–780 nm range.
const Pairs& pairs() {
    static const Pairs table = [] {
        Pairs p;
        Rng rng(kDefaultSeed, 0);
        auto direction = [&] {
            const double z = rng.uniform();
            const double phi = kTwoPi * rng.uniform();
            const double s = std::sqrt(1.0 - z * z);
            return Vec3d(s * std::cos(phi), s * std::sin(phi), z);
        };
        for (int k = 0; k < 1024; ++k) {
            p.wi.push_back(direction());
            p.wo.push_back(direction());
            p.lambda.push_back(380.0 + 400.0 * rng.uniform());
        }
        return p;
    }();
    return table;
}

void BM_Filip2024Eval(benchmark::State& state) {
    const Filip2024Brdf brdf(filip2024_preset("parrot"));
    const Pairs& p = pairs();
    std::size_t i = 0;
    for (auto _ : state) {
        const std::size_t k = i++ & 1023U;
        benchmark::DoNotOptimize(brdf.eval(p.wi[k], p.wo[k], p.lambda[k]));
    }
    state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_Filip2024Eval);

void BM_Filip2024EvalPerLobe(benchmark::State& state) {
    const Filip2024Brdf brdf(filip2024_preset("parrot"));
    const Pairs& p = pairs();
    std::array<double, kFilip2024LobeCount> lobes{};
    std::size_t i = 0;
    for (auto _ : state) {
        const std::size_t k = i++ & 1023U;
        benchmark::DoNotOptimize(brdf.eval(p.wi[k], p.wo[k], p.lambda[k], lobes));
        benchmark::DoNotOptimize(lobes.data());
    }
    state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_Filip2024EvalPerLobe);

void BM_Filip2024Pdf(benchmark::State& state) {
    const Filip2024Brdf brdf(filip2024_preset("parrot"));
    const Pairs& p = pairs();
    std::size_t i = 0;
    for (auto _ : state) {
        const std::size_t k = i++ & 1023U;
        benchmark::DoNotOptimize(brdf.pdf(p.wi[k], p.wo[k], p.lambda[k]));
    }
    state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_Filip2024Pdf);

// One quantum: mixture choice, direction, f, pdf and the lobe draw.
void BM_Filip2024Sample(benchmark::State& state) {
    const Filip2024Brdf brdf(filip2024_preset("parrot"));
    const Pairs& p = pairs();
    Rng rng(kDefaultSeed, 1);
    const Vec2 position(0.0, 0.0);
    std::size_t i = 0;
    for (auto _ : state) {
        const std::size_t k = i++ & 1023U;
        benchmark::DoNotOptimize(brdf.sample(p.wi[k], p.lambda[k], position, rng));
    }
    state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_Filip2024Sample);

// The fibre models build their azimuthal tables (and Padrón-Griffe its masking
// partition) once per incident direction and keep the last one per thread.
// "Random" changes ωi at every call (the worst case: a rebuild each time);
// "FixedIncident" keeps ωi and sweeps ωo, as a goniometer does.
template <typename Model>
void eval_random(benchmark::State& state, const Model& model) {
    const Pairs& p = pairs();
    std::size_t i = 0;
    for (auto _ : state) {
        const std::size_t k = i++ & 1023U;
        benchmark::DoNotOptimize(model.eval(p.wi[k], p.wo[k], p.lambda[k]));
    }
    state.SetItemsProcessed(state.iterations());
}

template <typename Model>
void eval_fixed_incident(benchmark::State& state, const Model& model) {
    const Pairs& p = pairs();
    std::size_t i = 0;
    for (auto _ : state) {
        const std::size_t k = i++ & 1023U;
        benchmark::DoNotOptimize(model.eval(p.wi[0], p.wo[k], p.lambda[0]));
    }
    state.SetItemsProcessed(state.iterations());
}

template <typename Model>
void sample_fixed_incident(benchmark::State& state, const Model& model) {
    const Pairs& p = pairs();
    Rng rng(kDefaultSeed, 2);
    const Vec2 position(0.0, 0.0);
    for (auto _ : state)
        benchmark::DoNotOptimize(model.sample(p.wi[0], p.lambda[0], position, rng));
    state.SetItemsProcessed(state.iterations());
}

void BM_FibreBaselineEvalRandom(benchmark::State& state) {
    eval_random(state, FibreBaselineBsdf({}));
}
BENCHMARK(BM_FibreBaselineEvalRandom);
void BM_FibreBaselineEvalFixedIncident(benchmark::State& state) {
    eval_fixed_incident(state, FibreBaselineBsdf({}));
}
BENCHMARK(BM_FibreBaselineEvalFixedIncident);
void BM_FibreBaselineSampleFixedIncident(benchmark::State& state) {
    sample_fixed_incident(state, FibreBaselineBsdf({}));
}
BENCHMARK(BM_FibreBaselineSampleFixedIncident);

void BM_PadronGriffe2024EvalRandom(benchmark::State& state) {
    eval_random(state, PadronGriffe2024Bsdf({}));
}
BENCHMARK(BM_PadronGriffe2024EvalRandom);
void BM_PadronGriffe2024EvalFixedIncident(benchmark::State& state) {
    eval_fixed_incident(state, PadronGriffe2024Bsdf({}));
}
BENCHMARK(BM_PadronGriffe2024EvalFixedIncident);
void BM_PadronGriffe2024SampleFixedIncident(benchmark::State& state) {
    sample_fixed_incident(state, PadronGriffe2024Bsdf({}));
}
BENCHMARK(BM_PadronGriffe2024SampleFixedIncident);

// The analytic masking term alone (the exact upper-envelope partition), for
// random directions.
// Huang 2022: the visibility intervals are built once per incident direction (kept per
// thread), then eval integrates the TRT lobe over the hit normals.
void BM_Huang2022EvalRandom(benchmark::State& state) {
    eval_random(state, analysis::Huang2022Bsdf({}));
}
BENCHMARK(BM_Huang2022EvalRandom);
void BM_Huang2022EvalFixedIncident(benchmark::State& state) {
    eval_fixed_incident(state, analysis::Huang2022Bsdf({}));
}
BENCHMARK(BM_Huang2022EvalFixedIncident);
// The same sweep from a stated ω_i (θ_i = 0.6 rad in the x–z plane) at 550 nm: the input that
// bench/python_models_bench.py evaluates from Python, since the rate depends on ω_i (1.3–2.3 × 10⁵
// per CPU second over six ω_i) and the table's ω_i[0] cannot be reproduced outside C++.
void BM_Huang2022EvalStatedIncident(benchmark::State& state) {
    const Huang2022Bsdf model({});
    const Vec3d wi(std::sin(0.6), 0.0, std::cos(0.6));
    const Pairs& p = pairs();
    std::size_t i = 0;
    for (auto _ : state) {
        const std::size_t k = i++ & 1023U;
        benchmark::DoNotOptimize(model.eval(wi, p.wo[k], 550.0));
    }
    state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_Huang2022EvalStatedIncident);
// A new ω_i and ω_o every call at 550 nm: bench/python_huang_pairs_bench.py's case from C++ (issue
// 41: 10⁶ such pairs in ≤ 10 s on 2 cores), where the per-ω_i frame is the whole cost.
void BM_Huang2022EvalRandomPairs550(benchmark::State& state) {
    const Huang2022Bsdf model({});
    const Pairs& p = pairs();
    std::size_t i = 0;
    for (auto _ : state) {
        const std::size_t k = i++ & 1023U;
        benchmark::DoNotOptimize(model.eval(p.wi[k], p.wo[k], 550.0));
    }
    state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_Huang2022EvalRandomPairs550);
void BM_Huang2022SampleFixedIncident(benchmark::State& state) {
    sample_fixed_incident(state, analysis::Huang2022Bsdf({}));
}
BENCHMARK(BM_Huang2022SampleFixedIncident);

void BM_PadronGriffe2024Masking(benchmark::State& state) {
    const PadronGriffe2024Masking masking(geometry::BarbulePatchParams{});
    const Pairs& p = pairs();
    std::size_t i = 0;
    for (auto _ : state) benchmark::DoNotOptimize(masking(p.wi[i++ & 1023U]).barb);
    state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_PadronGriffe2024Masking);

// The Huang 2022 fit of a scatterogram under a 16° illumination cone (issue 42: a user's cone
// record gave no answer for minutes and printed nothing): the image is the model's own at the
// published parameters with 3 % standard errors, the fit starts from d = 0.55 µm and H = 1.0 with
// φ0, φ1 fixed, as `plumage fit` does. Arguments: rows of the image, wavelengths (450–650 nm).
// Reported: the fit's wall time per run, its evaluations and the time of one model evaluation,
// which the command line prints as the fit's expected cost before it goes on.
void BM_Huang2022FitCone(benchmark::State& state) {
    gonio::ScatterometerConfig config;
    config.illumination = gonio::Illumination::cone;
    config.beam_direction = Vec3d(std::sin(0.35), 0.0, std::cos(0.35));
    config.cone_aperture_rad = 16.0 * kPi / 180.0;
    config.image_size = static_cast<int>(state.range(0));
    const auto nl = static_cast<std::size_t>(state.range(1));
    config.wavelengths_nm.clear();
    for (std::size_t l = 0; l < nl; ++l)
        config.wavelengths_nm.push_back(
            nl == 1 ? 550.0 : 450.0 + 200.0 * static_cast<double>(l) / static_cast<double>(nl - 1));
    HuangFitOptions options;
    options.fixed = {"phi0", "phi1"};
    options.threads = 0;
    gonio::Scatterogram data = huang2022_scatterogram({}, config, options);
    data.standard_error.resize(data.intensity.size());
    for (std::size_t i = 0; i < data.intensity.size(); ++i)
        data.standard_error[i] = 0.03 * data.intensity[i];
    Huang2022Params start;
    start.d_um = 0.55;
    start.H = 1.0;
    HuangFitResult fit;
    for (auto _ : state) fit = fit_huang2022(data, start, options);
    state.counters["evaluations"] = fit.function_evaluations;
    state.counters["s_per_evaluation"] = fit.wall_time_s / fit.function_evaluations;
    state.counters["d_um"] = fit.parameters.d_um;
    state.counters["illumination_directions"] =
        options.illumination_nodes_radial * options.illumination_nodes_azimuthal;
}
BENCHMARK(BM_Huang2022FitCone)
    ->Args({41, 3})
    ->Iterations(1)
    ->Unit(benchmark::kSecond)
    ->UseRealTime();

}  // namespace
}  // namespace plumage::analysis

BENCHMARK_MAIN();
