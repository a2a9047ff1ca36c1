// The structural colour of a spongy keratin medulla, as an albedo band for the tracer's
// diffuse medulla (sim/scene.h): the band sits at the first-order Bragg peak of the keratin/
// air network, λ = 2 n̄ Λ, with n̄ = f n_keratin(λ) + (1 − f) the volume-averaged index
// (Prum et al. 1998's single-scattering estimate, the one the species study uses; the
// network's scattering itself is not traced).
//
// Parameters (units, ranges):
//   spacing_um         Λ, dominant spacing of the network      (0.05, 1] µm
//   keratin_fraction   f, keratin filling fraction              [0.05, 0.95]
//   band_width_nm      Gaussian standard deviation of the band  [1, 300] nm
//   albedo             at the band's peak                       [0, 1]
//   base_albedo        away from the band (melanin beneath)     [0, albedo]
#pragma once

#include "sim/scene.h"

namespace plumage::sim {

// λ = 2 n̄(λ) Λ in nm, solved by fixed-point iteration from n̄ = 1.3 (keratin's dispersion is
// weak: each step contracts the error by |2 f Λ dn/dλ| < 1e-3, so 20 steps reach machine
// precision from any start in the visible).
double bragg_peak_nm(double spacing_um, double keratin_fraction);

// albedo(λ) = base + (peak − base) exp(−(λ − λ_B)²/(2 w²)).
AlbedoSpectrum bragg_band_albedo(double spacing_um, double keratin_fraction, double band_width_nm,
                                 double albedo, double base_albedo);

}  // namespace plumage::sim
