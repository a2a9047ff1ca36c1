// Physical optics in 2D (issue 16): the far field of a rock-dove barbule row.
//
//  - BM_PhysicalOpticsRow/threads: 8 barbules of the rock-dove arc (A = 10 µm, b = 0.25,
//    φ ∈ [−0.37, 2.64], film 0.59 µm over a 0.3 µm air gap over melanin), spacing H A = 12.5 µm,
//    tilt μ = −0.35 rad, no jitter; θ_i = 20°; 181 outgoing angles on [−90°, 90°]; 7 wavelengths
//    400–700 nm; TE and TM (14 far fields per iteration). Sampling at λ/10 per wavelength
//    (3900–6900 samples for the row), the lit test, one transfer matrix per lit sample and the
//    O(samples × angles) sum are all inside the timing. `threads` OpenMP threads.
//  - BM_PhysicalOpticsRowVisibility/threads: one of those far fields (550 nm, TE, reflected
//    part) with outgoing visibility.
//  - BM_PhysicalOpticsHybridRow/threads (issue 36): the same row, angles, wavelengths and
//    polarisations through physical_optics_hybrid_2d.h, each barbule a closed keratin sheet over
//    its 0.3 µm gap and a melanin core that transmits (barbule_with_gap: the whole ellipse, not
//    the arc; 16 µm apart, as whole ellipses 12.5 µm apart would overlap at this tilt), with
//    every path through the films, the gaps and the cores up to 16 interfaces;
//    the scattering width's circle integral off (circle_angles = 0).
//  - BM_PhysicalOpticsHybridRowPair/threads: the same, TE and TM together
//    (hybrid_far_field_pair: 7 calls, one set of rays and one sum per wavelength).
#include <cmath>
#include <numbers>
#include <vector>

#include <benchmark/benchmark.h>
#include <omp.h>

#include "sim/wave/surface/physical_optics_2d.h"
#include "sim/wave/surface/physical_optics_hybrid_2d.h"

namespace plumage::sim::wave {
namespace {

Row2d rock_dove_row() {
    Row2d row;
    row.cell = barbule_arc(geometry::EllipticalArc(10.0, 2.5, -0.37, 2.64), 0.59, 0.3);
    row.count = 8;
    row.spacing_um = 1.25 * 10.0;
    row.tilt_rad = -0.35;
    return row;
}

void BM_PhysicalOpticsRow(benchmark::State& state) {
    const int threads = static_cast<int>(state.range(0));
    const int saved = omp_get_max_threads();
    omp_set_num_threads(threads);
    const Row2d row = rock_dove_row();
    std::vector<double> theta(181);
    for (int m = 0; m < 181; ++m) theta[m] = (m - 90) * std::numbers::pi / 180.0;
    const double theta_i = 20.0 * std::numbers::pi / 180.0;
    for (auto _ : state) {
        for (int l = 0; l < 7; ++l) {
            const double lambda = 400.0 + 50.0 * l;
            for (Polarisation2d pol : {Polarisation2d::te, Polarisation2d::tm}) {
                const std::vector<double> sigma =
                    scattering_width(row, {lambda, theta_i, pol}, theta);
                benchmark::DoNotOptimize(sigma.data());
            }
        }
    }
    omp_set_num_threads(saved);
}
BENCHMARK(BM_PhysicalOpticsRow)->Arg(1)->Arg(2)->UseRealTime()->Unit(benchmark::kMillisecond);

// The same row, one far field (550 nm, TE, reflected part) with outgoing visibility: one ray
// cast per lit sample and angle.
void BM_PhysicalOpticsRowVisibility(benchmark::State& state) {
    const int threads = static_cast<int>(state.range(0));
    const int saved = omp_get_max_threads();
    omp_set_num_threads(threads);
    const Row2d row = rock_dove_row();
    std::vector<double> theta(181);
    for (int m = 0; m < 181; ++m) theta[m] = (m - 90) * std::numbers::pi / 180.0;
    PhysicalOpticsOptions options;
    options.part = FarFieldPart::reflected;
    options.outgoing_visibility = true;
    for (auto _ : state) {
        const std::vector<double> sigma = scattering_width(
            row, {550.0, 20.0 * std::numbers::pi / 180.0, Polarisation2d::te}, theta, options);
        benchmark::DoNotOptimize(sigma.data());
    }
    omp_set_num_threads(saved);
}
BENCHMARK(BM_PhysicalOpticsRowVisibility)
    ->Arg(1)
    ->Arg(2)
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);

// The hybrid's row: each barbule closed, its sheet over the gap and a melanin core.
CrossSection2d hybrid_row() {
    Row2d row = rock_dove_row();
    row.cell = barbule_with_gap(10.0, 0.25, 0.59, 0.3);
    row.spacing_um = 16.0;  // whole ellipses 12.5 µm apart at this tilt would overlap
    return row_cross_section(row);
}

std::vector<double> every_degree() {
    std::vector<double> theta(181);
    for (int m = 0; m < 181; ++m) theta[m] = (m - 90) * std::numbers::pi / 180.0;
    return theta;
}

// The hybrid row's 7 wavelengths × TE and TM, in 14 calls or in 7 pairs.
void hybrid_row_fields(benchmark::State& state, bool pair) {
    const int threads = static_cast<int>(state.range(0));
    const int saved = omp_get_max_threads();
    omp_set_num_threads(threads);
    const CrossSection2d section = hybrid_row();
    const std::vector<double> theta = every_degree();
    HybridOptions options;
    options.circle_angles = 0;
    const double theta_i = 20.0 * std::numbers::pi / 180.0;
    std::size_t elements = 0, fields = 0;
    for (auto _ : state) {
        for (int l = 0; l < 7; ++l) {
            const double lambda = 400.0 + 50.0 * l;
            if (pair) {
                const HybridFarFieldPair far =
                    hybrid_far_field_pair(section, lambda, theta_i, theta, options);
                elements += far.te.elements;
                ++fields;
                benchmark::DoNotOptimize(far.te.u.data());
                benchmark::DoNotOptimize(far.tm.u.data());
                continue;
            }
            for (Polarisation2d pol : {Polarisation2d::te, Polarisation2d::tm}) {
                const HybridFarField2d far =
                    hybrid_far_field(section, {lambda, theta_i, pol}, theta, options);
                elements += far.elements;
                ++fields;
                benchmark::DoNotOptimize(far.u.data());
            }
        }
    }
    state.counters["elements_per_field"] =
        static_cast<double>(elements) / static_cast<double>(fields);
    omp_set_num_threads(saved);
}

void BM_PhysicalOpticsHybridRow(benchmark::State& state) { hybrid_row_fields(state, false); }
BENCHMARK(BM_PhysicalOpticsHybridRow)->Arg(1)->Arg(2)->UseRealTime()->Unit(benchmark::kMillisecond);

void BM_PhysicalOpticsHybridRowPair(benchmark::State& state) { hybrid_row_fields(state, true); }
BENCHMARK(BM_PhysicalOpticsHybridRowPair)
    ->Arg(1)
    ->Arg(2)
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace plumage::sim::wave

BENCHMARK_MAIN();
