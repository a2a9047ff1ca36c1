// First-Born scattering in flatland: the 2D counterpart of born_medium.h, for structures
// invariant along z (channels, a 2D field χ(x, y)) lit by waves travelling in the (x, y)
// plane. The numbers a 2D transport model (flatland_slab.h) needs: μ_s(λ), the phase
// function p(θ) over the in-plane scattering angle, g = ⟨cos θ⟩.
//
// Units: lengths µm, wavelengths nm (vacuum), μ_s in µm⁻¹ (per unit path length in the
// plane), dμ_s/dθ in µm⁻¹ rad⁻¹, p(θ) in rad⁻¹, S̄(q) in µm² (power_spectrum.h, 2D).
//
// Polarisations. TE: E along z (out of the plane; "Ez" in Meep), a scalar field u = E_z.
// TM: H along z ("Hz"), E in the plane. Both are conserved by any z-invariant structure:
// a TE wave scatters only into TE waves, TM into TM.
//
// Derivation (TE first). With the background ε_eff and the fluctuation
// Δε(r) = (ε_k − ε_a)(χ(r) − f) (+ a constant that scatters only at q = 0), the field obeys
//     (∇² + k²) u = −k0² Δε u,   k = k0 n_eff, k0 = 2π/λ.
// The 2D outgoing Green's function of ∇² + k² is G(r) = (i/4) H0⁽¹⁾(k r), so in first Born
// (u → the incident plane wave e^{i k k̂_i·r} on the right)
//     u_s(r) = (i/4) k0² ∫ H0⁽¹⁾(k |r − r'|) Δε(r') e^{i k k̂_i·r'} d²r'.
// Far away H0⁽¹⁾(k r) → √(2/(π k r)) e^{i (k r − π/4)} and |r − r'| → r − ŝ·r', so
//     u_s → (i/4) √(2/(π k r)) e^{i(kr − π/4)} k0² Δε̂(q),  q = k (ŝ − k̂_i), |q| = 2k sin(θ/2),
// with Δε̂(q) = ∫ Δε e^{−i q·r} d²r = (ε_k − ε_a) χ̂(q). The scattered power through an arc
// r dθ, per unit incident intensity (|u_inc|² = 1, the same impedance), is |u_s|² r dθ:
//     dσ/dθ = k0⁴ |ε_k − ε_a|² |χ̂(q)|² / (8π k)          (scattering width, µm rad⁻¹).
// Per unit area A of the medium, |χ̂|²/A → S(q) (power_spectrum.h), and the orientation
// average S̄(|q|) gives
//     dμ_s/dθ = k0⁴ |ε_k − ε_a|² S̄(q) / (8π k) · P(θ),   P_TE = 1,  P_TM = cos²θ.
// Units: µm⁻⁴ · µm² / µm⁻¹ = µm⁻¹ per radian. TM: the source is the in-plane polarisation
// P ∝ Δε E_inc with E_inc ⊥ k̂_i; a 2D dipole radiates the part of P transverse to ŝ, whose
// length is |E_inc · (ŝ rotated by 90°)| = |cos θ|, so the intensity carries cos²θ (the 2D
// analogue of 3D's (1 + cos²θ)/2, which averages over two polarisations). θ is the signed
// angle from the incident direction, θ ∈ (−π, π]; dμ_s/dθ is even in θ.
// Check (tests/sim/wave/born_2d_test.cpp): for a dilute set of thin cylinders of radius a
// (number density ρ per µm²), S̄ = ρ (πa²)² [2J1(qa)/(qa)]², and for ka → 0 the total
// μ_s = ρ C_sca reproduces the Rayleigh cylinder of van de Hulst (§15.3) at low contrast:
// C_sca,TE = π² k³ a⁴ |Δε|² / 4 (E ∥ axis), C_sca,TM = C_sca,TE / 2 (E ⊥ axis, to lowest
// order in Δε: the local-field factor 2/(ε + 1) → 1).
//
// Integrals and table (born_medium.h's integrate_differential does not fit: it integrates
// over μ = cos θ with the 3D solid-angle weight, and dθ = dμ/√(1 − μ²) would put endpoint
// singularities into its Gauss–Legendre rule). μ_s = ∫_{−π}^{π} dμ_s/dθ dθ = 2 ∫_0^π dμ_s/dθ
// dθ, by the trapezoid rule on 4096 intervals of [0, π]: the integrand is even and
// 2π-periodic, for which the trapezoid rule converges faster than any power of the step when
// it is smooth (it is, up to the kinks of a linearly interpolated S̄, which leave O(Δθ²)
// ≈ 6e-7 relative). p(θ) = (dμ_s/dθ) / μ_s,
// normalised to ∫_{−π}^{π} p dθ = 1; g = ∫ cos θ p dθ. The table holds p at `table_points`
// values of θ uniform on [0, π] (p is even: p(−θ) = p(θ)).
//
// Effective medium (2D: cylinders, not spheres). The choice, per polarisation:
//  - TE (E along the invariant axis): E_z is continuous across every interface, so the
//    quasi-static effective permittivity is the plain average ε_TE = f ε_k + (1 − f) ε_a
//    (exact in the long-wavelength limit for any z-invariant structure: Wiener's upper
//    bound is attained).
//  - TM (E in the plane): the 2D Bruggeman equation for circular inclusions (depolarisation
//    factor ½)
//        f (ε_k − ε)/(ε_k + ε) + (1 − f)(ε_a − ε)/(ε_a + ε) = 0
//    ⇔ ε² − b ε − ε_k ε_a = 0, b = (2f − 1)(ε_k − ε_a), ε = (b + √(b² + 4 ε_k ε_a)) / 2.
//    At f = ½ this is ε = √(ε_k ε_a), Dykhne's exact result for any statistically
//    phase-symmetric 2D two-phase medium (the channel field at f = ½ is one), which is why
//    Bruggeman rather than Maxwell-Garnett is used.
// n_eff = √ε_eff; q uses k = k0 n_eff, the wave that propagates in the medium.
//
// Validity: first Born needs k0 |Δε| ℓ / n_eff ≪ 1 over the correlation length ℓ; for
// keratin/air (Δε ≈ 1.4) at ℓ = π/q_peak ≈ 0.09 µm it is ≈ 1.4–1.5 at λ = 425 nm and ≈ 0.9 at
// 700 nm: tests/reference/spongy_2d/README.md measures what that costs against a full-wave
// (Meep) reference of the same fields (band R within 15 % from 400 to 600–650 nm; the
// optically thin red bands low, TM by 30–40 %).
//
// Parameter table:
//  | name               | unit | range                                                  |
//  |--------------------|------|--------------------------------------------------------|
//  | lambda_nm          | nm   | finite, > 0 (and in the materials' range)              |
//  | spectrum S̄(q)      | µm²  | finite, >= 0 for q in [0, 2k]                          |
//  | eps_contrast       | 1    | ε_k − ε_a, finite, != 0                                |
//  | n_eff              | 1    | finite, > 0 (real: a lossless background)              |
//  | f                  | 1    | (0, 1) for born_flatland; [0, 1] for the effective ε   |
//  | table_points       | 1    | [2, 100000]                                            |
//  | pixel h (spectrum) | µm   | <= λ / (4 n_max) (index_field.h's resolution limit)    |
#pragma once

