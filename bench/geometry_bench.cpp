// Geometry construction: time and memory of a 1 mm × 1 mm rock-dove barbule patch
// built with instancing (issue target: under 200 MB), and of the cell tessellation at
// several tolerances. Memory is reported as counters (bytes of meshes + transforms).
#include <cmath>

#include <benchmark/benchmark.h>

#include "geometry/barbule.h"

namespace plumage::geometry {
namespace {

void BM_MillimetreRockDovePatch(benchmark::State& state) {
    BarbuleRowParams params;
    params.barbules = static_cast<int>(std::ceil(1000.0 / (params.H * params.cell.semi_major_um)));
    params.cells_per_barbule = static_cast<int>(std::ceil(1000.0 / params.cell.cell_length_um));
    const TessellationTolerance tolerance{0.01, 0.02};
    std::size_t bytes = 0, triangles = 0, instances = 0;
    for (auto _ : state) {
        const BarbuleRow row = build_barbule_row(params, tolerance);
        bytes = row.memory_bytes();
        triangles = row.cell_film.triangles.size() + row.cell_melanin.triangles.size();
        instances = row.instances.size();
        benchmark::DoNotOptimize(bytes);
    }
    state.counters["bytes"] = static_cast<double>(bytes);
    state.counters["unit_triangles"] = static_cast<double>(triangles);
    state.counters["instances"] = static_cast<double>(instances);
    state.counters["flattened_triangles"] = static_cast<double>(triangles * instances);
}
BENCHMARK(BM_MillimetreRockDovePatch)->Unit(benchmark::kMillisecond);

void BM_CellTessellation(benchmark::State& state) {
    const BarbuleCell cell({});
    const double chord = 1.0 / static_cast<double>(state.range(0));
    std::size_t triangles = 0;
    for (auto _ : state) {
        const TriangleMesh mesh = cell.tessellate({chord, 0.02});
        triangles = mesh.triangles.size();
        benchmark::DoNotOptimize(triangles);
    }
    state.counters["triangles"] = static_cast<double>(triangles);
    state.SetLabel("max chord 1/" + std::to_string(state.range(0)) + " um");
}
BENCHMARK(BM_CellTessellation)->Arg(10)->Arg(100)->Arg(1000)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace plumage::geometry

BENCHMARK_MAIN();
