// Throughput of the analytic feather models: evaluations of f(ωi, ωo, λ), of pdf(), and sampled
// quanta per second. Directions and wavelengths come from a pre-drawn table of 1024 (fits in L1/L2)
// so that the timed loop is the model alone.
#include <array>
#include <cmath>
#include <vector>

#include <benchmark/benchmark.h>

#include "analysis/filip2024.h"
#include "sim/random.h"

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
            const double phi = 2.0 * 3.141592653589793 * rng.uniform();
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

}  // namespace
}  // namespace plumage::analysis

BENCHMARK_MAIN();
