// Bruggeman and Maxwell-Garnett effective permittivities (conventions in the header).
//
// Parameter table:
//  | name        | unit | valid range                                        |
//  |-------------|------|----------------------------------------------------|
//  | eps1, eps2  | 1    | finite, Re > 0, Im >= 0 (passive dielectrics)       |
//  | f           | 1    | [0, 1], volume fraction of component 1             |
#include "sim/wave/volume/effective_index.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "common/error.h"

namespace plumage::sim::wave {
namespace {

void require_dielectric(const char* what, const char* name, Complex eps) {
    if (!(std::isfinite(eps.real()) && std::isfinite(eps.imag()) && eps.real() > 0.0 &&
          eps.imag() >= 0.0)) {
        throw InputError(fmt::format(
            "{}: {} = ({}, {}): expected a finite permittivity with Re > 0 and Im >= 0 (a "
            "passive dielectric; the root selection is not valid for metals)",
            what, name, eps.real(), eps.imag()));
    }
}

void require_fraction(const char* what, double f) {
    if (!(f >= 0.0 && f <= 1.0)) {
        throw InputError(fmt::format("{}: f = {}: expected a volume fraction in [0, 1]", what, f));
    }
}

}  // namespace

Complex bruggeman_permittivity(Complex eps1, Complex eps2, double f) {
    constexpr const char* kWhat = "Bruggeman effective permittivity";
    require_dielectric(kWhat, "eps1", eps1);
    require_dielectric(kWhat, "eps2", eps2);
    require_fraction(kWhat, f);
    // The end points exactly: the quadratic's roots there are ε_i and −ε_j/2, and the
    // formula below would return them only up to round-off.
    if (f == 0.0) return eps2;
    if (f == 1.0) return eps1;
    const Complex b = (3.0 * f - 1.0) * eps1 + (2.0 - 3.0 * f) * eps2;
    const Complex root = std::sqrt(b * b + 8.0 * eps1 * eps2);
    const Complex plus = (b + root) / 4.0;
    const Complex minus = (b - root) / 4.0;
    // Lossless components: both roots real (to round-off), take the positive one. Otherwise
    // the passive one, Im >= 0; the other root then has Im <= 0 (product −ε1ε2/2).
    const double scale = std::abs(plus) + std::abs(minus);
    const double tiny = 1e-13 * scale;
    Complex eps;
    if (std::abs(plus.imag()) <= tiny && std::abs(minus.imag()) <= tiny) {
        eps = plus.real() > minus.real() ? plus : minus;
        eps.imag(std::max(0.0, eps.imag()));
    } else {
        eps = plus.imag() > minus.imag() ? plus : minus;
    }
    PLUMAGE_CHECK(
        eps.real() > 0.0 && eps.imag() >= -tiny,
        fmt::format("Bruggeman root ({}, {}) is not a passive dielectric", eps.real(), eps.imag()));
    return eps;
}

Complex maxwell_garnett_permittivity(Complex eps_inclusion, Complex eps_host, double f) {
    constexpr const char* kWhat = "Maxwell-Garnett effective permittivity";
    require_dielectric(kWhat, "eps_inclusion", eps_inclusion);
    require_dielectric(kWhat, "eps_host", eps_host);
    require_fraction(kWhat, f);
    const Complex beta = (eps_inclusion - eps_host) / (eps_inclusion + 2.0 * eps_host);
    return eps_host * (1.0 + 2.0 * f * beta) / (1.0 - f * beta);
}

Complex bruggeman_index(Complex n1, Complex n2, double f) {
    // std::sqrt takes the principal root: Re >= 0, and Im >= 0 when Im ε >= 0.
    return std::sqrt(bruggeman_permittivity(n1 * n1, n2 * n2, f));
}

}  // namespace plumage::sim::wave
