// A material's index over a band as a sum of Lorentz poles, the form Meep's time stepping
// takes (its lorentzian_susceptibility), so that ONE full-wave run covers every wavelength of
// the band (full_wave_2d.h, Dispersion::fitted) instead of one run per wavelength.
//
//   ε(f) = ε_∞ + Σ_k σ_k f_k² / (f_k² − f² − i f γ_k),   f = 1/λ in 1/µm,
//
// Meep's frequency with its length unit a = 1 µm, its e^{−iωt} (absorption: Im ε > 0); f_k
// and γ_k in the same unit (Meep multiplies both by 2π). The model is causal by construction and
// passive because every term has σ_k ≥ 0 and γ_k ≥ 0; ε_∞ ≥ 1 keeps the instantaneous wave no
// faster than in vacuum, so Meep's Courant step stays stable. Every f_k is at most
// max_pole_frequency: a pole at f_k is stable in Meep's update while 2π f_k Δt < 2
// (Δt = courant / resolution); full_wave_2d refuses a resolution that breaks it.
//
// The fit: for pole positions and widths fixed, ε_∞ and σ_k are a linear least-squares problem
// with bounds (ε_∞ ≥ 1, σ_k ≥ 0), solved exactly by trying every active set (at most 2^4);
// the positions and widths are found by Nelder–Mead on the relative misfit
// Σ |ε_fit − ε|² / |ε|² at 81 frequencies evenly spaced over the band, adding one pole at a
// time (from a fixed grid of starts: deterministic) until the index is within `target_index_error`
// or `max_poles` are used. A material without absorption in the band gets lossless poles
// (γ_k = 0). The error is then measured on 401 wavelengths: max |n_fit + i k_fit − (n + i k)|.
//
// The project's own indices are not exactly causal (melanin's k = C exp(−λ/D) beside a Cauchy
// n does not obey Kramers–Kronig), so no pole sum reproduces them exactly. Over 380–780 nm with
// poles up to 10 /µm: keratin |Δ(n + ik)| = 3.3e-4 (one lossless pole at 9.05 /µm, ε_∞ held at
// 1), melanin 4.2e-3 (three poles; 2.0e-3 over 400–700 nm; 3.8e-3 without the damping bound
// below). tests/sim/fullwave/lorentz_fit_test.cpp holds both.
//
// An absorbing material's poles are damped, f_k / γ_k ≤ 10 (lorentz_fit.cpp, kMaxQuality): the
// source's pulse excites poles just above the band, and an undamped one rings on after it (a
// lossless melanin pole at 266 nm kept a 20 µm barbule's run going for over 15 minutes). A run that
// uses a fit states its error (FullWave2dResult) and refuses a fit worse than the caller allows.
//
// Parameter table:
//  | name                     | unit | range                                        |
//  |--------------------------|------|----------------------------------------------|
//  | lambda_min_nm, max       | nm   | 200 < min < max <= 2000                      |
//  | max_pole_frequency       | 1/µm | > 1000 / lambda_min_nm (above the band)       |
//  | max_poles                | 1    | 1–3                                          |
//  | target_index_error       | 1    | > 0                                          |
#pragma once

#include <complex>
#include <string>
#include <vector>

#include "sim/optics/material.h"

namespace plumage::sim::fullwave {

struct LorentzPole {
    double frequency_per_um = 0.0;  // f_k
    double damping_per_um = 0.0;    // γ_k
    double strength = 0.0;          // σ_k
};

struct LorentzPermittivity {
    double eps_infinity = 1.0;
    std::vector<LorentzPole> poles;
    std::complex<double> epsilon(double lambda_nm) const;
};

struct LorentzFit {
    std::string material;
    LorentzPermittivity model;
    double lambda_min_nm = 0.0, lambda_max_nm = 0.0;
    double max_index_error = 0.0;  // max over the band of |n_fit + i k_fit − (n + i k)|
};

LorentzFit fit_lorentz(const optics::Material& material, double lambda_min_nm, double lambda_max_nm,
                       double max_pole_frequency_per_um, int max_poles = 3,
                       double target_index_error = 1e-3);

}  // namespace plumage::sim::fullwave
