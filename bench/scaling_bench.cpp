// How the eval-based measurements and the fits scale with threads (issue "every core busy").
// Each benchmark takes the OpenMP thread count as its argument and runs at 1 and 2 threads (the
// CI machine has 2 cores; pass --benchmark_filter and edit nothing to try more: the arguments
// go up to the machine's core count). Wall time (UseRealTime), so the rate is what a user waits
// for; compare the 1- and 2-thread rows of the same run.
//  - Huang table: the rock-dove Huang model on the 3660-pair Filip set at the default study's
//    7 wavelengths, eval estimator (the default study's "BRDF: Huang model" stage); and the
//    model's point values on the same cells (no detector cone). The adaptive table (converged
//    to 1 %, 13 wavelengths, a quarter of the pairs) runs on 2 threads only, cell by cell
//    against lobe by lobe, twice, alternating.
//  - Filip table: the parrot preset on the same set (the species study's model tables).
//  - Filip fit: the rooster preset's BRDF with 2 % noise on the same set at 7 wavelengths
//    (25 620 observations, 18 free parameters), fitted from the parrot's Table 1 row: a start
//    far from the optimum, as the species study's fits of simulated BRDFs start.
#include <algorithm>
#include <cmath>
#include <thread>
#include <vector>

#include <benchmark/benchmark.h>
#include <omp.h>

#include "analysis/fits/filip2024_fit.h"
#include "analysis/models/filip2024.h"
#include "analysis/models/huang2022.h"
#include "common/constants.h"
#include "sim/scatterer/random.h"
#include "virtual_gonio/goniometer.h"

