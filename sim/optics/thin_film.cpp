#include "sim/optics/thin_film.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <fmt/format.h>

#include "common/error.h"

namespace plumage::optics {

void require_wavelength(double lambda_nm) {
    if (!std::isfinite(lambda_nm) || !(lambda_nm > 0.0)) {
        throw InputError(
            fmt::format("wavelength = {} nm: expected a finite positive value", lambda_nm));
    }
}

void require_thickness(double thickness_um) {
    if (!std::isfinite(thickness_um) || thickness_um < 0.0) {
        throw InputError(fmt::format(
            "film thickness = {} um: expected a finite value >= 0 (micrometres)", thickness_um));
    }
}

FilmAmplitudes airy_film_amplitudes(const FilmMedia& media, double thickness_um, double lambda_nm,
                                    double cos_theta_i, Polarisation pol) {
    require_lossless_incidence(Complex(media.above), "thin film (medium above)");
    require_passive_medium(media.film, "thin film (film)");
    require_passive_medium(media.below, "thin film (medium below)");
    require_cos_theta(cos_theta_i);
    require_thickness(thickness_um);
    require_wavelength(lambda_nm);

    const Complex n1(media.above);
    const Complex q1(media.above * cos_theta_i);
    const Complex q2 = normal_wavevector(media.film, media.above, cos_theta_i);
    const Complex q3 = normal_wavevector(media.below, media.above, cos_theta_i);

    const FresnelAmplitudes a12 = fresnel_amplitudes(n1, q1, media.film, q2, pol);
    const FresnelAmplitudes a21 = fresnel_amplitudes(media.film, q2, n1, q1, pol);
    const FresnelAmplitudes a23 = fresnel_amplitudes(media.film, q2, media.below, q3, pol);
    // Exactly grazing incidence on a film that differs from the medium above: t_12 = 0
    // and the series below is 0/0 when Δψ is a multiple of 2π. Nothing enters a film of
    // any positive thickness (r = r_12 = −1); a film of zero thickness is no film.
    if (q1 == 0.0 && media.film != n1) {
        if (thickness_um > 0.0) return {a12.r, Complex(0.0)};
        const FresnelAmplitudes bare = fresnel_amplitudes(n1, q1, media.below, q3, pol);
        return {bare.r, bare.t};
    }

    // e^{iΔψ/2} = exp(i 2π d q_2 / λ); Im q_2 >= 0 keeps its modulus <= 1, so neither a
    // thick absorbing film nor an evanescent (frustrated TIR) film can overflow.
    const double k0_d = 2.0 * std::numbers::pi * thickness_um * 1000.0 / lambda_nm;
    const Complex half_phase = std::exp(Complex(0.0, 1.0) * k0_d * q2);
    const Complex full_phase = half_phase * half_phase;
    const Complex denominator = 1.0 - a21.r * a23.r * full_phase;
    return {a12.r + a12.t * a21.t * a23.r * full_phase / denominator,
            a12.t * a23.t * half_phase / denominator};
}

FilmIntensities airy_film_intensities(const FilmMedia& media, double thickness_um, double lambda_nm,
                                      double cos_theta_i, Polarisation pol) {
    const FilmAmplitudes a = airy_film_amplitudes(media, thickness_um, lambda_nm, cos_theta_i, pol);
    const Complex q1(media.above * cos_theta_i);
    const Complex q3 = normal_wavevector(media.below, media.above, cos_theta_i);
    const double reflectance = std::norm(a.r);
    const double transmittance =
        std::norm(a.t) * transmittance_factor(Complex(media.above), q1, media.below, q3, pol);
    return {reflectance, transmittance, 1.0 - reflectance - transmittance};
}

FilmIntensities airy_film_intensities_unpolarised(const FilmMedia& media, double thickness_um,
                                                  double lambda_nm, double cos_theta_i) {
    const FilmIntensities s =
        airy_film_intensities(media, thickness_um, lambda_nm, cos_theta_i, Polarisation::s);
    const FilmIntensities p =
        airy_film_intensities(media, thickness_um, lambda_nm, cos_theta_i, Polarisation::p);
    return {0.5 * (s.reflectance + p.reflectance), 0.5 * (s.transmittance + p.transmittance),
            0.5 * (s.absorptance + p.absorptance)};
}

}  // namespace plumage::optics
