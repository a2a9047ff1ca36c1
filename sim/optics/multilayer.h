// Planar multilayer stacks: coherent transfer matrices, with layers that may be flagged
// incoherent (much thicker than the light's coherence length) and combined by intensity.
//
// Geometry: light arrives from the ambient medium (lossless, index n_0) above the
// stack, crosses layers 1..N from top to bottom, and leaves into the substrate (index
// n_{N+1}, may absorb). Conventions as in fresnel.h (n + ik, k >= 0; s and p; q = n cos θ).
// Units: thickness in micrometres, wavelength in nanometres.
//
// Coherent part (Byrnes, arXiv:1603.02720, Sec. 3): each layer's propagation matrix
// diag(e^{-iδ}, e^{iδ}) is written as e^{-iδ} diag(1, e^{2iδ}), and each interface
// matrix [[1, r], [r, 1]] / t as (1/t) [[1, r], [r, 1]]. The scalar factors are carried
// apart, so every matrix entry has modulus <= 2 and nothing overflows for a 100 µm layer
// with k = 10 (where e^{-iδ} alone would be e^{15000}), and no division by t occurs.
//
// Incoherent layers (Katsidis & Siapkas, Appl. Opt. 41, 3978 (2002)): the stack is cut
// at each incoherent layer into coherent sub-stacks; each sub-stack's forward and
// backward intensity reflectance and transmittance are combined through the layer's
// single-pass power attenuation, i.e. the phase-averaged result. A 50 µm layer then
// does not alias under any spectral sampling.
#pragma once

#include <span>
#include <vector>

#include "sim/optics/fresnel.h"

namespace plumage::optics {

enum class Coherence { coherent, incoherent };

struct StackLayer {
    Complex n;            // refractive index of the layer at the wavelength in question
    double thickness_um;  // >= 0
    Coherence coherence = Coherence::coherent;
};

// One wavelength's view of a stack: indices already evaluated at that wavelength.
struct StackIndices {
    double ambient;                      // incidence medium, lossless
    std::span<const StackLayer> layers;  // top to bottom; may be empty (a bare interface)
    Complex substrate;                   // exit medium, may absorb
};

struct StackAmplitudes {
    Complex r;
    Complex t;
};

struct StackIntensities {
    double reflectance;
    double transmittance;
    double absorptance;  // 1 − R − T
};

// Amplitudes of an all-coherent stack (InputError if any layer is incoherent: an
// incoherent layer has no defined phase).
StackAmplitudes transfer_matrix_amplitudes(const StackIndices& stack, double lambda_nm,
                                           double cos_theta_i, Polarisation pol);

// R, T, A of any stack; incoherent layers are combined by intensity.
StackIntensities transfer_matrix_intensities(const StackIndices& stack, double lambda_nm,
                                             double cos_theta_i, Polarisation pol);
StackIntensities transfer_matrix_intensities_unpolarised(const StackIndices& stack,
                                                         double lambda_nm, double cos_theta_i);

// Fraction of the incident power absorbed in each layer of an all-coherent stack,
// from the normal Poynting flux of the fields at each layer's top and bottom
// (Byrnes Eqs. 24–25); the substrate receives the transmittance. Independent of the
// reflectance, so R + T + Σ A_j = 1 is a real check of the field solution.
std::vector<double> coherent_layer_absorption(const StackIndices& stack, double lambda_nm,
                                              double cos_theta_i, Polarisation pol);

}  // namespace plumage::optics
