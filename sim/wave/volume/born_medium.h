// Scattering coefficient, phase function and absorption of spongy keratin, computed from
// its structure: the first-Born (Rayleigh–Gans–Debye) route from the indicator's power
// spectrum, and the sphere route (Mie × structure factor) for sphere packings. The numbers
// a sim::Medium (sim/medium.h) needs: μ_s(λ), p(cos θ, λ), μ_a(λ).
//
// Units: lengths µm, wavelengths nm (vacuum), μ_s and μ_a in µm⁻¹, phase function in sr⁻¹.
//
// Born route. The medium is the effective medium ε_eff (Bruggeman, effective_index.h) plus
// the fluctuation Δε(r) = ε(r) − ε_eff = (ε_k − ε_a)(χ(r) − f) + const; the constant only
// scatters at q = 0 (forward, zero measure), so
//     dσ/dΩ / V = k0⁴ / (16π²) · |ε_k − ε_a|² · S̄(q) · (1 + cos²θ)/2,
//     q = 2 k0 n_eff sin(θ/2),
// S̄ the orientation-averaged indicator spectrum of power_spectrum.h (µm³, Σ S / V = f(1−f)),
// k0 = 2π/λ the *vacuum* wavenumber, n_eff = Re √ε_eff. Why vacuum k0 with absolute Δε: the
// wave equation in the background is (∇² + k0² ε_eff) E = −k0² Δε E, so the source of the
// scattered wave is k0² Δε E and its far field carries k0⁴ |Δε|²/(16π²); written with the
// medium's wavenumber k = k0 n_eff the same factor is k⁴ |Δε/ε_eff|²/(16π²). The wave that
// propagates and scatters is the one in the medium, so q uses k0 n_eff. (1 + cos²θ)/2 is the
// dipole factor for unpolarised light. The orientation average assumes a statistically
// isotropic structure (power_spectrum.h says how to check). Validity: first Born holds
// for k0 |Δε| ℓ / n_eff ≪ 1 over the correlation length ℓ — for keratin/air (Δε ≈ 1.4)
// at ℓ ≈ 0.1–0.2 µm this is marginal. Against 3D full wave (tests/reference/spongy_3d, keratin
// n = 1.55, 2 µm slabs): every 50-nm band of the diffuse reflectance within 15 % beyond the noise
// on channel networks and on air spheres in keratin; the packings' diffuse-R peak, full wave's
// at 458 nm near their Bragg condition and the route's at 400 nm, differ within that peak's noise
// floor (79 nm over three realisations), which the reference cannot narrow; keratin spheres in
// air 20–72 % high.
//
// Sphere route. N spheres of radius a per volume V (number density ρ = N/V), index n_s, in
// the effective medium n_eff (lossless part): with Mie amplitudes S1, S2 at m = n_s/n_eff,
// x = k0 n_eff a, and the structure factor S(q) of the centres,
//     dσ/dΩ / V = ρ · (|S1|² + |S2|²) / (2 k²) · S(q),  k = k0 n_eff,
// the same normalisation as the Born route. This is the convention of structcol (Mie of a
// sphere in the Bruggeman medium): the sphere's contrast is to ε_eff, not to the host.
//
// The two routes do NOT agree at weak contrast. For disjoint spheres (a hard-sphere
// packing) the indicator spectrum is S̄(q) = ρ V_s² F(qa)² S(q) at q ≠ 0 (F the sphere form
// factor), and as m → 1 Mie tends to RGD, (|S1|² + |S2|²)/(2k²) → k⁴ |m² − 1|² V_s² F² /
// (16π²) · (1 + cos²θ)/2 with k⁴ |m² − 1|² = k0⁴ |ε_s − ε_eff|². So, angle by angle,
//     Born / sphere route = |ε_s − ε_h|² / |ε_s − ε_eff|² · (1 + O(Δn)),
// and Bruggeman to first order in δ = ε_s − ε_h (effective_index.h) is ε_eff = ε_h + φ δ
// − φ(1 − φ) δ²/(3 ε_h), so ε_s − ε_eff = (1 − φ) δ (1 + φ δ/(3 ε_h) + O(δ²)) and
//     μ_s(Born) / μ_s(sphere) → 1 / (1 − φ)²   as Δn → 0,
// φ the sphere volume fraction: 2.04 at φ = 0.3, 4 at φ = 0.5. The O(Δn) remainder is
// Bruggeman's second-order term and Mie's departure from RGD; the ratio → 1 only as φ → 0
// (dilute spheres, ε_eff → ε_h). The routes differ in convention, not in accuracy: Born
// scatters from the full two-phase contrast around the mean medium, the sphere route from
// each sphere's contrast to a medium that already contains the spheres. 3D full wave decides
// for Born's full contrast: the sphere route is 40–84 % low on both packings there
// (tests/reference/spongy_3d/README.md). Tests
// (born_medium_test.cpp): RoutesDifferByTheSquaredDepletedContrastAtWeakContrast on the exact
// spectrum of a Percus–Yevick packing; GeneratedPackingFollowsTheWeakContrastRatio on a generated
// packing's measured spectrum and S(q), within 1.2 % of 1/(1 − φ)² in a 3.2 µm box (the rest is
// the interpolation between the box's q shells).
//
// Integrals and table. μ_s = 2π ∫_{−1}^{1} dσ/dΩ/V dμ, by 512-point Gauss–Legendre in μ =
// cos θ. p(μ) = (dσ/dΩ/V) / μ_s, normalised to ∫ p dΩ = 1; g = 2π ∫ μ p dμ. The table
// holds p at `table_points` values of μ, uniform in θ from 0 to π.
//
// Absorption: μ_a = 4π Im(n_eff) / λ (λ in µm) from the Bruggeman index of the complex
// component indices (keratin's k; zero for the lossless defaults).
//
// Validity limits refused with InputError naming value and limit: no contrast (f = 0 or 1,
// equal indices), voxels coarser than λ / (4 n_max) (index_field.h).
#pragma once

