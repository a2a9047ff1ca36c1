// The colour error of a spectral grid: how far the colour computed from a spectrum sampled
// on a study's wavelengths (trapezoidal rule, sim/optics/colour.h) is from the colour of the
// same spectrum integrated at 1 nm over the same span. Thin keratin films oscillate in λ
// (period λ²/(2nd) ≈ 180 nm at 550 nm for d = 0.59 µm), so a 50 nm grid misplaces their hue
// by ΔE00 up to ~8; a 25 nm grid keeps it below 1 (measured in tests/analysis).
//
// The spectra come from a callable, spectrum index and wavelength → reflectance factor
// (π·f for a BRDF, R for a film), evaluated on both grids, in parallel over spectra. An
// analytic model is the natural source: its spectra are exact at every wavelength, so the
// error is the grid's alone. Each spectrum's ΔE00 goes into the mean, the 95th percentile
// and the maximum.
#pragma once

#include <cstddef>
#include <functional>
#include <span>

#include "sim/optics/spectrum.h"

namespace plumage::analysis {

struct ColourQuadratureError {
    double mean = 0.0, p95 = 0.0, max = 0.0;
    std::size_t spectra = 0;
    double reference_step_nm = 1.0;
};

// The sampling both quadrature errors share (this one in colour, analysis/metrics/avian_compare.h's
// in a bird's cone catches): for each spectrum i, in parallel over spectra (each thread its own
// buffers), `compare(i, coarse, dense)` with reflectance(i, λ) on `grid` and on `fine`.
// `compare` writes only what belongs to spectrum i.
void for_each_spectrum_on_two_grids(std::size_t spectra, const optics::WavelengthGrid& grid,
                                    const optics::WavelengthGrid& fine,
                                    const std::function<double(std::size_t, double)>& reflectance,
                                    const std::function<void(std::size_t, std::span<const double>,
                                                             std::span<const double>)>& compare);

// `reflectance(i, λ)` must be safe to call from several threads at once. Throws InputError
// if the grid cannot carry colour (ReflectanceToXyz) or has fewer than two wavelengths.
ColourQuadratureError colour_quadrature_error(
    std::size_t spectra, const optics::WavelengthGrid& grid,
    const std::function<double(std::size_t, double)>& reflectance);

}  // namespace plumage::analysis