#include <complex>
#include <functional>
#include <string_view>
#include <vector>

#include "sim/optics/material.h"
#include "sim/wave/volume/power_spectrum.h"

namespace plumage::sim::wave {

// TE: E out of the plane (Ez); TM: E in the plane (Hz).
enum class Polarisation2d { te, tm };

std::string_view polarisation_name(Polarisation2d pol);  // "TE" or "TM"

struct FlatlandTable {
    double lambda_nm = 0.0;
    Polarisation2d polarisation = Polarisation2d::te;
    double n_eff = 0.0;                 // background index (real, lossless)
    double mu_s_per_um = 0.0;           // ∫_{−π}^{π} dμ_s/dθ dθ
    double g = 0.0;                     // ⟨cos θ⟩
    std::vector<double> theta_rad;      // table abscissae, uniform from 0 to π
    std::vector<double> phase_per_rad;  // p(θ) there, ∫_{−π}^{π} p dθ = 1 (even in θ)
};

// The common integral: dμ_s/dθ as a function of θ ∈ [0, π] (µm⁻¹ rad⁻¹, finite, >= 0;
// the function is taken even in θ). n_eff, λ and polarisation are left for the caller.
FlatlandTable integrate_flatland(const std::function<double(double)>& dmu_dtheta,
                                 int table_points = 721);

// Effective permittivity of a 2D (z-invariant) two-phase mixture, per polarisation (header):
// TE the average f ε1 + (1 − f) ε2, TM the 2D Bruggeman root with Im ε >= 0. Components must
// be passive dielectrics (Re ε > 0, Im ε >= 0), f in [0, 1]; InputError otherwise.
std::complex<double> effective_permittivity_2d(std::complex<double> eps1, std::complex<double> eps2,
                                               double f, Polarisation2d pol);

// Born route for any orientation-averaged 2D spectrum S̄(q) (µm², q in µm⁻¹).
FlatlandTable born_scattering_2d(const std::function<double(double)>& spectrum, double eps_contrast,
                                 double n_eff, double lambda_nm, Polarisation2d pol,
                                 int table_points = 721);

// The 2D spongy medium from a measured 2D indicator spectrum (power_spectrum.h, square or
// rectangular): n_eff from effective_permittivity_2d, Δε = ε_k − ε_a (lossless: the real
// parts of the materials' indices are used; absorption is not modelled in flatland). S̄
// between shell centres is interpolated linearly in q, held at the first shell's value below
// it (as born_medium.h). Refuses a 3D spectrum, f = 0 or 1, equal indices, and pixels coarser
// than λ/(4 n_max).
FlatlandTable born_flatland(const PowerSpectrum& spectrum, const optics::Material& keratin,
                            const optics::Material& air, double lambda_nm, Polarisation2d pol,
                            int table_points = 721);

}  // namespace plumage::sim::wave