#include <complex>
#include <functional>
#include <vector>

#include "sim/optics/material.h"
#include "sim/wave/volume/power_spectrum.h"

namespace plumage::sim::wave {

struct ScatteringTable {
    double lambda_nm = 0.0;
    std::complex<double> n_eff;  // Bruggeman effective index
    double mu_s_per_um = 0.0;
    double mu_a_per_um = 0.0;
    double g = 0.0;
    std::vector<double> cos_theta;     // table abscissae, from 1 (θ = 0) to −1 (θ = π)
    std::vector<double> phase_per_sr;  // p(μ), ∫ p dΩ = 1
};

// The common integral: dσ/dΩ/V as a function of μ = cos θ (µm⁻¹ sr⁻¹, >= 0).
ScatteringTable integrate_differential(const std::function<double(double)>& dsigma_domega,
                                       int table_points = 181);

// Born route for any orientation-averaged spectrum S̄(q) (µm³, q in µm⁻¹), given the
// component contrast ε_k − ε_a and the background index n_eff (real part used for q).
ScatteringTable born_scattering(const std::function<double(double)>& spectrum,
                                std::complex<double> eps_contrast, std::complex<double> n_eff,
                                double lambda_nm, int table_points = 181);

// The spongy-keratin medium from a measured indicator spectrum (power_spectrum.h):
// refuses f = 0 or 1, equal indices, voxels coarser than λ/(4 n_max). S̄ between shell
// centres is interpolated linearly in q; below the first shell it is held at the first
// shell's value (the box has no modes there; at the forward angles concerned the dipole
// factor and the small solid angle make that choice matter little for μ_s).
ScatteringTable born_medium(const PowerSpectrum& spectrum, const optics::Material& keratin,
                            const optics::Material& air, double lambda_nm, int table_points = 181);
// born_medium's refusals alone (the wavelength, f, the contrast, the voxels), for the routes
// that take the same inputs (strong_contrast.h).
void require_born_inputs(const PowerSpectrum& spectrum, const optics::Material& keratin,
                         const optics::Material& air, double lambda_nm);

// Sphere route: spheres of index `sphere` and radius `radius_um` at number density
// `number_density_per_um3` (volume fraction φ = ρ 4π a³/3 of sphere material; the rest is
// `host`), structure factor S(q) of the centres (q in µm⁻¹). n_eff is the Bruggeman index
// of sphere and host at fraction φ. Refuses φ outside (0, 1) and equal indices.
ScatteringTable sphere_medium(double radius_um, double number_density_per_um3,
                              const optics::Material& sphere, const optics::Material& host,
                              const std::function<double(double)>& structure_factor,
                              double lambda_nm, int table_points = 181);

}  // namespace plumage::sim::wave
