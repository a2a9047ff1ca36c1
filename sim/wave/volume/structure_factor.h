// Structure factors of sphere packings: the Percus–Yevick closed form for hard spheres and
// the measured S(q) of a periodic set of centres.
//
// Conventions: lengths in µm, wavenumbers in µm⁻¹ (q = 2 k n sin(θ/2) in a medium).
// S(q) = (1/N) |Σ_j e^{−i q·r_j}|² for q ≠ 0, so S → 1 at large q (uncorrelated centres)
// and S(0) is the reduced compressibility. φ is the hard-sphere volume fraction
// n π σ³ / 6 (σ the hard-sphere diameter = the minimum centre separation, n the number
// density).
//
// Percus–Yevick (Wertheim 1963, Thiele 1963): the direct correlation function is
//     c(r) = −α − β (r/σ) − (φ α / 2) (r/σ)³ for r < σ, 0 beyond,
//     α = (1 + 2φ)² / (1 − φ)⁴, β = −6 φ (1 + φ/2)² / (1 − φ)⁴,
// and S(q) = 1 / (1 − n ĉ(q)) with ĉ its 3D Fourier transform (closed form in the
// source). S(0) = (1 − φ)⁴ / (1 + 2φ)². PY describes *equilibrium* hard spheres; a random
// sequential addition packing (geometry/spongy_volume.h) is not in equilibrium and jams
// at φ ≈ 0.38, so its S(q) agrees with PY only approximately (first-peak position to a
// few per cent at φ ≈ 0.3; the peak height is lower).
//
// Measured S(q): the box is periodic (side L), so only q on the reciprocal lattice
// (2π/L) ℤ³ is meaningful. The orientation average is taken over the modes of the shells
// |q| ∈ [(j − ½) Δq, (j + ½) Δq), Δq = 2π/L, j = 1 … j_max, as in measure_power_spectrum.
#pragma once

#include <algorithm>

#include <cstddef>
#include <vector>

#include <Eigen/Core>

namespace plumage::sim::wave {

// S(q) of equilibrium hard spheres of diameter sigma_um at volume fraction phi in (0, 0.6]
// (the closed form is finite up to φ < 1, but PY is unphysical beyond random close
// packing). Throws InputError outside those ranges or for q < 0.
double percus_yevick_structure_factor(double q_per_um, double sigma_um, double phi);

// The first maximum of the PY S(q) (golden-section search on a bracket found by scanning
// qσ in (0, 4π)), µm⁻¹.
double percus_yevick_first_peak(double sigma_um, double phi);

struct MeasuredStructureFactor {
    std::vector<double> q_per_um;    // mean |q| of each shell's modes
    std::vector<double> s;           // mean S over each shell
    std::vector<std::size_t> modes;  // number of reciprocal-lattice vectors in the shell
    double shell_width_per_um = 0.0;

    // S at |q| (1/µm), linear between the shells' mean |q|; the first and last shell's S beyond
    // them. q_per_um ascending, at least one shell.
    double at(double q) const {
        if (q <= q_per_um.front()) return s.front();
        if (q >= q_per_um.back()) return s.back();
        const auto i = static_cast<std::size_t>(
            std::upper_bound(q_per_um.begin(), q_per_um.end(), q) - q_per_um.begin());
        const double t = (q - q_per_um[i - 1]) / (q_per_um[i] - q_per_um[i - 1]);
        return (1.0 - t) * s[i - 1] + t * s[i];
    }
};

// S(q) of N points in the periodic box [0, L)³ for the shells up to q_max_per_um (direct
// sums over the centres, O(N · modes)). Throws InputError for fewer than 2 centres, a
// centre outside the box, L <= 0, or q_max below the first shell.
MeasuredStructureFactor measure_structure_factor(const std::vector<Eigen::Vector3d>& centres_um,
                                                 double box_um, double q_max_per_um);

// Peak of a tabulated S(q): vertex of the parabola through the largest value in
// [q_min, q_max] and its neighbours.
double structure_factor_peak(const MeasuredStructureFactor& s, double q_min_per_um,
                             double q_max_per_um);

}  // namespace plumage::sim::wave
