// Spongy keratin's medium by the strong-contrast expansion: the effective permittivity of a
// two-phase medium, resummed to all orders in the contrast at the two-point level, with the
// attenuation of the coherent wave that scattering causes — a third route beside first Born
// and the sphere route (born_medium.h), which are both second order in the contrast.
//
// Units: lengths µm, wavenumbers µm⁻¹, wavelengths nm (vacuum), S̄(q) µm³, μ in µm⁻¹.
//
// The expansion (Torquato's strong-contrast series in its nonlocal form, Torquato and Kim,
// Phys. Rev. X 11, 021002 (2021); derivation in docs/spongy_media.md). A host phase q of
// permittivity ε_q, an inclusion phase p of ε_p at volume fraction φ, β = (ε_p − ε_q)/(ε_p + 2
// ε_q). Truncated after its two-point term,
//     φ² β / y = φ − β A₂(Q),   y = (ε_e − ε_q)/(ε_e + 2 ε_q),
// that is ε_e = ε_q [1 + 3 β φ² / (φ (1 − β φ) − β A₂(Q))]. With A₂ = 0 it is Maxwell
// Garnett (the Hashin–Shtrikman bound of that host); A₂ carries the spectral density
// S̄(q) = χ̃_V(q) (power_spectrum.h, µm³, ∫ S̄ d³q/(2π)³ = φ(1 − φ)) through
//     A₂(Q) = 3 ∫ d³r χ_V(r) ê·H(r)·ê e^{−iQ k̂·r},
// H the dyadic Green function of the host (∇×∇× − Q²) without its δ(r) part, ê ⊥ k̂.
//
// Im A₂ is the on-shell part: the pole of the transverse propagator puts the scattered wave
// on the sphere |Q k̂ + q| = Q, with the dipole projection ê·(I − ŝŝ)·ê averaged over ê:
//     Im A₂(Q) = (3Q/8π) ∫₀^{2Q} q S̄(q) w(q, Q) dq,   w = (1 + μ²)/2,  μ = 1 − q²/(2Q²).
// At weak contrast, Im ε_e = 3 ε_q β² Im A₂ and μ_ext = k0 Im ε_e / √ε_q: exactly first
// Born's μ_s (born_medium.h) in the host — the test. Averaging the dyadic over directions
// before applying the incident phase would replace w by its directional mean 2/3: equal as
// Q → 0, but back-scattering (μ = −1) weighed 2/3 as much — and spongy colour is back-
// scattering, so w is kept (the Debye check below tells the two forms apart).
//
// Re A₂ from causality. A₂(Q)/Q² is analytic in the upper half Q-plane (in real space it is
// an integral of e^{iQ(r − k̂·r)}, bounded there) and tends to a constant as Q → 0 (A₂ = 0 in
// the static limit of an isotropic medium) and to 0 as |Q| → ∞, so one subtraction gives
//     Re A₂(Q) = (2Q²/π) ∫₀^∞ [h(s) − h(Q)] / (s² − Q²) ds,   h(s) = Im A₂(s)/s,
// (P∫₀^∞ ds/(s² − Q²) = 0). Check (strong_contrast_test.cpp): for a Debye medium
// χ_V = φ(1 − φ) e^{−r/a} this gives Re A₂ → (11/5) Q² φ(1 − φ) a² as Qa → 0, the real-space
// expansion of the dyadic with the incident phase (2/3 from the wave part, 1/15 from the
// static dipole field times the phase's second order) — an independent closed form.
//
// Spectra. S̄ is known up to q_cut (a voxel volume's last shell); beyond it Porod's law
// S̄ = S̄(q_cut) (q_cut/q)⁴ of sharp interfaces, integrated in closed form, so h(s) is exact
// for the piecewise-linear S̄ at every s and tends to h_∞ = (3/8π) ∫₀^∞ q S̄ dq.
//
// The medium (strong_contrast_medium): with a phase as host, ε_e at Q = k0 Re √ε_MG (the wave
// that propagates in the composite samples the structure; ε_MG, Maxwell Garnett of the chosen
// host, tends to the host's at weak contrast); self-consistent, at Q = k0 Re √ε_e (below).
// μ_ext = 2 k0 Im √ε_e; μ_a = 2 k0 Im √ε_bg (the phases' own loss in the A₂ = 0 background:
// Maxwell Garnett or Bruggeman); μ_s = μ_ext − μ_a. The phase function is first Born's shape S̄(q)(1
// + μ²)/2 at q = 2 k0 Re √ε_e sin(θ/2): the two-point level resums the strength of scattering, not
// its angular distribution. n_eff = Re √ε_e + i μ_a/(2 k0).
//
// What it leaves out, and its range: three-point and higher terms (the expansion converges
// fast when the host is the connected phase; for a bicontinuous network neither phase is
// the obvious host — both are offered, and the self-consistent form); Torquato and Kim state
// the nonlocal series for 0 ≤ |k| ℓ ≲ 1 (ℓ a heterogeneity length); spongy colour is made at
// k n_eff Λ ≈ 3, beyond that. Against 3D full wave (tests/reference/spongy_3d/README.md) no
// form moves the air-sphere packing's diffuse-R peak where first Born misses it, so the
// studies keep first Born; this route is there to be compared.
//
// Refused (InputError, value and limit named): what born_medium refuses (f = 0 or 1, equal
// indices, voxels coarser than λ/(4 n_max)), q_cut ≤ 0, a spectrum < 0 or not finite.
#pragma once

