// First-Born and sphere-route scattering tables (conventions in the header).
//
// Parameter table:
//  | name                   | unit  | valid range                                        |
//  |------------------------|-------|----------------------------------------------------|
//  | lambda_nm              | nm    | finite, > 0, in the materials' range               |
//  | table_points           | 1     | [2, 100000]                                        |
//  | spectrum S̄(q)          | µm³   | finite, >= 0 (Born route)                          |
//  | voxel_um (of spectrum) | µm    | <= λ / (4 n_max)                                   |
//  | filling fraction f     | 1     | (0, 1)                                             |
//  | radius_um              | µm    | finite, > 0 (sphere route)                         |
//  | number_density_per_um3 | µm⁻³  | > 0 with φ = ρ 4π a³/3 in (0, 1)                   |
//  | structure_factor S(q)  | 1     | finite, >= 0                                       |
#include "sim/wave/volume/born_medium.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <fmt/format.h>

#include "common/constants.h"
#include "common/error.h"
#include "common/gauss_legendre.h"
#include "sim/wave/volume/effective_index.h"
#include "sim/wave/volume/index_field.h"
#include "sim/wave/volume/mie.h"

namespace plumage::sim::wave {
namespace {

constexpr int kQuadratureNodes = 512;

// The 512-node rule, computed once.
const GaussLegendreRule& angle_rule() {
    static const GaussLegendreRule rule = gauss_legendre(kQuadratureNodes);
    return rule;
}

void require_wavelength(double lambda_nm) {
    if (!(std::isfinite(lambda_nm) && lambda_nm > 0.0)) {
        throw InputError(fmt::format(
            "wave medium: lambda = {} nm: expected a finite wavelength > 0", lambda_nm));
    }
}

double absorption_per_um(std::complex<double> n_eff, double lambda_nm) {
    return 4.0 * kPi * n_eff.imag() / (lambda_nm * 1e-3);
}

}  // namespace

ScatteringTable integrate_differential(const std::function<double(double)>& dsigma_domega,
                                       int table_points) {
    if (table_points < 2 || table_points > 100000) {
        throw InputError(fmt::format(
            "wave medium: table_points = {}: expected 2 to 100000 phase-function entries",
            table_points));
    }
    const GaussLegendreRule& rule = angle_rule();
    double total = 0.0, first_moment = 0.0;
    for (std::size_t i = 0; i < rule.nodes.size(); ++i) {
        const double value = dsigma_domega(rule.nodes[i]);
        PLUMAGE_CHECK(std::isfinite(value) && value >= 0.0,
                      fmt::format("dsigma/dOmega = {} at cos theta = {}", value, rule.nodes[i]));
        total += rule.weights[i] * value;
        first_moment += rule.weights[i] * rule.nodes[i] * value;
    }
    ScatteringTable t;
    t.mu_s_per_um = 2.0 * kPi * total;
    t.g = total > 0.0 ? first_moment / total : 0.0;
    t.cos_theta.resize(table_points);
    t.phase_per_sr.resize(table_points);
    for (int i = 0; i < table_points; ++i) {
        const double mu = std::cos(kPi * i / (table_points - 1));
        t.cos_theta[i] = mu;
        t.phase_per_sr[i] = t.mu_s_per_um > 0.0 ? dsigma_domega(mu) / t.mu_s_per_um : 0.0;
    }
    return t;
}

ScatteringTable born_scattering(const std::function<double(double)>& spectrum,
                                std::complex<double> eps_contrast, std::complex<double> n_eff,
                                double lambda_nm, int table_points) {
    require_wavelength(lambda_nm);
    const double k0 = 2.0 * kPi / (lambda_nm * 1e-3);
    const double k = k0 * n_eff.real();
    const double prefactor = std::pow(k0, 4) * std::norm(eps_contrast) / (16.0 * kPi * kPi);
    auto dsigma = [&](double mu) {
        const double q = 2.0 * k * std::sqrt(std::max(0.0, 0.5 * (1.0 - mu)));
        return prefactor * spectrum(q) * 0.5 * (1.0 + mu * mu);
    };
    ScatteringTable t = integrate_differential(dsigma, table_points);
    t.lambda_nm = lambda_nm;
    t.n_eff = n_eff;
    t.mu_a_per_um = absorption_per_um(n_eff, lambda_nm);
    return t;
}

void require_born_inputs(const PowerSpectrum& spectrum, const optics::Material& keratin,
                         const optics::Material& air, double lambda_nm) {
    require_wavelength(lambda_nm);
    const double f = spectrum.filling_fraction();
    if (!(f > 0.0 && f < 1.0)) {
        throw InputError(fmt::format(
            "Born medium: keratin filling fraction f = {}: expected 0 < f < 1 (a volume without "
            "both components has no contrast)",
            f));
    }
    const std::complex<double> n_k = keratin.index(lambda_nm), n_a = air.index(lambda_nm);
    if (n_k == n_a) {
        throw InputError(fmt::format(
            "Born medium: {} and {} have the same index ({}, {}) at lambda = {} nm: expected an "
            "index contrast",
            keratin.name(), air.name(), n_k.real(), n_k.imag(), lambda_nm));
    }
    require_resolved(spectrum.voxel_um(), lambda_nm, std::max(n_k.real(), n_a.real()));
}

ScatteringTable born_medium(const PowerSpectrum& spectrum, const optics::Material& keratin,
                            const optics::Material& air, double lambda_nm, int table_points) {
    require_born_inputs(spectrum, keratin, air, lambda_nm);
    const std::complex<double> n_k = keratin.index(lambda_nm), n_a = air.index(lambda_nm);
    const std::complex<double> n_eff = bruggeman_index(n_k, n_a, spectrum.filling_fraction());
    const RadialSpectrum radial = spectrum.radial();
    auto interpolate = [&radial](double q) { return radial.at(q); };
    return born_scattering(interpolate, n_k * n_k - n_a * n_a, n_eff, lambda_nm, table_points);
}

ScatteringTable sphere_medium(double radius_um, double number_density_per_um3,
                              const optics::Material& sphere, const optics::Material& host,
                              const std::function<double(double)>& structure_factor,
                              double lambda_nm, int table_points) {
    require_wavelength(lambda_nm);
    if (!(std::isfinite(radius_um) && radius_um > 0.0)) {
        throw InputError(
            fmt::format("sphere medium: radius_um = {}: expected a finite radius > 0", radius_um));
    }
    const double phi = number_density_per_um3 * 4.0 * kPi / 3.0 * std::pow(radius_um, 3);
    if (!(phi > 0.0 && phi < 1.0)) {
        throw InputError(fmt::format(
            "sphere medium: number_density_per_um3 = {} gives a sphere volume fraction {}: "
            "expected one in (0, 1)",
            number_density_per_um3, phi));
    }
    const std::complex<double> n_s = sphere.index(lambda_nm), n_h = host.index(lambda_nm);
    if (n_s == n_h) {
        throw InputError(fmt::format(
            "sphere medium: {} and {} have the same index ({}, {}) at lambda = {} nm: expected "
            "an index contrast",
            sphere.name(), host.name(), n_s.real(), n_s.imag(), lambda_nm));
    }
    const std::complex<double> n_eff = bruggeman_index(n_s, n_h, phi);
    const double k = 2.0 * kPi / (lambda_nm * 1e-3) * n_eff.real();
    // Mie needs a lossless host: the loss of the effective medium enters through μ_a.
    const MieCoefficients c = mie_coefficients(n_s / n_eff.real(), k * radius_um);
    auto dsigma = [&](double mu) {
        const MieAmplitudes s = mie_amplitudes(c, mu);
        const double q = 2.0 * k * std::sqrt(std::max(0.0, 0.5 * (1.0 - mu)));
        return number_density_per_um3 * (std::norm(s.s1) + std::norm(s.s2)) / (2.0 * k * k) *
               structure_factor(q);
    };
    ScatteringTable t = integrate_differential(dsigma, table_points);
    t.lambda_nm = lambda_nm;
    t.n_eff = n_eff;
    t.mu_a_per_um = absorption_per_um(n_eff, lambda_nm);
    return t;
}

}  // namespace plumage::sim::wave
