// First-Born scattering in flatland (conventions, derivation and parameter table in the
// header).
#include "sim/wave/volume/born_2d.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "common/constants.h"
#include "common/error.h"
#include "sim/wave/volume/index_field.h"

namespace plumage::sim::wave {
namespace {

constexpr int kTrapezoidIntervals = 4096;

void require_wavelength(double lambda_nm) {
    if (!(std::isfinite(lambda_nm) && lambda_nm > 0.0)) {
        throw InputError(fmt::format(
            "2D Born medium: lambda = {} nm: expected a finite wavelength > 0", lambda_nm));
    }
}

void require_dielectric(const char* name, std::complex<double> eps) {
    if (!(std::isfinite(eps.real()) && std::isfinite(eps.imag()) && eps.real() > 0.0 &&
          eps.imag() >= 0.0)) {
        throw InputError(fmt::format(
            "2D effective permittivity: {} = ({}, {}): expected a finite permittivity with Re > 0 "
            "and Im >= 0 (a passive dielectric)",
            name, eps.real(), eps.imag()));
    }
}

}  // namespace

std::string_view polarisation_name(Polarisation2d pol) {
    return pol == Polarisation2d::te ? "TE" : "TM";
}

FlatlandTable integrate_flatland(const std::function<double(double)>& dmu_dtheta,
                                 int table_points) {
    if (table_points < 2 || table_points > 100000) {
        throw InputError(fmt::format(
            "flatland medium: table_points = {}: expected 2 to 100000 phase-function entries",
            table_points));
    }
    // Trapezoid on [0, π]: end points with weight ½; ×2 for θ ∈ [−π, 0].
    const double step = kPi / kTrapezoidIntervals;
    double total = 0.0, first_moment = 0.0;
    for (int i = 0; i <= kTrapezoidIntervals; ++i) {
        const double theta = step * i;
        const double value = dmu_dtheta(theta);
        PLUMAGE_CHECK(std::isfinite(value) && value >= 0.0,
                      fmt::format("dmu_s/dtheta = {} at theta = {}", value, theta));
        const double w = (i == 0 || i == kTrapezoidIntervals) ? 0.5 : 1.0;
        total += w * value;
        first_moment += w * std::cos(theta) * value;
    }
    FlatlandTable t;
    t.mu_s_per_um = 2.0 * step * total;
    t.g = total > 0.0 ? first_moment / total : 0.0;
    t.theta_rad.resize(table_points);
    t.phase_per_rad.resize(table_points);
    for (int i = 0; i < table_points; ++i) {
        const double theta = kPi * i / (table_points - 1);
        t.theta_rad[i] = theta;
        t.phase_per_rad[i] = t.mu_s_per_um > 0.0 ? dmu_dtheta(theta) / t.mu_s_per_um : 0.0;
    }
    return t;
}

std::complex<double> effective_permittivity_2d(std::complex<double> eps1, std::complex<double> eps2,
                                               double f, Polarisation2d pol) {
    require_dielectric("eps1", eps1);
    require_dielectric("eps2", eps2);
    if (!(f >= 0.0 && f <= 1.0)) {
        throw InputError(fmt::format(
            "2D effective permittivity: f = {}: expected an area fraction in [0, 1]", f));
    }
    if (pol == Polarisation2d::te) return f * eps1 + (1.0 - f) * eps2;
    if (f == 0.0) return eps2;
    if (f == 1.0) return eps1;
    // ε² − b ε − ε1 ε2 = 0: the roots' product is −ε1 ε2, so for dielectrics one root has
    // Re > 0 and (for lossy components) Im >= 0, the other the opposite; take the passive one.
    const std::complex<double> b = (2.0 * f - 1.0) * (eps1 - eps2);
    const std::complex<double> root = std::sqrt(b * b + 4.0 * eps1 * eps2);
    const std::complex<double> plus = 0.5 * (b + root), minus = 0.5 * (b - root);
    const std::complex<double> eps = plus.real() > minus.real() ? plus : minus;
    PLUMAGE_CHECK(eps.real() > 0.0 && eps.imag() >= -1e-13 * std::abs(eps),
                  fmt::format("2D Bruggeman root ({}, {}) is not a passive dielectric", eps.real(),
                              eps.imag()));
    return {eps.real(), std::max(0.0, eps.imag())};
}

FlatlandTable born_scattering_2d(const std::function<double(double)>& spectrum, double eps_contrast,
                                 double n_eff, double lambda_nm, Polarisation2d pol,
                                 int table_points) {
    require_wavelength(lambda_nm);
    if (!(std::isfinite(n_eff) && n_eff > 0.0)) {
        throw InputError(fmt::format(
            "2D Born medium: n_eff = {}: expected a finite background index > 0", n_eff));
    }
    if (!(std::isfinite(eps_contrast) && eps_contrast != 0.0)) {
        throw InputError(fmt::format(
            "2D Born medium: eps_contrast = {}: expected a finite, non-zero eps_k - eps_a",
            eps_contrast));
    }
    const double k0 = kTwoPi / (lambda_nm * 1e-3);
    const double k = k0 * n_eff;
    const double prefactor = std::pow(k0, 4) * eps_contrast * eps_contrast / (8.0 * kPi * k);
    auto dmu = [&](double theta) {
        const double q = 2.0 * k * std::sin(0.5 * theta);
        const double c = std::cos(theta);
        const double dipole = pol == Polarisation2d::te ? 1.0 : c * c;
        const double s = spectrum(q);
        if (!(std::isfinite(s) && s >= 0.0)) {
            throw InputError(fmt::format(
                "2D Born medium: spectrum S({} 1/um) = {} um^2: expected finite values >= 0", q,
                s));
        }
        return prefactor * s * dipole;
    };
    FlatlandTable t = integrate_flatland(dmu, table_points);
    t.lambda_nm = lambda_nm;
    t.polarisation = pol;
    t.n_eff = n_eff;
    return t;
}

FlatlandTable born_flatland(const PowerSpectrum& spectrum, const optics::Material& keratin,
                            const optics::Material& air, double lambda_nm, Polarisation2d pol,
                            int table_points) {
    require_wavelength(lambda_nm);
    if (spectrum.dimension() != 2) {
        throw InputError(
            fmt::format("2D Born medium: a {}D power spectrum: expected a 2D one (measure_2d)",
                        spectrum.dimension()));
    }
    const double f = spectrum.filling_fraction();
    if (!(f > 0.0 && f < 1.0)) {
        throw InputError(fmt::format(
            "2D Born medium: keratin area fraction f = {}: expected 0 < f < 1 (a field without "
            "both components has no contrast)",
            f));
    }
    const double n_k = keratin.index(lambda_nm).real(), n_a = air.index(lambda_nm).real();
    if (n_k == n_a) {
        throw InputError(fmt::format(
            "2D Born medium: {} and {} have the same index {} at lambda = {} nm: expected an "
            "index contrast",
            keratin.name(), air.name(), n_k, lambda_nm));
    }
    require_resolved(spectrum.voxel_um(), lambda_nm, std::max(n_k, n_a));
    const double eps_k = n_k * n_k, eps_a = n_a * n_a;
    const double n_eff = std::sqrt(effective_permittivity_2d(eps_k, eps_a, f, pol).real());
    const RadialSpectrum radial = spectrum.radial();
    auto interpolate = [&radial](double q) { return radial.at(q); };
    return born_scattering_2d(interpolate, eps_k - eps_a, n_eff, lambda_nm, pol, table_points);
}

}  // namespace plumage::sim::wave
