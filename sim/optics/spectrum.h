// Wavelength grids and sampled spectra. Wavelengths are in nanometres (vacuum).
//
// A grid is any strictly increasing list of finite positive wavelengths. It is not
// restricted to the visible range (birds see UV); only colour conversion (colour.h)
// requires the grid to lie within 300–830 nm (colour.h: UV below 360 nm has weight 0).
#pragma once

#include <cstddef>
#include <span>
#include <vector>

#include "common/require.h"

namespace plumage::optics {

class WavelengthGrid {
public:
    // Throws InputError naming the first offending entry if the list is empty, not
    // finite, not positive or not strictly increasing.
    explicit WavelengthGrid(std::vector<double> wavelengths_nm);

    // first, first + step, ..., up to last (inclusive when last − first is a whole
    // number of steps, to within 1e-9 of a step). At most kMaxWavelengths entries: a step
    // too small for the range is an InputError naming the bound, before any allocation.
    static WavelengthGrid uniform(double first_nm, double last_nm, double step_nm);
    // 0.1 nm across 360–830 nm (common/require.h, every measurement's rule); far beyond any
    // spectral quadrature a study needs, and small enough that a mistyped step cannot exhaust
    // memory.
    static constexpr std::size_t kMaxWavelengths = plumage::kMaxWavelengths;
    // The count uniform() would give, as a double (no overflow for any finite input).
    static double uniform_count(double first_nm, double last_nm, double step_nm);

    std::size_t size() const { return nm_.size(); }
    double operator[](std::size_t i) const { return nm_[i]; }
    std::span<const double> nm() const { return nm_; }
    double first() const { return nm_.front(); }
    double last() const { return nm_.back(); }

private:
    std::vector<double> nm_;
};

// Linear interpolation in a table sampled at first_nm + i * step_nm; zero outside.
double interpolate_uniform_table(std::span<const double> table, double first_nm, double step_nm,
                                 double lambda_nm);

}  // namespace plumage::optics
