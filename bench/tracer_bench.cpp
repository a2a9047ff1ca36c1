// The full tracer against bare Embree on the same scene, in the same run (issue 4,
// acceptance 4: the tracer should reach at least 0.5 of bare Embree's rays per second;
// issue 15: 0.8).
//
// Scenes, one thread, light at 30° from the patch normal in the x–z plane, 550 nm:
//  - rock dove: the 1 mm × 1 mm barbule patch (geometry::build_barbule_row with Huang's
//    parameters, 80 barbules × 50 cells = 4000 instanced cells, film + melanin);
//  - barb patch: a stork-like vane of the species study (studies/species.toml's stork: clear
//    keratin barbs 40 µm wide with a white medulla, inclined barbules 16 µm wide; 5 barbs ×
//    1 mm, tessellation 0.1 µm / 3°), whose light wanders through dielectric fibres.
//
//  - BM_Tracer*: whole paths (ExplicitScatterer::trace), counting every Embree query a
//    path makes; "rays/s" is queries per second, "paths/s" paths per second.
//  - BM_BareEmbreeReplay: rtcIntersect1 alone on exactly the rays the tracer cast
//    (recorded from the same paths): the same ray mix, so the ratio of the two rays/s is
//    the share of time the tracer spends in Embree.
//  - BM_TracerOverReplay: the two alternating in blocks of 1000 paths in one benchmark, the
//    ratio as a counter (robust to a machine whose load changes between benchmarks).
//  - BM_BareEmbreePrimary: rtcIntersect1 on the primary rays only (coherent in direction,
//    long): the optimistic bare figure.
//  - BM_EmbreeStreamOverSingle: the recorded rays path generation by generation, one call per
//    ray against streams of 64 (rtcIntersect1M): what ray streams could gain on Embree's share.
// After the benchmarks the program prints the ratios.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <limits>
#include <memory>
#include <tuple>
#include <vector>

#include <benchmark/benchmark.h>

#include "common/constants.h"
#include "geometry/barb.h"
#include "geometry/barbule.h"
#include "sim/tracer.h"

namespace plumage::sim {
namespace {

constexpr double kLambda = 550.0;
constexpr std::uint64_t kSeed = 7;
constexpr std::uint64_t kRecordedPaths = 50'000;

struct Fixture {
    std::shared_ptr<const Scene> scene;
    Vec3d wi;
    BeamFootprint footprint;
    std::vector<RaySegment> recorded;     // the tracer's rays, for the replay
    std::vector<std::size_t> path_start;  // where each path's rays begin in `recorded`

