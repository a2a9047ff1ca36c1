// Power spectra of a sampled indicator field (3D and 2D), with FFTW3.
//
// Field and frames: a periodic cube (square in 2D) of side L = N h, N voxels (pixels) of
// side h per axis, values at the voxel centres; index (i, j, k) with k fastest, as in
// index_field.h. Wavevectors lie on the lattice q = (2π/L) m, m ∈ ℤ³, |m_a| <= N/2.
//
// Rectangular 2D fields (measure_2d(values, nx, ny, h)): a periodic rectangle of nx × ny
// square pixels of side h, Lx = nx h, Ly = ny h, stored row by row (ny rows of nx values, x
// fastest: values[row · nx + column], as an image). The lattice is q = 2π (m_x/Lx, m_y/Ly),
// |m_x| <= nx/2, |m_y| <= ny/2, and the area A = Lx Ly replaces L^d below. The square API is
// the case nx = ny = N (same numbers to round-off).
//
// Normalisation (the same as geometry::measure_power_spectrum): with
//     χ̂(q) = h^d Σ_x (χ(x) − f) e^{−i q·x}    (d = 3 or 2),
// the power spectral density is S(q) = |χ̂(q)|² / L^d (µm³ in 3D, µm² in 2D), so that
//     Σ_q S(q) / L^d = ∫ S(q) d^d q / (2π)^d = f (1 − f) = Var χ
// (Parseval; the q = 0 mode is zero since the mean is subtracted). S(q) is real, even in
// q. `variance()` returns that sum, and equals the real-space variance to round-off.
//
// Radial shells: width Δq = 2π / max(L_a) (the finest lattice spacing; 2π/L for a cube or
// square); shell j holds the modes with |q| ∈ [(j − ½) Δq, (j + ½) Δq), j = 1 … ⌊N_long/2⌋,
// N_long the pixel count along the longest side (its axis points q = j Δq put at least one
// mode in every shell, so no shell is empty). The last shell reaches π/h, the Nyquist
// wavenumber of every axis (the pixels are square), as for the cube.
//
// Isotropy assumption. born_medium.h uses only the orientation average S̄(|q|): this is
// exact for a statistically isotropic structure (channel- and sphere-type spongy keratin
// from random seeds) and an approximation for a single realisation, whose shells hold a
// finite number of modes. `isotropy` quantifies the directional spread on the peak shell
// as the ratio of the extreme eigenvalues of the power-weighted second-moment tensor
//     M = Σ_shell S(q) q̂ q̂ᵀ / Σ_shell S(q)
// (1 for isotropy: M = I/3 in 3D, I/2 in 2D). For a Gaussian random field each mode's
// power is exponentially distributed, so even an isotropic sample shows a ratio above 1,
// by about 1 + c/√(modes on the shell); a ratio well above that means orientation, and
// the orientation average should not be used as the scattering kernel.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace plumage::sim::wave {

struct RadialSpectrum {
    std::vector<double> q_per_um;     // mean |q| of each shell's modes, shells j = 1 … ⌊N/2⌋
                                      // (⌊N_long/2⌋ for a rectangle)
    std::vector<double> power;        // mean S over each shell (µm³ or µm²)
    std::vector<std::size_t> modes;   // modes in each shell (whole q space, both signs)
    double shell_width_per_um = 0.0;  // Δq = 2π / max L; shell j: |q|/Δq ∈ [j − ½, j + ½)
    double peak_q_per_um = 0.0;       // parabolic vertex at the largest shell
    std::size_t peak_shell = 0;       // index into the vectors above
    // Isotropy on the peak shell (header): λ_max / λ_min of M, and the eigenvalues.
    double isotropy_eigenvalue_ratio = 1.0;
    std::vector<double> moment_eigenvalues;

    // S̄(q) as the Born routes use it (born_medium.h, born_2d.h): linear in q between shell
    // centres; below the first shell held at its value (the box has no modes there; the
    // forward angles concerned carry little of μ_s); from the last shell's mean |q| to the
    // outer edge of that shell held at its value (the voxel limit keeps 2k below π/h, the
    // edge); beyond it an internal error (PLUMAGE_CHECK): the caller broke that limit.
    double at(double q_per_um) const;
};

// The spectrum of one field. Half-complex layout of FFTW's r2c transform: the last axis
// keeps m_last = 0 … N/2 only; modes with 0 < m_last < N/2 stand for themselves and their
// mirror −q.
class PowerSpectrum {
public:
    int dimension() const { return dimension_; }
    // N of a cube or square; for a rectangle nx (the last, fastest axis).
    int voxels_per_side() const { return shape_[2]; }
    double voxel_um() const { return voxel_um_; }
    // L of a cube or square; for a rectangle Lx.
    double box_um() const { return shape_[2] * voxel_um_; }
    // Pixels along x (last axis) and y (2D: the rows; 3D: the middle axis).
    int voxels_x() const { return shape_[2]; }
    int voxels_y() const { return shape_[1]; }
    // Area (2D, µm²) or volume (3D, µm³) of the periodic cell: the L^d of the header.
    double cell_measure() const;
    double filling_fraction() const { return fraction_; }
    // S at lattice index (i, j[, k]) of the half-complex array (last index <= N/2).
    double at(std::size_t flat_index) const { return power_[flat_index]; }
    const std::vector<double>& half_complex() const { return power_; }
    // Σ_q S(q) / L^d over the full lattice (each half-complex mode with its multiplicity).
    double variance() const;
    // The shells' average, computed once when the spectrum is measured (the Born and
    // strong-contrast routes read it at every wavelength).
    const RadialSpectrum& radial() const { return radial_; }

    // Measured on a field of 0/1 values (or any real field: the mean is subtracted).
    // values.size() must be N³ (3D) or N² (2D); throws InputError otherwise, for N < 4 or
    // N > 1024, or for h <= 0.
    static PowerSpectrum measure_3d(const std::vector<double>& values, int n, double voxel_um);
    static PowerSpectrum measure_2d(const std::vector<double>& values, int n, double voxel_um);
    // A rectangular periodic 2D field, nx × ny pixels (header: values[row · nx + column]).
    // Throws InputError for nx or ny outside [4, 1024], h <= 0, values.size() != nx ny, or a
    // non-finite value.
    static PowerSpectrum measure_2d(const std::vector<double>& values, int nx, int ny,
                                    double voxel_um);

private:
    // shape = {n0, n1, n2}: pixels per axis, slowest first (2D: {1, ny, nx}).
    static PowerSpectrum measure(const std::vector<double>& values, int dimension,
                                 std::array<int, 3> shape, double voxel_um);
    RadialSpectrum radial_average() const;
    int dimension_ = 3;
    std::array<int, 3> shape_{0, 0, 0};
    double voxel_um_ = 0.0;
    double fraction_ = 0.0;
    std::vector<double> power_;  // half-complex, last axis n2/2 + 1
    RadialSpectrum radial_;
};

}  // namespace plumage::sim::wave