#include <complex>
#include <functional>
#include <vector>

#include "sim/optics/material.h"
#include "sim/wave/volume/born_medium.h"
#include "sim/wave/volume/power_spectrum.h"

namespace plumage::sim::wave {

// A₂(Q) of one spectrum, for any Q > 0 (µm⁻¹). Built once per spectrum: the cumulative
// moments ∫₀^x qⁿ S̄ dq (n = 1, 3, 5) of S̄ linear between nodes, exact for that S̄.
class StrongContrastKernel final {
public:
    // S̄ linear through (q_i, S_i), q_0 = 0 < q_1 < … = q_cut (µm⁻¹), S_i in µm³.
    StrongContrastKernel(std::vector<double> q_nodes_per_um, std::vector<double> spectrum_um3);
    // spectrum: S̄(q) on [0, q_cut], sampled every q_step (the last step shortened).
    static StrongContrastKernel sampled(const std::function<double(double)>& spectrum,
                                        double q_cut_per_um, double q_step_per_um);
    // A voxel volume's radial spectrum exactly as born_medium uses it (RadialSpectrum::at):
    // nodes at 0 and at the shells' mean |q|, q_cut the last shell's.
    static StrongContrastKernel of(const RadialSpectrum& radial);

    double im_a2(double q_per_um) const;             // (3Q/8π) ∫₀^{2Q} q S̄ w dq
    std::complex<double> a2(double q_per_um) const;  // Re by the subtracted dispersion relation
    double im_a2_over_q_limit() const { return h_infinity_; }  // h_∞

private:
    double moment(int n, double x) const;  // ∫₀^x qⁿ S̄ dq, n ∈ {1, 3, 5}
    double h(double s) const;              // Im A₂(s)/s

    std::vector<double> q_, s_;         // nodes and S̄ there
    std::vector<double> m1_, m3_, m5_;  // cumulative moments at the nodes
    double porod_ = 0.0;                // S̄(q_cut) q_cut⁴
    double h_infinity_ = 0.0;
};

// ε_e of the two-point strong-contrast approximation (header).
std::complex<double> strong_contrast_permittivity(std::complex<double> eps_inclusion,
                                                  std::complex<double> eps_host,
                                                  double inclusion_fraction,
                                                  std::complex<double> a2);

// The self-consistent form (host = the effective medium itself, ε_r = ε_e, so y = 0): the
// two-point series of a general reference, ⟨β⟩ + (β_a − β_b)² A₂ = 0 with
// β_i = (ε_i − ε_e)/(ε_i + 2 ε_e), treats both phases alike (a bicontinuous network has no
// matrix). With A₂ = 0 it is Bruggeman's condition; at weak contrast Im ε_e = Δε² Im A₂/(3 ε_e),
// first Born in the Bruggeman medium — born_medium exactly, n_eff included. Solved by Newton at
// fixed A₂(k0 Re √ε), A₂ updated until ε is stationary (1e-13), from `start` (Bruggeman).
std::complex<double> self_consistent_strong_contrast_permittivity(
    std::complex<double> eps_a, std::complex<double> eps_b, double fraction_a,
    const std::function<std::complex<double>(std::complex<double>)>& a2_of_eps,
    std::complex<double> start);

// keratin or air: that phase is the expansion's host (Maxwell Garnett background);
// bruggeman: the self-consistent form (Bruggeman background).
enum class StrongContrastHost { keratin, air, bruggeman };

// The spongy-keratin medium from a measured indicator spectrum, with keratin or air as the
// host phase of the expansion. Same refusals as born_medium.
ScatteringTable strong_contrast_medium(const PowerSpectrum& spectrum,
                                       const optics::Material& keratin, const optics::Material& air,
                                       double lambda_nm, StrongContrastHost host,
                                       int table_points = 181);

}  // namespace plumage::sim::wave
