#include "sim/optics/spectrum.h"

#include <cmath>

#include <fmt/format.h>

#include "common/error.h"

namespace plumage::optics {

WavelengthGrid::WavelengthGrid(std::vector<double> wavelengths_nm)
    : nm_(std::move(wavelengths_nm)) {
    if (nm_.empty()) throw InputError("wavelength grid is empty: expected at least one wavelength");
    for (std::size_t i = 0; i < nm_.size(); ++i) {
        if (!std::isfinite(nm_[i]) || !(nm_[i] > 0.0)) {
            throw InputError(fmt::format(
                "wavelength grid entry {} = {} nm: expected a finite positive wavelength", i,
                nm_[i]));
        }
        if (i > 0 && !(nm_[i] > nm_[i - 1])) {
            throw InputError(fmt::format(
                "wavelength grid entry {} = {} nm follows {} nm: expected strictly increasing "
                "wavelengths",
                i, nm_[i], nm_[i - 1]));
        }
    }
}

WavelengthGrid WavelengthGrid::uniform(double first_nm, double last_nm, double step_nm) {
    if (!std::isfinite(first_nm) || !std::isfinite(last_nm) || !std::isfinite(step_nm) ||
        !(step_nm > 0.0) || !(last_nm >= first_nm)) {
        throw InputError(
            fmt::format("uniform wavelength grid {}..{} nm step {} nm: expected finite values with "
                        "first <= last and step > 0",
                        first_nm, last_nm, step_nm));
    }
    const double wanted = uniform_count(first_nm, last_nm, step_nm);
    if (!(wanted <= static_cast<double>(kMaxWavelengths))) {
        throw InputError(fmt::format(
            "uniform wavelength grid {}..{} nm step {} nm gives {:.3g} wavelengths: expected at "
            "most {} (step_nm >= {:.4g})",
            first_nm, last_nm, step_nm, wanted, kMaxWavelengths,
            (last_nm - first_nm) / static_cast<double>(kMaxWavelengths - 1)));
    }
    const auto count = static_cast<std::size_t>(wanted);
    std::vector<double> nm(count);
    for (std::size_t i = 0; i < count; ++i) nm[i] = first_nm + static_cast<double>(i) * step_nm;
    return WavelengthGrid(std::move(nm));
}

double WavelengthGrid::uniform_count(double first_nm, double last_nm, double step_nm) {
    return std::floor((last_nm - first_nm) / step_nm + 1e-9) + 1.0;
}

double interpolate_uniform_table(std::span<const double> table, double first_nm, double step_nm,
                                 double lambda_nm) {
    const double x = (lambda_nm - first_nm) / step_nm;
    const double last = static_cast<double>(table.size() - 1);
    if (!(x >= 0.0) || x > last) return 0.0;
    const auto i = static_cast<std::size_t>(std::floor(x));
    if (i + 1 >= table.size()) return table.back();
    const double f = x - static_cast<double>(i);
    return (1.0 - f) * table[i] + f * table[i + 1];
}

}  // namespace plumage::optics
