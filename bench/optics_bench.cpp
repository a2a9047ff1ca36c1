// Throughput of the spectral thin-film optics: evaluations per second of the Airy
// film, the transfer-matrix solver (coherent and with an incoherent layer), and the
// spectrum → XYZ integration. Wavelength and angle vary per iteration so that no
// result is cached by the compiler.
#include <cmath>
#include <vector>

#include <benchmark/benchmark.h>

#include "sim/optics/colour.h"
#include "sim/optics/multilayer.h"
#include "sim/optics/thin_film.h"

namespace plumage::optics {
namespace {

double wavelength(std::size_t i) { return 380.0 + static_cast<double>(i % 401); }
double cosine(std::size_t i) { return 0.05 + 0.95 * static_cast<double>(i % 97) / 96.0; }

// A 0.595 µm keratin film over `media`, at wavelengths and angles that change every call.
void airy_film_rate(benchmark::State& state, const FilmMedia& media) {
    std::size_t i = 0;
    for (auto _ : state) {
        benchmark::DoNotOptimize(
            airy_film_intensities_unpolarised(media, 0.595, wavelength(i), cosine(i)));
        ++i;
    }
    state.SetItemsProcessed(state.iterations());
}

// Over absorbing melanin: the general (complex) path.
void BM_AiryFilmUnpolarised(benchmark::State& state) {
    airy_film_rate(state, {1.0, Complex(1.55), Complex(1.74, 0.088)});
}
BENCHMARK(BM_AiryFilmUnpolarised);

// The Huang 2022 model's film: lossless keratin in air (real indices throughout), the
// case of every facet node and wavelength of its tabulation.
void BM_AiryFilmUnpolarisedLossless(benchmark::State& state) {
    airy_film_rate(state, {1.0, Complex(1.55), Complex(1.0)});
}
BENCHMARK(BM_AiryFilmUnpolarisedLossless);

void BM_TransferMatrixUnpolarised(benchmark::State& state) {
    std::vector<StackLayer> layers;
    for (int j = 0; j < state.range(0); ++j) {
        layers.push_back({j % 2 == 0 ? Complex(1.55) : Complex(1.74, 0.088), 0.1 + 0.01 * j});
    }
    std::size_t i = 0;
    for (auto _ : state) {
        benchmark::DoNotOptimize(transfer_matrix_intensities_unpolarised(
            {1.0, layers, Complex(1.0)}, wavelength(i), cosine(i)));
        ++i;
    }
    state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_TransferMatrixUnpolarised)->Arg(1)->Arg(5)->Arg(20);

void BM_TransferMatrixWithIncoherentLayer(benchmark::State& state) {
    const std::vector<StackLayer> layers = {{Complex(1.55), 0.595},
                                            {Complex(1.55, 1e-4), 50.0, Coherence::incoherent},
                                            {Complex(1.74, 0.088), 0.3}};
    std::size_t i = 0;
    for (auto _ : state) {
        benchmark::DoNotOptimize(transfer_matrix_intensities_unpolarised(
            {1.0, layers, Complex(1.0)}, wavelength(i), cosine(i)));
        ++i;
    }
    state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_TransferMatrixWithIncoherentLayer);

void BM_ReflectanceToXyz81(benchmark::State& state) {
    const auto grid = WavelengthGrid::uniform(380.0, 780.0, 5.0);
    const ReflectanceToXyz to_xyz(grid, Illuminant::d65);
    std::vector<double> r(grid.size());
    for (std::size_t k = 0; k < r.size(); ++k)
        r[k] = 0.5 + 0.4 * std::sin(0.1 * static_cast<double>(k));
    for (auto _ : state) {
        benchmark::DoNotOptimize(to_xyz(r));
        r[0] += 1e-12;
    }
    state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_ReflectanceToXyz81);

}  // namespace
}  // namespace plumage::optics

BENCHMARK_MAIN();
