#include "analysis/metrics/colour_quadrature.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "common/error.h"
#include "sim/optics/colour.h"

namespace plumage::analysis {

void for_each_spectrum_on_two_grids(std::size_t spectra, const optics::WavelengthGrid& grid,
                                    const optics::WavelengthGrid& fine,
                                    const std::function<double(std::size_t, double)>& reflectance,
                                    const std::function<void(std::size_t, std::span<const double>,
                                                             std::span<const double>)>& compare) {
#pragma omp parallel
    {
        std::vector<double> coarse(grid.size()), dense(fine.size());
#pragma omp for schedule(dynamic, 8)
        for (std::size_t i = 0; i < spectra; ++i) {
            for (std::size_t k = 0; k < grid.size(); ++k) coarse[k] = reflectance(i, grid[k]);
            for (std::size_t k = 0; k < fine.size(); ++k) dense[k] = reflectance(i, fine[k]);
            compare(i, coarse, dense);
        }
    }
}

ColourQuadratureError colour_quadrature_error(
    std::size_t spectra, const optics::WavelengthGrid& grid,
    const std::function<double(std::size_t, double)>& reflectance) {
    if (grid.size() < 2) {
        throw InputError("colour quadrature error: a grid of one wavelength carries no colour");
    }
    ColourQuadratureError e;
    // 1 nm over the grid's own span: the error of sampling, not of the span.
    const double step = e.reference_step_nm;
    const optics::WavelengthGrid fine = optics::WavelengthGrid::uniform(
        grid.first(), grid.first() + step * std::floor((grid.last() - grid.first()) / step), step);
    const optics::ReflectanceToXyz coarse_xyz(grid, optics::Illuminant::d65),
        fine_xyz(fine, optics::Illuminant::d65);
    std::vector<double> delta(spectra, 0.0);
    for_each_spectrum_on_two_grids(
        spectra, grid, fine, reflectance,
        [&](std::size_t i, std::span<const double> coarse, std::span<const double> dense) {
            delta[i] =
                optics::ciede2000(optics::lab_from_xyz(fine_xyz(dense), fine_xyz.white()),
                                  optics::lab_from_xyz(coarse_xyz(coarse), coarse_xyz.white()));
        });
    e.spectra = spectra;
    if (spectra == 0) return e;
    double total = 0.0;
    for (double d : delta) total += d;
    e.mean = total / static_cast<double>(spectra);
    std::vector<double> sorted = delta;
    std::sort(sorted.begin(), sorted.end());
    e.max = sorted.back();
    e.p95 = sorted[static_cast<std::size_t>(std::ceil(0.95 * static_cast<double>(spectra))) - 1];
    return e;
}

}  // namespace plumage::analysis
