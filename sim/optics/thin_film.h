// One coherent film between two media: the Airy summation of Huang et al. 2022, Eq. 1,
// generalised to different media above and below the film.
//
//   r = r_12 + t_12 t_21 r_23 e^{iΔψ} / (1 − r_21 r_23 e^{iΔψ})
//   t = t_12 t_23 e^{iΔψ/2} / (1 − r_21 r_23 e^{iΔψ}),   Δψ = 4π d q_2 / λ
//
// with q_2 = n_2 cos θ_2 the film's normal wavevector (fresnel.h conventions). Huang's
// Eq. 1 drops the transmission phase e^{iΔψ/2}; it does not change |t|² but is kept
// here so that the amplitude equals the transfer-matrix one (multilayer.h) exactly.
// Units: thickness in micrometres, wavelength in nanometres.
#pragma once

#include <string_view>

#include "sim/optics/fresnel.h"

namespace plumage::optics {

struct FilmMedia {
    double above;   // incidence medium, lossless (e.g. air 1.0)
    Complex film;   // the film (e.g. keratin), may absorb
    Complex below;  // the medium under the film, may absorb
};

struct FilmAmplitudes {
    Complex r;
    Complex t;
};

struct FilmIntensities {
    double reflectance;
    double transmittance;
    double absorptance;  // 1 − R − T: what the film and nothing else absorbs
};

FilmAmplitudes airy_film_amplitudes(const FilmMedia& media, double thickness_um, double lambda_nm,
                                    double cos_theta_i, Polarisation pol);
FilmIntensities airy_film_intensities(const FilmMedia& media, double thickness_um, double lambda_nm,
                                      double cos_theta_i, Polarisation pol);
FilmIntensities airy_film_intensities_unpolarised(const FilmMedia& media, double thickness_um,
                                                  double lambda_nm, double cos_theta_i);

// Intensities take a real-arithmetic path when the film and the medium below are lossless
// (zero imaginary index) and the wave propagates in both (no total internal reflection, not
// exactly grazing); otherwise the complex amplitudes above. From air the real path is within
// 5e-16 of a long-double closed form and within 1.4e-13 of the complex path, whose own
// round-off grows like ε / cos θ near grazing (tests/optics/thin_film_test.cpp). This entry
// point always takes the complex path, for that test.
namespace detail {
FilmIntensities airy_film_intensities_complex(const FilmMedia& media, double thickness_um,
                                              double lambda_nm, double cos_theta_i,
                                              Polarisation pol);
}  // namespace detail

// Shared precondition checks (InputError naming the value).
void require_wavelength(double lambda_nm);
// The one rule for a film's thickness everywhere (films, stacks, scenes, physical optics):
// finite and >= 0 µm; `where` (e.g. the surface) prefixes the message when given.
void require_thickness(double thickness_um, std::string_view where = {});

}  // namespace plumage::optics
