// Effective permittivity of a two-component random mixture (keratin/air), the background
// around which the first-Born medium (born_medium.h) expands the scattering.
//
// Conventions: permittivities are relative (ε = n², dimensionless), complex with the
// e^{−iωt} time convention of sim/optics/material.h, so an absorbing component has
// Im ε >= 0 (n + ik with k >= 0). Fractions are volume fractions in [0, 1]; f is the
// fraction of component 1, 1 − f that of component 2.
//
// Bruggeman (symmetric effective-medium approximation, spherical grains, 3D):
//     f (ε1 − ε)/(ε1 + 2ε) + (1 − f)(ε2 − ε)/(ε2 + 2ε) = 0,
// i.e. the quadratic 2ε² − b ε − ε1 ε2 = 0 with b = (3f − 1) ε1 + (2 − 3f) ε2, roots
// ε = (b ± √(b² + 8 ε1 ε2)) / 4. The physical root is the one with Im ε >= 0 (a passive
// mixture of passive components does not amplify); for lossless components both roots are
// real, their product −ε1 ε2 / 2 < 0, and the physical one is the positive one. That
// choice is continuous in f from ε2 (f = 0) to ε1 (f = 1) for the dielectrics of this
// project (|arg ε| small); it is not meant for metals near a plasmon (Re ε < 0), which are
// refused.
//
// Maxwell-Garnett (inclusions ε1 at fraction f in a host ε2, dilute limit):
//     ε = ε2 (1 + 2 f β) / (1 − f β), β = (ε1 − ε2)/(ε1 + 2 ε2).
// Both agree to second order in the contrast δ = ε1 − ε2:
//     ε = ε2 + f δ − f (1 − f) δ² / (3 ε2) + O(δ³).
#pragma once

#include <complex>

namespace plumage::sim::wave {

using Complex = std::complex<double>;

// Throws InputError if f is outside [0, 1] or not finite, or if a component has
// Re ε <= 0 or Im ε < 0 (the branch rule above needs a dielectric).
Complex bruggeman_permittivity(Complex eps1, Complex eps2, double f);
Complex maxwell_garnett_permittivity(Complex eps_inclusion, Complex eps_host, double f);

// Effective complex index √ε_eff (principal root, Im >= 0) from two complex indices.
Complex bruggeman_index(Complex n1, Complex n2, double f);

}  // namespace plumage::sim::wave
