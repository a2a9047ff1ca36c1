#include "sim/optics/fresnel.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "common/error.h"

namespace plumage::optics {

Complex normal_wavevector(Complex n, double n0, double cos_theta0) {
    const double q0 = n0 * cos_theta0;
    Complex q = std::sqrt((n * n - n0 * n0) + q0 * q0);
    // std::sqrt takes the principal branch (Re q >= 0), which for a lossless medium
    // beyond the critical angle may land on −i|q| when the imaginary part of the
    // argument is a negative zero. The physical wave must decay away from the interface.
    if (q.imag() < 0.0 || (q.imag() == 0.0 && q.real() < 0.0)) q = -q;
    return q;
}

FresnelAmplitudes fresnel_amplitudes(Complex n1, Complex q1, Complex n2, Complex q2,
                                     Polarisation pol) {
    // Index-matched media: no interface. At grazing incidence both q vanish and the
    // formulas below become 0/0; the limit is r = 0, t = 1.
    if (n1 == n2) return {Complex(0.0), Complex(1.0)};
    if (pol == Polarisation::s) {
        const Complex denominator = q1 + q2;
        return {(q1 - q2) / denominator, 2.0 * q1 / denominator};
    }
    const Complex n1sq = n1 * n1;
    const Complex n2sq = n2 * n2;
    const Complex denominator = n2sq * q1 + n1sq * q2;
    return {(n2sq * q1 - n1sq * q2) / denominator, 2.0 * n1 * n2 * q1 / denominator};
}

double transmittance_factor(Complex n1, Complex q1, Complex n2, Complex q2, Polarisation pol) {
    if (pol == Polarisation::s) {
        const double incident = q1.real();
        return incident > 0.0 ? q2.real() / incident : 0.0;
    }
    // Re(n conj(cos θ)) with cos θ = q / n.
    const double incident = (n1 * std::conj(q1 / n1)).real();
    return incident > 0.0 ? (n2 * std::conj(q2 / n2)).real() / incident : 0.0;
}

void require_lossless_incidence(Complex n1, const char* what) {
    if (!std::isfinite(n1.real()) || !(n1.real() > 0.0) || n1.imag() != 0.0) {
        throw InputError(
            fmt::format("{}: the incidence medium must be lossless with a positive real index "
                        "(the angle of incidence is only a real angle there); got n = {} + {}i",
                        what, n1.real(), n1.imag()));
    }
}

void require_cos_theta(double cos_theta_i) {
    if (!std::isfinite(cos_theta_i) || cos_theta_i < 0.0 || cos_theta_i > 1.0) {
        throw InputError(fmt::format(
            "cos(theta_i) = {} is outside [0, 1]: incidence angles are measured from the "
            "interface normal on the incidence side, 0..90 degrees",
            cos_theta_i));
    }
}

void require_passive_medium(Complex n, const char* what) {
    if (!std::isfinite(n.real()) || !std::isfinite(n.imag()) || !(n.real() > 0.0) ||
        n.imag() < 0.0) {
        throw InputError(
            fmt::format("{}: expected a finite refractive index with n > 0 and k >= 0 (a passive "
                        "medium); got n = {} + {}i",
                        what, n.real(), n.imag()));
    }
}

namespace {

struct InterfaceWaves {
    Complex q1, q2;
};

InterfaceWaves interface_waves(double n1, Complex n2, double cos_theta_i) {
    require_lossless_incidence(Complex(n1), "Fresnel");
    require_passive_medium(n2, "Fresnel (transmission medium)");
    require_cos_theta(cos_theta_i);
    return {Complex(n1 * cos_theta_i), normal_wavevector(n2, n1, cos_theta_i)};
}

}  // namespace

FresnelAmplitudes fresnel_amplitudes(double n1, Complex n2, double cos_theta_i, Polarisation pol) {
    const InterfaceWaves w = interface_waves(n1, n2, cos_theta_i);
    return fresnel_amplitudes(Complex(n1), w.q1, n2, w.q2, pol);
}

FresnelIntensities fresnel_intensities(double n1, Complex n2, double cos_theta_i,
                                       Polarisation pol) {
    const InterfaceWaves w = interface_waves(n1, n2, cos_theta_i);
    const FresnelAmplitudes a = fresnel_amplitudes(Complex(n1), w.q1, n2, w.q2, pol);
    return {std::norm(a.r),
            std::norm(a.t) * transmittance_factor(Complex(n1), w.q1, n2, w.q2, pol)};
}

FresnelIntensities fresnel_intensities_unpolarised(double n1, Complex n2, double cos_theta_i) {
    const FresnelIntensities s = fresnel_intensities(n1, n2, cos_theta_i, Polarisation::s);
    const FresnelIntensities p = fresnel_intensities(n1, n2, cos_theta_i, Polarisation::p);
    return {0.5 * (s.reflectance + p.reflectance), 0.5 * (s.transmittance + p.transmittance)};
}

}  // namespace plumage::optics
