// Mie scattering by a homogeneous sphere (Bohren & Huffman 1983, ch. 4; term count and
// recurrences after Wiscombe, "Improved Mie scattering algorithms", Appl. Opt. 19, 1505,
// 1980).
//
// Conventions:
//  - Time dependence e^{−iωt} (Bohren & Huffman), so the relative index m = n_sphere /
//    n_host = n + ik is absorbing for k > 0, as in sim/optics/material.h.
//  - Size parameter x = k_host a = 2π n_host a / λ (λ the vacuum wavelength, a the
//    radius), i.e. the wavenumber in the host medium, which must be lossless.
//  - Efficiencies are cross-sections over the geometric cross-section π a².
//  - Amplitude functions S1(θ) (perpendicular), S2(θ) (parallel) are Bohren & Huffman's
//    (their eq. 4.74): the scattered far field is e^{ikr}/(−ikr) × S. The unpolarised
//    differential cross-section is dσ/dΩ = (|S1|² + |S2|²) / (2 k²), k the host
//    wavenumber, so that Q_sca = (1/x²) ∫_{−1}^{1} (|S1|² + |S2|²) dcosθ and
//    Q_ext = (4/x²) Re S(0) (optical theorem; S1(0) = S2(0)).
//  - Q_back = |S1(π)|² · 4 / x² (Bohren & Huffman's definition: 4π dσ/dΩ(π) / (π a²)).
//
// Validity: the series is exact; the implementation is accurate for x up to ~10⁴ and
// |m x| up to ~10⁴ (the downward recurrence for D_n is stable for any m). x must be > 0.
#pragma once

#include <complex>
#include <vector>

namespace plumage::sim::wave {

struct MieCoefficients {
    std::vector<std::complex<double>> a, b;  // a[n − 1] = a_n, n = 1 … n_stop
};

struct MieEfficiencies {
    double q_ext = 0.0;
    double q_sca = 0.0;
    double q_abs = 0.0;
    double q_back = 0.0;
    double g = 0.0;  // asymmetry parameter <cos θ>
};

struct MieAmplitudes {
    std::complex<double> s1, s2;
};

// Throws InputError for x <= 0 or not finite, or m with Re m <= 0, Im m < 0 or not finite.
MieCoefficients mie_coefficients(std::complex<double> m, double x);
MieEfficiencies mie_efficiencies(std::complex<double> m, double x);
MieEfficiencies mie_efficiencies(const MieCoefficients& c, double x);
// cos θ in [−1, 1].
MieAmplitudes mie_amplitudes(const MieCoefficients& c, double cos_theta);
std::vector<MieAmplitudes> mie_amplitudes(const MieCoefficients& c,
                                          const std::vector<double>& cos_theta);

// Wiscombe's number of terms: x + 4 x^{1/3} + 1 (x <= 8), x + 4.05 x^{1/3} + 2 (x < 4200),
// x + 4 x^{1/3} + 2 beyond.
int mie_term_count(double x);

}  // namespace plumage::sim::wave
