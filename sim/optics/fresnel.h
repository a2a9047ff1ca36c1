// Fresnel coefficients at a planar interface between two homogeneous media.
//
// Conventions (shared by thin_film.h and multilayer.h):
//  - Complex refractive index n = n' + i k with k >= 0 for an absorbing medium; fields
//    go as exp(i (k·r - ω t)), so a wave travelling along +z decays when Im(k_z) > 0.
//  - The incidence medium is lossless (real index): only there is the angle of
//    incidence a real angle. Media beyond it may absorb.
//  - Snell's invariant β = n_1 sin θ_1 is conserved across parallel interfaces. Each
//    medium's normal wavevector component, in units of the vacuum wavenumber, is
//    q = n cos θ = sqrt(n² − β²) on the branch with Im q > 0 (decaying), or q >= 0 when
//    real (propagating away from the interface). Total internal reflection makes q
//    purely imaginary (an evanescent wave).
//  - s: electric field perpendicular to the plane of incidence. p: electric field in
//    the plane of incidence; amplitudes are electric-field amplitudes with
//    r_p = (n_2² q_1 − n_1² q_2) / (n_2² q_1 + n_1² q_2), so r_p = −r_s at normal
//    incidence (Born & Wolf's sign convention differs by the sign of r_p only; no
//    intensity depends on it).
//  - Transmittance is the ratio of normal energy fluxes:
//    T = |t|² Re(n_2 conj(cos θ_2)) / Re(n_1 conj(cos θ_1)) for p and
//    T = |t|² Re(q_2) / Re(q_1) for s (Byrnes, arXiv:1603.02720, Eqs. 21–22).
//  - Unpolarised light is the equal-weight incoherent mix of s and p.
#pragma once

#include <complex>

namespace plumage::optics {

using Complex = std::complex<double>;

enum class Polarisation { s, p };

// q = n cos θ on the physical branch (see above), for light arriving from the lossless
// medium n0 at cos θ0. Evaluated as sqrt((n² − n0²) + (n0 cos θ0)²) rather than
// sqrt(n² − β²): near grazing incidence β² ≈ n0² and the subtraction would lose every
// digit of the small q (a medium equal to the ambient then gets q = q0 exactly).
Complex normal_wavevector(Complex n, double n0, double cos_theta0);

struct FresnelAmplitudes {
    Complex r;  // reflected / incident electric-field amplitude
    Complex t;  // transmitted / incident electric-field amplitude
};

// Amplitudes for the interface medium 1 → medium 2, given each medium's index and
// normal wavevector component. Media 1 may absorb here: this is the building block
// of the multilayer solver, where both sides can be film layers.
FresnelAmplitudes fresnel_amplitudes(Complex n1, Complex q1, Complex n2, Complex q2,
                                     Polarisation pol);

// Normal-flux ratio factor that turns |t|² into a transmittance (see above).
double transmittance_factor(Complex n1, Complex q1, Complex n2, Complex q2, Polarisation pol);

struct FresnelIntensities {
    double reflectance;
    double transmittance;
};

// Light in the lossless medium n1 arrives with cos θ_i ∈ [0, 1] on medium n2 (real or
// absorbing). Either side can be the denser one; beyond the critical angle the
// reflectance is 1 and the transmittance 0.
FresnelAmplitudes fresnel_amplitudes(double n1, Complex n2, double cos_theta_i, Polarisation pol);
FresnelIntensities fresnel_intensities(double n1, Complex n2, double cos_theta_i, Polarisation pol);
FresnelIntensities fresnel_intensities_unpolarised(double n1, Complex n2, double cos_theta_i);

// Shared precondition checks; they throw InputError naming the value.
void require_lossless_incidence(Complex n1, const char* what);
void require_cos_theta(double cos_theta_i);
void require_passive_medium(Complex n, const char* what);

}  // namespace plumage::optics
