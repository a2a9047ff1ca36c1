#include "common/require.h"

#include <fmt/format.h>

#include <cmath>
#include <string>

#include "common/error.h"

namespace plumage {

void require(bool ok, std::string_view what, std::string_view message) {
    if (!ok) throw InputError(std::string(what) + ": " + std::string(message));
}

void require(bool ok, std::string_view what, std::string_view key, double value,
             std::string_view expected) {
    if (!ok) throw InputError(fmt::format("{}: {} = {}: expected {}", what, key, value, expected));
}

void require_wavelengths(std::span<const double> wavelengths_nm, std::string_view what) {
    require(
        !wavelengths_nm.empty() && wavelengths_nm.size() <= kMaxWavelengths, what,
        fmt::format("{} wavelengths: expected 1 to {}", wavelengths_nm.size(), kMaxWavelengths));
    for (std::size_t k = 0; k < wavelengths_nm.size(); ++k) {
        const double l = wavelengths_nm[k];
        require(std::isfinite(l) && l > 0.0, what,
                fmt::format("wavelength {} = {} nm: expected a finite value > 0", k, l));
    }
}

}  // namespace plumage
