// The full tracer against bare Embree on the same scene, in the same run (issue 4,
// acceptance 4: the tracer should reach at least 0.5 of bare Embree's rays per second).
//
// Scene: the 1 mm × 1 mm rock-dove barbule patch (geometry::build_barbule_row with
// Huang's parameters, 80 barbules × 50 cells = 4000 instanced cells, film + melanin),
// light at 30° from the patch normal in the x–z plane, 550 nm, one thread.
//
//  - BM_Tracer*: whole paths (ExplicitScatterer::trace), counting every Embree query a
//    path makes; "rays/s" is queries per second, "paths/s" paths per second.
//  - BM_BareEmbreeReplay: rtcIntersect1 alone on exactly the rays the tracer cast
//    (recorded from the same paths): the same ray mix, so the ratio of the two rays/s is
//    the share of time the tracer spends in Embree.
//  - BM_BareEmbreePrimary: rtcIntersect1 on the primary rays only (coherent in direction,
//    long): the optimistic bare figure.
// After the benchmarks the program prints the ratios.
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <vector>

#include <benchmark/benchmark.h>

#include "geometry/barbule.h"
#include "sim/tracer.h"

namespace plumage::sim {
namespace {

constexpr double kLambda = 550.0;
constexpr std::uint64_t kSeed = 7;

struct Fixture {
    std::shared_ptr<const Scene> scene;
    Vec3d wi;
    BeamFootprint footprint;
    std::vector<RaySegment> recorded;  // the tracer's rays, for the replay
};

const Fixture& fixture() {
    static const Fixture f = [] {
        geometry::BarbuleRowParams params;
        params.barbules =
            static_cast<int>(std::ceil(1000.0 / (params.H * params.cell.semi_major_um)));
        params.cells_per_barbule = static_cast<int>(std::ceil(1000.0 / params.cell.cell_length_um));
        const geometry::BarbuleRow row = geometry::build_barbule_row(params, {0.01, 0.02});
        Fixture out;
        out.scene = std::make_shared<const Scene>(barbule_row_scene(row));
        const double t = 30.0 * std::acos(-1.0) / 180.0;
        out.wi = Vec3d(std::sin(t), 0.0, std::cos(t));
        out.footprint = {{-250.0, -250.0}, {250.0, 250.0}};
        const ExplicitScatterer tracer(out.scene);
        for (std::uint64_t i = 0; i < 50'000; ++i) {
            Rng rng(kSeed, i);
            const Vec2 p =
                out.footprint.min_um + Vec2(500.0 * rng.uniform(), 500.0 * rng.uniform());
            tracer.trace(out.wi, kLambda, p, rng, &out.recorded);
        }
        return out;
    }();
    return f;
}

double g_tracer_rays = 0.0, g_tracer_direct_rays = 0.0, g_replay_rays = 0.0, g_primary_rays = 0.0;

void run_tracer(benchmark::State& state, const TracerOptions& options) {
    const Fixture& f = fixture();
    const ExplicitScatterer tracer(f.scene, options);
    std::uint64_t index = 0;
    std::int64_t rays = 0, paths = 0;
    for (auto _ : state) {
        Rng rng(kSeed, index++);
        const Vec2 p = f.footprint.min_um + Vec2(500.0 * rng.uniform(), 500.0 * rng.uniform());
        const PathResult path = tracer.trace(f.wi, kLambda, p, rng);
        rays += path.rays;
        ++paths;
        benchmark::DoNotOptimize(path.event);
    }
    state.counters["rays/s"] =
        benchmark::Counter(static_cast<double>(rays), benchmark::Counter::kIsRate);
    state.counters["paths/s"] =
        benchmark::Counter(static_cast<double>(paths), benchmark::Counter::kIsRate);
    state.counters["rays/path"] = static_cast<double>(rays) / static_cast<double>(paths);
    state.SetItemsProcessed(rays);
}

void BM_Tracer(benchmark::State& state) { run_tracer(state, {}); }
BENCHMARK(BM_Tracer)->MinTime(2.0);

void BM_TracerDirectAiry(benchmark::State& state) {
    TracerOptions options;
    options.tabulate_films = false;
    run_tracer(state, options);
}
BENCHMARK(BM_TracerDirectAiry)->MinTime(2.0);

void BM_TracerROnly(benchmark::State& state) {
    TracerOptions options;
    options.max_events = 1;
    run_tracer(state, options);
}
BENCHMARK(BM_TracerROnly)->MinTime(2.0);

void intersect(RTCScene scene, const Vec3d& origin, const Vec3d& direction) {
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    RTCRayHit rh = make_ray_hit(origin, direction);
    rtcIntersect1(scene, &context, &rh);
    benchmark::DoNotOptimize(rh.hit.primID);
}

void BM_BareEmbreeReplay(benchmark::State& state) {
    const Fixture& f = fixture();
    const RTCScene scene = f.scene->embree_scene();
    std::size_t i = 0;
    for (auto _ : state) {
        const RaySegment& r = f.recorded[i];
        intersect(scene, r.origin, r.direction);
        if (++i == f.recorded.size()) i = 0;
    }
    state.counters["rays/s"] =
        benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
    state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_BareEmbreeReplay)->MinTime(2.0);

void BM_BareEmbreePrimary(benchmark::State& state) {
    const Fixture& f = fixture();
    const RTCScene scene = f.scene->embree_scene();
    const ExplicitScatterer tracer(f.scene);
    const double top = tracer.top_z_um();
    std::uint64_t index = 0;
    for (auto _ : state) {
        Rng rng(kSeed, index++);
        const Vec2 p = f.footprint.min_um + Vec2(500.0 * rng.uniform(), 500.0 * rng.uniform());
        intersect(scene, Vec3d(p.x(), p.y(), top), -f.wi);
    }
    state.counters["rays/s"] =
        benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
    state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_BareEmbreePrimary)->MinTime(2.0);

// Collects each benchmark's rays/s to print the ratios at the end.
class RatioReporter final : public benchmark::ConsoleReporter {
public:
    void ReportRuns(const std::vector<Run>& runs) override {
        ConsoleReporter::ReportRuns(runs);
        for (const Run& run : runs) {
            const auto it = run.counters.find("rays/s");
            if (it == run.counters.end()) continue;
            const double rate = it->second.value;  // already per second (kIsRate)
            const std::string name = run.benchmark_name();
            if (name.rfind("BM_TracerDirectAiry", 0) == 0)
                g_tracer_direct_rays = rate;
            else if (name.rfind("BM_TracerROnly", 0) == 0)
                continue;
            else if (name.rfind("BM_Tracer", 0) == 0)
                g_tracer_rays = rate;
            else if (name.rfind("BM_BareEmbreeReplay", 0) == 0)
                g_replay_rays = rate;
            else if (name.rfind("BM_BareEmbreePrimary", 0) == 0)
                g_primary_rays = rate;
        }
    }
};

}  // namespace
}  // namespace plumage::sim

int main(int argc, char** argv) {
    using namespace plumage::sim;
    benchmark::Initialize(&argc, argv);
    if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
    RatioReporter reporter;
    benchmark::RunSpecifiedBenchmarks(&reporter);
    benchmark::Shutdown();
    if (g_tracer_rays > 0.0 && g_replay_rays > 0.0) {
        std::printf("\ntracer / bare Embree (same rays):     %.3f\n",
                    g_tracer_rays / g_replay_rays);
    }
    if (g_tracer_rays > 0.0 && g_primary_rays > 0.0) {
        std::printf("tracer / bare Embree (primary rays):  %.3f\n", g_tracer_rays / g_primary_rays);
    }
    if (g_tracer_direct_rays > 0.0 && g_replay_rays > 0.0) {
        std::printf("tracer without film tables / bare:    %.3f\n",
                    g_tracer_direct_rays / g_replay_rays);
    }
    return 0;
}