namespace plumage {
namespace {

std::vector<double> seven_wavelengths() { return {400, 450, 500, 550, 600, 650, 700}; }

gonio::GoniometerConfig eval_config() {
    gonio::GoniometerConfig c;
    c.direction_set = "filip2024_btf";
    c.pairs = gonio::filip2024_btf_pairs();
    c.wavelengths_nm = seven_wavelengths();
    c.detector_half_angle_rad = 5.0 * kDeg;
    c.estimator = gonio::Estimator::eval;
    return c;
}

void thread_arguments(benchmark::internal::Benchmark* b) {
    const int cores = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
    for (int t = 1; t <= cores; t *= 2) b->Arg(t);
}

// The model's table on the 3660-pair set at state.range(0) threads.
void tabulate(benchmark::State& state, const Scatterer& model) {
    omp_set_num_threads(static_cast<int>(state.range(0)));
    const gonio::GoniometerConfig c = eval_config();
    for (auto _ : state) benchmark::DoNotOptimize(gonio::measure_brdf(model, c));
    state.counters["pairs_per_s"] = benchmark::Counter(
        static_cast<double>(c.pairs.size()), benchmark::Counter::kIsIterationInvariantRate);
}

void BM_HuangTable3660x7(benchmark::State& state) { tabulate(state, analysis::Huang2022Bsdf({})); }
BENCHMARK(BM_HuangTable3660x7)
    ->Apply(thread_arguments)
    ->UseRealTime()
    ->Unit(benchmark::kSecond)
    ->Iterations(1);

// The same model behind a scatterer that hides Scatterer::evaluates_lobes_apart: the adaptive
// cone cubature then refines cell by cell, as before it refined lobe by lobe.
class CellByCell final : public Scatterer {
public:
    explicit CellByCell(const Scatterer& model) : model_(model) {}
    std::string name() const override { return model_.name(); }
    const std::vector<std::string>& lobe_names() const override { return model_.lobe_names(); }
    std::optional<ScatterEvent> sample(const Vec3d& wi, double lambda_nm, const Vec2& position,
                                       Rng& rng) const override {
        return model_.sample(wi, lambda_nm, position, rng);
    }
    bool can_evaluate() const override { return true; }
    double eval(const Vec3d& wi, const Vec3d& wo, double lambda_nm,
                std::span<double> per_lobe) const override {
        return model_.eval(wi, wo, lambda_nm, per_lobe);
    }

private:
    const Scatterer& model_;
};

// The default study's "BRDF: Huang model": the adaptive cone cubature converged to 1 % per cell
// (eval_tolerance 0.01, up to 64 rings), 13 wavelengths (400–700 nm every 25), on every fourth
// pair of the 3660-pair set (915 pairs); cell by cell (arg 0) or lobe by lobe (arg 1), on 2
// threads.
void BM_HuangAdaptiveTable915x13(benchmark::State& state) {
    omp_set_num_threads(2);
    const analysis::Huang2022Bsdf model({});
    const CellByCell hidden(model);
    gonio::GoniometerConfig c = eval_config();
    c.pairs.clear();
    const std::vector<gonio::DirectionPair> all = gonio::filip2024_btf_pairs();
    for (std::size_t p = 0; p < all.size(); p += 4) c.pairs.push_back(all[p]);
    c.wavelengths_nm.clear();
    for (int k = 0; k <= 12; ++k) c.wavelengths_nm.push_back(400.0 + 25.0 * k);
    c.eval_tolerance = 0.01;
    const Scatterer& measured = state.range(0) == 0 ? static_cast<const Scatterer&>(hidden) : model;
    gonio::BrdfRecord r;
    for (auto _ : state) r = gonio::measure_brdf(measured, c);
    double worst = 0.0;
    for (std::size_t i = 0; i < r.value.size(); ++i)
        if (r.value[i] > 0.0) worst = std::max(worst, r.standard_error[i] / r.value[i]);
    state.counters["worst_stated_error"] = worst;
}
BENCHMARK(BM_HuangAdaptiveTable915x13)
    ->Arg(0)
    ->Arg(1)
    ->Arg(0)
    ->Arg(1)
    ->UseRealTime()
    ->Unit(benchmark::kSecond)
    ->Iterations(1);

// The Huang model's own values f(ω_i, ω_o, λ) at the same 3660 pairs × 7 wavelengths (no detector
// cone): issue 15's "Huang model tabulated on the 3660-pair set" (its accuracy: test
// Huang2022.PointTableOnTheFilipSetIsConvergedTo1e4). Pairs in a static schedule: each value is
// a function of its pair alone, so the table is the same on any thread count.
void BM_HuangPointTable3660x7(benchmark::State& state) {
    omp_set_num_threads(static_cast<int>(state.range(0)));
    const analysis::Huang2022Bsdf model({});
    const std::vector<gonio::DirectionPair> pairs = gonio::filip2024_btf_pairs();
    const std::vector<double> wavelengths = seven_wavelengths();
    std::vector<double> table(pairs.size() * wavelengths.size());
    for (auto _ : state) {
#pragma omp parallel for schedule(static)
        for (std::size_t p = 0; p < pairs.size(); ++p) {
            for (std::size_t k = 0; k < wavelengths.size(); ++k)
                table[p * wavelengths.size() + k] =
                    model.eval(pairs[p].wi, pairs[p].wo, wavelengths[k]);
        }
        benchmark::DoNotOptimize(table.data());
    }
    state.counters["values_per_s"] =
        benchmark::Counter(static_cast<double>(table.size()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_HuangPointTable3660x7)
    ->Apply(thread_arguments)
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);

void BM_FilipTable3660x7(benchmark::State& state) {
    tabulate(state, analysis::Filip2024Brdf(analysis::filip2024_preset("parrot")));
}
BENCHMARK(BM_FilipTable3660x7)
    ->Apply(thread_arguments)
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);

void BM_Filip2024Fit25620(benchmark::State& state) {
    omp_set_num_threads(static_cast<int>(state.range(0)));
    const analysis::Filip2024Brdf model(analysis::filip2024_preset("rooster"));
    std::vector<analysis::BrdfObservation> data;
    Rng rng(derive_seed(7, "bench/filip fit"), 0);
    for (const auto& p : gonio::filip2024_btf_pairs()) {
        for (double lambda : seven_wavelengths()) {
            const double f = model.eval(p.wi, p.wo, lambda);
            const double sigma = 0.02 * f + 1e-4;
            const double gauss = std::sqrt(-2.0 * std::log(1.0 - rng.uniform())) *
                                 std::cos(2.0 * kPi * rng.uniform());
            data.push_back({p.wi, p.wo, std::nullopt, lambda, f + sigma * gauss, sigma});
        }
    }
    const analysis::Filip2024Parameters start = analysis::filip2024_preset("parrot");
    analysis::Filip2024FitResult fit;
    for (auto _ : state) fit = analysis::fit_filip2024(data, start);
    state.counters["evaluations"] = fit.function_evaluations;
    state.counters["reduced_chi2"] = fit.reduced_chi_square;
    state.counters["converged"] = fit.converged ? 1.0 : 0.0;
}
BENCHMARK(BM_Filip2024Fit25620)
    ->Apply(thread_arguments)
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace plumage

BENCHMARK_MAIN();
