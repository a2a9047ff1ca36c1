// Exact scattering of a plane wave by an infinite homogeneous circular cylinder at normal
// incidence (Bohren & Huffman 1983, §8.4): the closed form the 2D full-wave level is tested
// against (tests/sim/fullwave), in the 2D levels' normalisation (physical_optics_2d.h).
//
// Conventions:
//  - Time dependence e^{−iωt}; relative index m = n + ik, absorbing for k > 0; the host is air.
//  - Size parameter x = k a = 2π a / λ, a the radius.
//  - TE (Polarisation2d::te): E along the cylinder axis, Bohren & Huffman's case I, whose
//    coefficients are b_n; TM: H along the axis, case II, coefficients a_n. Both are stored
//    as `coefficient[n]`, n = 0 … n_stop (b_{−n} = b_n, a_{−n} = a_n).
//  - Far field: u_s → u_0 e^{i3π/4} √(2/(πkr)) e^{ikr} T(ψ), T(ψ) = c_0 + 2 Σ_{n≥1} c_n cos nψ,
//    ψ the scattering angle from the forward direction. The differential scattering width
//    (power per unit length per radian over the incident intensity) is
//        σ(ψ) = r |u_s|² / |u_0|² = (2 / (π k)) |T(ψ)|²     [µm/rad],
//    and the widths (cross-sections per unit length, µm) are
//        C_sca = (4/k) (|c_0|² + 2 Σ |c_n|²),  C_ext = (4/k) Re(c_0 + 2 Σ c_n),
//    C_abs = C_ext − C_sca (= 0 for a lossless cylinder: a check of the series, tested).
//
// Interior Bessel functions enter only through the logarithmic derivative
// D_n(z) = J_n'(z)/J_n(z), z = m x, by downward recurrence D_{n−1} = (n−1)/z − 1/(D_n + n/z)
// (stable for any complex z, as for spheres); the exterior J_n(x), Y_n(x) are std's real
// Bessel functions. Terms: n_stop = x + 4.05 x^{1/3} + 2 (Wiscombe's rule), at least 3.
//
// Parameter table:
//  | name   | unit | range                                   |
//  |--------|------|-----------------------------------------|
//  | m      | 1    | Re m > 0, Im m >= 0, finite             |
//  | x      | 1    | finite, in (0, 1000]                    |
#pragma once

#include <complex>
#include <vector>

#include "sim/wave/volume/born_2d.h"  // Polarisation2d

namespace plumage::sim::wave {

struct CylinderSeries {
    Polarisation2d polarisation = Polarisation2d::te;
    double x = 0.0;
    std::vector<std::complex<double>> coefficient;  // c_n, n = 0 … n_stop
};

struct CylinderWidths {
    double extinction_um = 0.0, scattering_um = 0.0, absorption_um = 0.0;
};

// InputError when m or x is outside the parameter table.
CylinderSeries cylinder_series(std::complex<double> m, double x, Polarisation2d pol);
// T(ψ) = c_0 + 2 Σ c_n cos nψ, ψ in rad from the forward direction.
std::complex<double> cylinder_amplitude(const CylinderSeries& s, double psi_rad);
// σ(ψ) in µm/rad for wavenumber k = 2π/λ (µm⁻¹).
double cylinder_sigma(const CylinderSeries& s, double k_per_um, double psi_rad);
CylinderWidths cylinder_widths(const CylinderSeries& s, double k_per_um);

}  // namespace plumage::sim::wave
