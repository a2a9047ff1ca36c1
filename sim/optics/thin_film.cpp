#include "sim/optics/thin_film.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <optional>

#include <fmt/format.h>

#include "common/error.h"

namespace plumage::optics {

void require_wavelength(double lambda_nm) {
    if (!std::isfinite(lambda_nm) || !(lambda_nm > 0.0)) {
        throw InputError(
            fmt::format("wavelength = {} nm: expected a finite positive value", lambda_nm));
    }
}

void require_thickness(double thickness_um, std::string_view where) {
    if (!std::isfinite(thickness_um) || thickness_um < 0.0) {
        throw InputError(
            fmt::format("{}{}film thickness = {} um: expected a finite value >= 0 (micrometres)",
                        where, where.empty() ? "" : ": ", thickness_um));
    }
}

namespace {

void require_film_inputs(const FilmMedia& media, double thickness_um, double lambda_nm,
                         double cos_theta_i) {
    require_lossless_incidence(Complex(media.above), "thin film (medium above)");
    require_passive_medium(media.film, "thin film (film)");
    require_passive_medium(media.below, "thin film (medium below)");
    require_cos_theta(cos_theta_i);
    require_thickness(thickness_um);
    require_wavelength(lambda_nm);
}

// a / b for finite a and finite non-zero b, by Smith's algorithm in real arithmetic.
// Why not operator/: libstdc++ calls libgcc's __divdc3 for complex<double> division, whose
// C99 Annex G inf/nan recovery took 44 % of the Huang model's tabulation time (issue 15).
// Here the denominator 1 − r_21 r_23 e^{iΔψ} is finite and non-zero (the 0/0 grazing case
// returns before), so that recovery never applies; Smith's scaling still avoids overflow.
Complex divide_finite(Complex a, Complex b) {
    if (std::abs(b.real()) >= std::abs(b.imag())) {
        const double ratio = b.imag() / b.real();
        const double scale = b.real() + b.imag() * ratio;
        return {(a.real() + a.imag() * ratio) / scale, (a.imag() - a.real() * ratio) / scale};
    }
    const double ratio = b.real() / b.imag();
    const double scale = b.real() * ratio + b.imag();
    return {(a.real() * ratio + a.imag()) / scale, (a.imag() * ratio - a.real()) / scale};
}

// A lossless film between lossless media with a propagating wave in each (no total
// internal reflection in the film or below, not exactly grazing): every Fresnel amplitude
// is real, r_21 = −r_12 and t_12 t_21 = 1 − r_12², so per polarisation
//   R = |r_12 + r_23 e^{iδ}|² / |1 + r_12 r_23 e^{iδ}|²,
//   T = (1 − r_12²)(1 − r_23²) / |1 + r_12 r_23 e^{iδ}|²,   δ = 4π d q_2 / λ,
// in real arithmetic, with one sin and cos for both polarisations. Near grazing incidence
// r_12 r_23 → ±1 and the textbook forms (r_12² + r_23² + 2 r_12 r_23 cos δ, 1 − R) cancel
// their leading digits; with r_12 = (x_1 − x_2)/(x_1 + x_2), r_23 = (x_2 − x_3)/(x_2 + x_3)
// (x = q for s, x = q / n² for p) and D = (x_1 + x_2)(x_2 + x_3) they are, exactly,
//   (r_12 + r_23)² D²/4 = x_2² (x_1 − x_3)²,   (1 + r_12 r_23)² D²/4 = x_2² (x_1 + x_3)²,
//   (1 − r_12 r_23)² D²/4 = (x_1 x_3 + x_2²)²,  r_12 r_23 D = (x_1 − x_2)(x_2 − x_3),
//   (1 − r_12²)(1 − r_23²) D²/4 = 4 x_1 x_2² x_3,
// and |a + b e^{iδ}|² = (a + b)² − 4ab sin²(δ/2) = (a − b)² + 4ab cos²(δ/2), so
//   R = [x_2² (x_1 − x_3)² − P D s²] / Q,   T = 4 x_1 x_2² x_3 / Q,
//   Q = x_2² (x_1 + x_3)² − P D s² = (x_1 x_3 + x_2²)² + P D c²,
// with P = (x_1 − x_2)(x_2 − x_3) and (c, s) = (cos, sin)(δ/2),
// taking for Q the form whose two terms have the same sign: no cancellation anywhere but in
// the numerator of R near a reflectance zero, where it costs absolute, not relative, digits.
struct LosslessFilm {
    double q1, q2, q3;      // real normal wavevectors, all > 0
    double u1, u2, u3;      // q / n², the p-polarisation counterparts
    double cos_sq, sin_sq;  // cos²(δ/2), sin²(δ/2)
};

std::optional<LosslessFilm> lossless_film(const FilmMedia& media, double thickness_um,
                                          double lambda_nm, double cos_theta_i) {
    if (media.film.imag() != 0.0 || media.below.imag() != 0.0) return std::nullopt;
    const double n1 = media.above, n2 = media.film.real(), n3 = media.below.real();
    const double q1 = n1 * cos_theta_i;
    // As normal_wavevector: (n² − n0²) + q0², which keeps the digits of a small q.
    const double q2sq = (n2 * n2 - n1 * n1) + q1 * q1;
    const double q3sq = (n3 * n3 - n1 * n1) + q1 * q1;
    // q² <= 0: evanescent (TIR) or exactly critical; q1 = 0: exactly grazing. The complex
    // path handles those (complex amplitudes, and the grazing limit).
    // The forms below are quartic in q: q >= 1e-50 (cos θ_i >= 1e-50 from air) keeps them
    // clear of underflow once scaled by the largest q (lossless_film_intensities).
    if (!(q1 >= 1e-50) || !(q2sq >= 1e-100) || !(q3sq >= 1e-100)) return std::nullopt;
    const double q2 = std::sqrt(q2sq), q3 = std::sqrt(q3sq);
    // δ/2 = k0 d q_2, the complex path's phase argument computed the same way, so both
    // paths see the same rounding of a phase that reaches ~300 rad at 5 µm.
    const double k0_d = 2.0 * std::numbers::pi * thickness_um * 1000.0 / lambda_nm;
    const double half = k0_d * q2;
    const double c = std::cos(half), s = std::sin(half);
    return LosslessFilm{q1, q2, q3, q1 / (n1 * n1), q2 / (n2 * n2), q3 / (n3 * n3), c * c, s * s};
}

FilmIntensities lossless_film_intensities(double x1, double x2, double x3, double cos_sq,
                                          double sin_sq) {
    // R and T are homogeneous of degree 0 in x: scale to max x = 1 so that no quartic term
    // overflows or underflows for extreme (but passive, finite) indices.
    const double scale = 1.0 / std::max({x1, x2, x3});
    x1 *= scale, x2 *= scale, x3 *= scale;
    // P D = r_12 r_23 D², its sign that of r_12 r_23.
    const double p = (x1 - x2) * (x2 - x3) * ((x1 + x2) * (x2 + x3));
    const double x2sq = x2 * x2;
    const double q = p <= 0.0 ? x2sq * ((x1 + x3) * (x1 + x3)) - p * sin_sq
                              : (x1 * x3 + x2sq) * (x1 * x3 + x2sq) + p * cos_sq;
    // The numerator's two terms cancel only where R is near zero (r_12 ≈ r_23, s² ≈ 1):
    // absolute round-off of order ε, never relative.
    const double r_num = x2sq * ((x1 - x3) * (x1 - x3)) - p * sin_sq;
    const double reflectance = std::max(r_num, 0.0) / q;
    const double transmittance = 4.0 * x1 * x2sq * x3 / q;
    return {reflectance, transmittance, 1.0 - reflectance - transmittance};
}

FilmIntensities lossless_film_intensities(const LosslessFilm& f, Polarisation pol) {
    return pol == Polarisation::s ? lossless_film_intensities(f.q1, f.q2, f.q3, f.cos_sq, f.sin_sq)
                                  : lossless_film_intensities(f.u1, f.u2, f.u3, f.cos_sq, f.sin_sq);
}

FilmIntensities complex_film_intensities(const FilmMedia& media, double thickness_um,
                                         double lambda_nm, double cos_theta_i, Polarisation pol) {
    const FilmAmplitudes a = airy_film_amplitudes(media, thickness_um, lambda_nm, cos_theta_i, pol);
    const Complex q1(media.above * cos_theta_i);
    const Complex q3 = normal_wavevector(media.below, media.above, cos_theta_i);
    const double reflectance = std::norm(a.r);
    const double transmittance =
        std::norm(a.t) * transmittance_factor(Complex(media.above), q1, media.below, q3, pol);
    return {reflectance, transmittance, 1.0 - reflectance - transmittance};
}

FilmIntensities mean(const FilmIntensities& s, const FilmIntensities& p) {
    return {0.5 * (s.reflectance + p.reflectance), 0.5 * (s.transmittance + p.transmittance),
            0.5 * (s.absorptance + p.absorptance)};
}

}  // namespace

FilmAmplitudes airy_film_amplitudes(const FilmMedia& media, double thickness_um, double lambda_nm,
                                    double cos_theta_i, Polarisation pol) {
    require_film_inputs(media, thickness_um, lambda_nm, cos_theta_i);

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
    return {a12.r + divide_finite(a12.t * a21.t * a23.r * full_phase, denominator),
            divide_finite(a12.t * a23.t * half_phase, denominator)};
}

FilmIntensities airy_film_intensities(const FilmMedia& media, double thickness_um, double lambda_nm,
                                      double cos_theta_i, Polarisation pol) {
    require_film_inputs(media, thickness_um, lambda_nm, cos_theta_i);
    if (const auto f = lossless_film(media, thickness_um, lambda_nm, cos_theta_i)) {
        return lossless_film_intensities(*f, pol);
    }
    return complex_film_intensities(media, thickness_um, lambda_nm, cos_theta_i, pol);
}

FilmIntensities airy_film_intensities_unpolarised(const FilmMedia& media, double thickness_um,
                                                  double lambda_nm, double cos_theta_i) {
    require_film_inputs(media, thickness_um, lambda_nm, cos_theta_i);
    if (const auto f = lossless_film(media, thickness_um, lambda_nm, cos_theta_i)) {
        return mean(lossless_film_intensities(*f, Polarisation::s),
                    lossless_film_intensities(*f, Polarisation::p));
    }
    return mean(
        complex_film_intensities(media, thickness_um, lambda_nm, cos_theta_i, Polarisation::s),
        complex_film_intensities(media, thickness_um, lambda_nm, cos_theta_i, Polarisation::p));
}

namespace detail {

FilmIntensities airy_film_intensities_complex(const FilmMedia& media, double thickness_um,
                                              double lambda_nm, double cos_theta_i,
                                              Polarisation pol) {
    require_film_inputs(media, thickness_um, lambda_nm, cos_theta_i);
    return complex_film_intensities(media, thickness_um, lambda_nm, cos_theta_i, pol);
}

}  // namespace detail

}  // namespace plumage::optics