    Vec2 position(Rng& rng) const {
        const Vec2 size = footprint.max_um - footprint.min_um;
        const double u = rng.uniform(), v = rng.uniform();
        return footprint.min_um + Vec2(u * size.x(), v * size.y());
    }
};

Fixture record(std::shared_ptr<const Scene> scene, const BeamFootprint& footprint) {
    Fixture out;
    out.scene = std::move(scene);
    out.wi = Vec3d(std::sin(30.0 * kDeg), 0.0, std::cos(30.0 * kDeg));
    out.footprint = footprint;
    const ExplicitScatterer tracer(out.scene);
    for (std::uint64_t i = 0; i < kRecordedPaths; ++i) {
        Rng rng(kSeed, i);
        const Vec2 p = out.position(rng);
        out.path_start.push_back(out.recorded.size());
        tracer.trace(out.wi, kLambda, p, rng, &out.recorded);
    }
    return out;
}

enum SceneKind { kRockDove = 0, kBarbPatch = 1 };

const Fixture& fixture(SceneKind kind) {
    static const Fixture rock_dove = [] {
        geometry::BarbuleRowParams params;
        params.barbules =
            static_cast<int>(std::ceil(1000.0 / (params.H * params.cell.semi_major_um)));
        params.cells_per_barbule = static_cast<int>(std::ceil(1000.0 / params.cell.cell_length_um));
        const geometry::BarbuleRow row = geometry::build_barbule_row(params, {0.01, 0.02});
        return record(std::make_shared<const Scene>(barbule_row_scene(row)),
                      {{-250.0, -250.0}, {250.0, 250.0}});
    }();
    static const Fixture barb_patch = [] {
        geometry::BarbulePatchParams params;
        params.barb.barb_width_um = 40.0;
        params.barb.barb_axis_ratio = 1.25;
        params.barb.medulla_scale = 0.7;
        params.barbule_width_um = 16.0;
        params.barbule_axis_ratio = 0.43589;
        params.barbule_inclination_rad = 20.0 * kDeg;
        params.barbule_length = 7.5;
        params.barbule_separation = 0.3;
        params.barb_spacing = 8.375;
        const geometry::BarbulePatch patch =
            geometry::build_barbule_patch(params, 1000.0, 5, {0.1, 3.0 * kDeg});
        BarbulePatchMaterials materials;
        materials.medulla = constant_albedo(0.8);
        return record(std::make_shared<const Scene>(barbule_patch_scene(patch, materials)),
                      {{-250.0, -0.5 * patch.period_um}, {250.0, 0.5 * patch.period_um}});
    }();
    return kind == kRockDove ? rock_dove : barb_patch;
}

// rays/s per scene, for the ratios printed at the end.
struct Rates {
    double tracer = 0.0, tracer_direct = 0.0, replay = 0.0, primary = 0.0;
};
Rates g_rates[2];
double g_interleaved[2] = {0.0, 0.0};  // BM_TracerOverReplay's ratio

void run_tracer(benchmark::State& state, const TracerOptions& options, SceneKind kind) {
    const Fixture& f = fixture(kind);
    const ExplicitScatterer tracer(f.scene, options);
    std::uint64_t index = 0;
    std::int64_t rays = 0, paths = 0;
    for (auto _ : state) {
        Rng rng(kSeed, index++);
        const Vec2 p = f.position(rng);
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

void BM_Tracer(benchmark::State& state, SceneKind kind) { run_tracer(state, {}, kind); }
BENCHMARK_CAPTURE(BM_Tracer, rock_dove, kRockDove)->MinTime(2.0);
BENCHMARK_CAPTURE(BM_Tracer, barb_patch, kBarbPatch)->MinTime(2.0);

void BM_TracerDirectAiry(benchmark::State& state, SceneKind kind) {
    TracerOptions options;
    options.tabulate_films = false;
    run_tracer(state, options, kind);
}
BENCHMARK_CAPTURE(BM_TracerDirectAiry, rock_dove, kRockDove)->MinTime(2.0);

void BM_TracerROnly(benchmark::State& state, SceneKind kind) {
    TracerOptions options;
    options.max_events = 1;
    run_tracer(state, options, kind);
}
BENCHMARK_CAPTURE(BM_TracerROnly, rock_dove, kRockDove)->MinTime(2.0);

void intersect(RTCScene scene, const Vec3d& origin, const Vec3d& direction) {
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    RTCRayHit rh = make_ray_hit(origin, direction);
    rtcIntersect1(scene, &context, &rh);
    benchmark::DoNotOptimize(rh.hit.primID);
}

void BM_BareEmbreeReplay(benchmark::State& state, SceneKind kind) {
    const Fixture& f = fixture(kind);
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
BENCHMARK_CAPTURE(BM_BareEmbreeReplay, rock_dove, kRockDove)->MinTime(2.0);
BENCHMARK_CAPTURE(BM_BareEmbreeReplay, barb_patch, kBarbPatch)->MinTime(2.0);

// The same ratio measured in one benchmark: blocks of 1000 paths traced, then bare Embree on
// exactly the rays those paths cast, alternating, each block timed in thread CPU time. The ratio
// of BM_Tracer's and BM_BareEmbreeReplay's rates comes from runs seconds apart and moves by
// ±0.04 with the load of a shared machine; alternating blocks see the same load.
double thread_cpu_seconds() {
    timespec t{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
    return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

void BM_TracerOverReplay(benchmark::State& state, SceneKind kind) {
    constexpr std::uint64_t kBlockPaths = 1000;
    const Fixture& f = fixture(kind);
    const ExplicitScatterer tracer(f.scene);
    const RTCScene scene = f.scene->embree_scene();
    std::uint64_t index = 0;  // the recording's paths, in order: path i cast the next rays
    std::size_t next_ray = 0;
    double trace_s = 0.0, replay_s = 0.0;
    std::int64_t rays = 0;
    for (auto _ : state) {
        if (index + kBlockPaths > kRecordedPaths) {
            index = 0;
            next_ray = 0;
        }
        const double t0 = thread_cpu_seconds();
        std::size_t block_rays = 0;
        for (std::uint64_t k = 0; k < kBlockPaths; ++k) {
            Rng rng(kSeed, index++);
            const Vec2 p = f.position(rng);
            const PathResult path = tracer.trace(f.wi, kLambda, p, rng);
            block_rays += static_cast<std::size_t>(path.rays);
            benchmark::DoNotOptimize(path.event);
        }
        const double t1 = thread_cpu_seconds();
        for (std::size_t k = 0; k < block_rays; ++k) {
            const RaySegment& r = f.recorded[next_ray++];
            intersect(scene, r.origin, r.direction);
        }
        const double t2 = thread_cpu_seconds();
        trace_s += t1 - t0;
        replay_s += t2 - t1;
        rays += static_cast<std::int64_t>(block_rays);
    }
    state.counters["tracer rays/s"] = static_cast<double>(rays) / trace_s;
    state.counters["bare rays/s"] = static_cast<double>(rays) / replay_s;
    state.counters["tracer/bare"] = replay_s / trace_s;
    g_interleaved[kind] = replay_s / trace_s;
}
BENCHMARK_CAPTURE(BM_TracerOverReplay, rock_dove, kRockDove)->MinTime(4.0);
BENCHMARK_CAPTURE(BM_TracerOverReplay, barb_patch, kBarbPatch)->MinTime(4.0);

// Ray streams (issue 15's lever rtcIntersect1M), on bare Embree: the tracer's recorded rays in
// the order a stream tracer would cast them (every path's first ray, then every second ray, …:
// paths advancing in lockstep, each generation sorted by direction octant and a 4 µm grid of
// origins, as a stream tracer would), cast one call per ray (rtcIntersect1) and in streams of 64
// (rtcIntersect1M, flagged incoherent, then coherent), alternating in blocks of 64 Ki rays in
// thread CPU time. The speed-ups are what casting in streams could take off Embree's share of
// the tracer's time, at most: with the tracer at 0.72 of bare Embree, Embree would have to run
// 1.16x faster for it to reach 0.8.
void BM_EmbreeStreamOverSingle(benchmark::State& state, SceneKind kind) {
    constexpr std::size_t kBlock = 65536, kStream = 64;
    const Fixture& f = fixture(kind);
    const RTCScene scene = f.scene->embree_scene();
    std::vector<RTCRayHit> lockstep;  // generation by generation
    std::size_t generation_begin = 0;
    for (std::size_t generation = 0;; ++generation) {
        bool any = false;
        for (std::size_t p = 0; p < f.path_start.size(); ++p) {
            const std::size_t end =
                p + 1 < f.path_start.size() ? f.path_start[p + 1] : f.recorded.size();
            const std::size_t i = f.path_start[p] + generation;
            if (i >= end) continue;
            lockstep.push_back(make_ray_hit(f.recorded[i].origin, f.recorded[i].direction));
            any = true;
        }
        if (!any) break;
        // Within a generation, rays close in space and direction side by side (a stream
        // tracer would sort them so): by direction octant, then a 4 µm grid cell of the origin.
        auto key = [](const RTCRayHit& rh) {
            const int octant = (rh.ray.dir_x < 0) + 2 * (rh.ray.dir_y < 0) + 4 * (rh.ray.dir_z < 0);
            const auto cx = static_cast<std::int64_t>(std::floor(rh.ray.org_x / 4.0f));
            const auto cy = static_cast<std::int64_t>(std::floor(rh.ray.org_y / 4.0f));
            return std::tuple(octant, cy, cx);
        };
        std::sort(lockstep.begin() + static_cast<std::ptrdiff_t>(generation_begin), lockstep.end(),
                  [&](const RTCRayHit& a, const RTCRayHit& b) { return key(a) < key(b); });
        generation_begin = lockstep.size();
    }
    auto reset = [](RTCRayHit& rh) {
        rh.ray.tfar = std::numeric_limits<float>::infinity();
        rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
        rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    };
    std::vector<RTCRayHit> block(kBlock);
    std::size_t next = 0;
    // Seconds for the block: one call per ray, streams flagged incoherent, streams coherent.
    std::array<double, 3> seconds{};
    auto cast = [&](int how) {
        std::copy_n(lockstep.begin() + static_cast<std::ptrdiff_t>(next), kBlock, block.begin());
        for (RTCRayHit& rh : block) reset(rh);
        RTCIntersectContext context;
        rtcInitIntersectContext(&context);
        context.flags =
            how == 2 ? RTC_INTERSECT_CONTEXT_FLAG_COHERENT : RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
        const double t0 = thread_cpu_seconds();
        if (how == 0) {
            for (RTCRayHit& rh : block) rtcIntersect1(scene, &context, &rh);
        } else {
            for (std::size_t k = 0; k < kBlock; k += kStream)
                rtcIntersect1M(scene, &context, block.data() + k, kStream, sizeof(RTCRayHit));
        }
        seconds[static_cast<std::size_t>(how)] += thread_cpu_seconds() - t0;
        benchmark::DoNotOptimize(block.back().hit.primID);
    };
    for (auto _ : state) {
        if (next + kBlock > lockstep.size()) next = 0;
        for (int how = 0; how < 3; ++how) cast(how);
        next += kBlock;
    }
    state.counters["incoherent stream speed-up"] = seconds[0] / seconds[1];
    state.counters["coherent stream speed-up"] = seconds[0] / seconds[2];
    state.counters["single rays/s"] = static_cast<double>(state.iterations() * kBlock) / seconds[0];
}
BENCHMARK_CAPTURE(BM_EmbreeStreamOverSingle, rock_dove, kRockDove)->MinTime(4.0);
BENCHMARK_CAPTURE(BM_EmbreeStreamOverSingle, barb_patch, kBarbPatch)->MinTime(4.0);

void BM_BareEmbreePrimary(benchmark::State& state, SceneKind kind) {
    const Fixture& f = fixture(kind);
    const RTCScene scene = f.scene->embree_scene();
    const ExplicitScatterer tracer(f.scene);
    const double top = tracer.top_z_um();
    std::uint64_t index = 0;
    for (auto _ : state) {
        Rng rng(kSeed, index++);
        const Vec2 p = f.position(rng);
        intersect(scene, Vec3d(p.x(), p.y(), top), -f.wi);
    }
    state.counters["rays/s"] =
        benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
    state.SetItemsProcessed(state.iterations());
}
BENCHMARK_CAPTURE(BM_BareEmbreePrimary, rock_dove, kRockDove)->MinTime(2.0);

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
            Rates& r =
                g_rates[name.find("barb_patch") != std::string::npos ? kBarbPatch : kRockDove];
            if (name.rfind("BM_TracerDirectAiry", 0) == 0)
                r.tracer_direct = rate;
            else if (name.rfind("BM_TracerROnly", 0) == 0)
                continue;
            else if (name.rfind("BM_Tracer", 0) == 0)
                r.tracer = rate;
            else if (name.rfind("BM_BareEmbreeReplay", 0) == 0)
                r.replay = rate;
            else if (name.rfind("BM_BareEmbreePrimary", 0) == 0)
                r.primary = rate;
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
    const char* names[] = {"rock dove", "barb patch"};
    for (int k : {kRockDove, kBarbPatch}) {
        const Rates& r = g_rates[k];
        if (r.tracer > 0.0 && r.replay > 0.0) {
            std::printf("%-10s tracer / bare Embree (same rays):     %.3f\n", names[k],
                        r.tracer / r.replay);
        }
        if (g_interleaved[k] > 0.0) {
            std::printf("%-10s tracer / bare Embree (same rays, interleaved): %.3f\n", names[k],
                        g_interleaved[k]);
        }
        if (r.tracer > 0.0 && r.primary > 0.0) {
            std::printf("%-10s tracer / bare Embree (primary rays):  %.3f\n", names[k],
                        r.tracer / r.primary);
        }
        if (r.tracer_direct > 0.0 && r.replay > 0.0) {
            std::printf("%-10s tracer without film tables / bare:    %.3f\n", names[k],
                        r.tracer_direct / r.replay);
        }
    }
    return 0;
}
