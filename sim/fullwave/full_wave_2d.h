// Full wave (level 4 of physics, docs/architecture.md): Maxwell's equations on a grid by the
// finite-difference time-domain method of Meep's C++ library, for 2D cross-sections. The
// level every cheaper level (ray optics + film, physical optics, Born) is judged against: it
// leaves out nothing but the grid's discretisation, whose error each result states.
//
// Frame, polarisations and normalisation are physical_optics_2d.h's, so the two compare point
// by point: x horizontal, z up, invariant along y; TE: E along y (u = E_y), TM: H along y
// (u = H_y); light comes from ω_i = (sin θ_i, cos θ_i) and travels along −ω_i; the far field
// is σ(θ_s) = lim r |u_s|² / |u_0|² in µm/rad towards ω_s = (sin θ_s, cos θ_s),
// θ_s ∈ (−π, π], u_s the SCATTERED field (total minus incident) and u_0 the incident
// amplitude; ∫σ dθ_s = scattered power per unit length over the incident intensity.
//
// The isolated cross-section (full_wave_far_field). Meep's grid is ours turned by −θ_i, so that
// the light always comes straight down (Meep's x = our x, Meep's y = our z at θ_i = 0; the
// invariant axis is Meep's z: TE is Meep's Ez, TM Meep's Hz): a line source across the whole
// cell, through the side PMLs (an integrated current, Meep's rule for a source that enters a
// PML), a Gaussian pulse covering the wavelengths asked. Each wavelength is one run with the
// materials exact at that wavelength: ε = Re(n + ik)² and a D conductivity σ_D = ω Im ε / Re ε
// (Meep's ε(ω) = ε(1 + iσ_D/ω)). The incident field at every wavelength comes from one run of
// air on a cell four columns wide, periodic in x, with the same rows, PML, source and stop rule:
// the wave does not depend on x, so this costs a few per cent of an empty run of the whole
// cell, and gives the widths of a melanin ellipse within 1.3e-4 (TE) and 1e-5 (TM) of what that
// empty run gives (40 px/µm), far under any grid error. On a closed box around the bodies
// (gap_um away) the scattered field is the run's discrete Fourier transform minus the incident
// wave's, on the same grid rows.
//  - Far field: the exterior Green's representation on the box,
//        f(θ) = e^{iπ/4}/√(8πk) ∮ [−ik (ω̂·ν) u_s − ∂u_s/∂ν] e^{−ik ω̂·r'} ds',
//    σ = |f|²/|u_0|², from ONE component u on the two grid lines straddling each side (their
//    mean and difference: consistent to O((kΔx)²)). Meep's own near2far is not used: it put a
//    mirror image of the forward lobe, (kΔx/2)² as strong, into the specular direction
//    (docs/full_wave.md).
//  - u_0: the incident wave near the box's bottom side referred to the origin with the
//    exact k (the wave the body's forward field interferes with in the optical theorem).
//  - Widths (µm; power per unit length over the incident intensity I = |u_0|²/2, in Meep's
//    units c = ε_0 = μ_0 = 1, where the normal flux through a line in air is
//    Im(u* ∂u/∂ν)/(2ω) for either polarisation): scattering = the scattered field's outward
//    flux through the box; absorption = minus the total field's; extinction = the 2D optical
//    theorem, −2 √(2π/k) Re[e^{iπ/4} f(forward)/u_0]. Three independent numbers:
//    extinction = scattering + absorption holds to the grid's error (tested).
//  - Stop: when |u|² at a probe under the bodies has fallen to `decay` of its peak, or (with
//    far_field_tolerance > 0) when the widths the DFTs give so far have settled: every 10 time
//    units once the source has ended and light has crossed the cell, the sums over the run's
//    wavelengths of the back-hemisphere, scattering and absorption widths are computed; the run
//    stops when each has stayed within the tolerance (max − min, over the back sum itself or
//    over scattering + absorption) for one round trip of light around the bodies' bounding box
//    at their largest index (at least 30 time units): light guided around a barbule's cortex
//    leaks a burst each trip. The incident wave's run keeps the probe rule.
//
// The planar stack (full_wave_stack): layers only, as a periodic row (full_wave_row, below) four
// grid columns wide at normal incidence, PML above and below. Reflectance: the scattered field's
// upward flux above the stack over the incident flux; transmittance: the total field's downward
// flux below it (a lossless medium: Im(u* ∂u/∂y)/(2ω), divided by ε for TM). Tested against the
// transfer matrix (multilayer.h).
//
// Dispersion (FullWave2dOptions::dispersion): per_wavelength as above, or fitted: one run for
// all wavelengths, each material as ε_∞ (subpixel-smoothed like a constant ε) plus Lorentz
// poles fitted over the band (lorentz_fit.h; Meep's lorentzian_susceptibility), whose strengths
// are averaged over each pixel a boundary cuts (the fraction of the pixel inside the body: Meep
// smooths only ε_∞). Poles are capped at 10 /µm (λ = 100 nm), stable in Meep's update for any
// grid finer than 15.7 px/µm, which the λ/(10 n) rule already demands in the visible. The
// fits' index errors are in the result; a fit worse than max_fit_index_error is refused.
//
// Resolution error: a caller runs resolution r and 1.5 r (subpixel smoothing on); the fine
// run's error is at most 2 |fine − coarse| for an error falling at least as fast as the grid
// step, 0.8 |fine − coarse| at second order (docs/full_wave.md; the tests hold the first).
//
// Refused before any work (InputError naming the limit): a grid coarser than λ/(10 n) for the
// shortest wavelength and the largest n of the bodies; a body thinner than two grid cells; a
// material with Re ε < 1 (metals: outside this level's scope); the memory the grid needs
// (estimated per cell) beyond memory_limit(). A set stop flag ends a run between time steps
// (InputError is not thrown: Interrupted, common/interrupt.h).
//
// Parameter table:
//  | name                  | unit  | range                                               |
//  |-----------------------|-------|-----------------------------------------------------|
//  | lambda_nm             | nm    | finite, in (200, 2000], in the materials' range     |
//  | theta_i               | rad   | finite                                              |
//  | resolution_px_per_um  | 1/µm  | finite, >= 10 n_max / λ_min(µm), <= 400             |
//  | pml_um, gap_um        | µm    | finite, >= one grid cell                            |
//  | decay                 | 1     | in (0, 1e-2]                                        |
//  | far_field_tolerance   | 1     | 0 (off) or in [1e-6, 1e-2]                          |
//  | tolerance             | 1     | in (0, 1)                                           |
#pragma once

#include <atomic>
#include <cstddef>
#include <span>
#include <vector>

#include "sim/fullwave/cross_section_2d.h"
#include "sim/fullwave/lorentz_fit.h"
#include "sim/wave/volume/born_2d.h"  // Polarisation2d

namespace plumage::sim::fullwave {

using wave::Polarisation2d;

// How the materials' dispersion enters the runs.
enum class Dispersion {
    per_wavelength,  // one run per wavelength, every material exact there (the reference)
    fitted,          // one run for all wavelengths, every material as Lorentz poles fitted
                     // over the band (lorentz_fit.h): about (wavelengths + 1)/2 times faster,
                     // within the fit's index error (stated in the result)
};

struct FullWave2dOptions {
    double resolution_px_per_um = 40.0;
    double pml_um = 1.0;
    double gap_um = 0.5;  // bodies → monitor box → source → PML
    double decay = 1e-7;  // stop when |u|² at the probe is below decay × its peak
    // full_wave_far_field only: > 0 replaces the probe's decay by the far field's own
    // convergence (above, "Stop"; docs/full_wave.md, "Cost"): the band sums of the widths stay
    // within this fraction over one round trip of light around the bodies.
    double far_field_tolerance = 0.0;
    // > 0: a run under the probe's rule also ends this many time units (µm/c) after its source
    // has, whatever the probe says (a field that never decays: full_wave_slab.h, "Stop").
    double max_time = 0.0;
    bool subpixel_smoothing = true;           // Meep's anisotropic averaging at boundaries
    const std::atomic<bool>* stop = nullptr;  // polled between time steps
    // Runs at once (the runs of the wavelengths are independent; each is serial):
    // 0 = OpenMP's default. Results do not depend on it (tested bit for bit).
    int threads = 0;
    Dispersion dispersion = Dispersion::per_wavelength;
    // Dispersion::fitted: the largest |Δ(n + ik)| a material's fit may have over the band
    // (380–780 nm, widened to the wavelengths asked); a worse fit is refused.
    double max_fit_index_error = 5e-3;
};

struct FarField2d {
    double lambda_nm = 0.0;
    std::vector<double> sigma_um_per_rad;   // at the θ_s asked
    double scattering_width_um = 0.0;       // scattered flux through the box / I
    double absorption_width_um = 0.0;       // −(total field's net outward flux) / I
    double extinction_width_um = 0.0;       // optical theorem
    double back_scattering_width_um = 0.0;  // ∫σ over the back hemisphere, ω_s·ω_i > 0
    double time_steps = 0.0;                // of this wavelength's run
};

struct FullWave2dResult {
    Polarisation2d polarisation = Polarisation2d::te;
    double theta_i_rad = 0.0, resolution_px_per_um = 0.0;
    std::vector<double> theta_s_rad;
    std::vector<FarField2d> wavelengths;  // in the order asked
    std::size_t grid_cells = 0;
    double seconds = 0.0;                     // wall time of all runs, the incident wave's included
    std::vector<LorentzFit> dispersion_fits;  // Dispersion::fitted: one per material
};

// σ(θ_s) and the widths of an isolated cross-section (no layers) at each wavelength.
FullWave2dResult full_wave_far_field(const CrossSection2d& section, Polarisation2d pol,
                                     double theta_i_rad, std::span<const double> lambdas_nm,
                                     std::span<const double> theta_s_rad,
                                     const FullWave2dOptions& options);

struct StackReflectance {
    double lambda_nm = 0.0;
    double reflectance = 0.0, transmittance = 0.0;
};

// R and T of a stack of layers (bodies whose shapes are layer(); the lowest may reach −∞) at
// normal incidence from air above. T is measured in the medium under the stack when it is
// lossless; under an absorbing substrate it is NaN (the power decays there).
std::vector<StackReflectance> full_wave_stack(const CrossSection2d& layers, Polarisation2d pol,
                                              std::span<const double> lambdas_nm,
                                              const FullWave2dOptions& options);

// One diffraction order of a periodic row: its number m (x wavenumber k_x + m/Λ in cycles/µm,
// k_x = −f sin θ_i), its direction ω_s = (sin θ_s, cos θ_s) (reflected: cos θ_s > 0;
// transmitted: < 0, in the medium under the row) and its power over the incident power.
struct DiffractionOrder {
    int m = 0;
    double theta_s_rad = 0.0;
    double efficiency = 0.0;
};

struct RowSpectrum {
    double lambda_nm = 0.0;
    double reflectance = 0.0;    // all propagating reflected orders
    double transmittance = 0.0;  // all transmitted orders; NaN under an absorbing substrate
    std::vector<DiffractionOrder> reflected, transmitted;  // the propagating orders, by m
    double time_steps = 0.0;                               // of the run holding this wavelength
};

struct FullWaveRowResult {
    Polarisation2d polarisation = Polarisation2d::te;
    double theta_i_rad = 0.0, period_um = 0.0;
    double resolution_px_per_um = 0.0;     // the grid's: the period in whole cells (>= the asked)
    std::vector<RowSpectrum> wavelengths;  // in the order asked
    std::size_t grid_cells = 0;
    double seconds = 0.0;                     // wall time of all runs
    std::vector<LorentzFit> dispersion_fits;  // Dispersion::fitted: one per material
};

// A periodic row (Bloch boundaries): `period` holds the bodies of one period around x = 0
// (they may reach into the neighbouring periods: every body is repeated at x + m·period_um),
// over air or a substrate layer, lit from air above by a plane wave at θ_i. Meep's frame is
// ours, not turned: x along the row, y = z. The source is a line across the cell with the
// phase e^{2πi k_x x}, k_x = −f sin θ_i (cycles/µm), and Meep's Bloch phase on the cell's
// sides; on a line above the bodies the scattered field (total minus the incident wave, which
// comes from a cell four columns wide with the same rows and phase) and on a line under them
// the total field are split into the Bloch orders q_m = k_x + m/Λ by a discrete Fourier sum
// over the period's grid columns, each propagating order's power being Im(a_m* ∂a_m/∂y)/(2ω)
// (divided by ε under the row for TM), over the incident power. R + T = 1 for lossless bodies
// (tested), and a planar film against the transfer matrix at oblique incidence.
//  - Normal incidence: one incident run and one run per wavelength (or one for all, fitted).
//  - Oblique: k_x depends on the wavelength, so every wavelength is a run of its own (and an
//    incident run), with a pulse narrow enough that order 0's grazing frequency f |sin θ_i| is
//    four pulse widths away. Dispersion::fitted is refused there.
// The period is a whole, even number of grid cells: the resolution is raised to the nearest
// such grid (result.resolution_px_per_um). Refused as full_wave_far_field's, and: |θ_i| > 80°,
// a period under four grid cells.
FullWaveRowResult full_wave_row(const CrossSection2d& period, double period_um, Polarisation2d pol,
                                double theta_i_rad, std::span<const double> lambdas_nm,
                                const FullWave2dOptions& options);

// The grid cells of one run of full_wave_row on this period (the grid refined to a whole, even
// number of cells per period, the rows as the run lays them out): for estimates of cost and
// memory before a run. No checks beyond full_wave_row's arithmetic.
std::size_t full_wave_row_cells(const CrossSection2d& period, double period_um,
                                const FullWave2dOptions& options);

// The largest grid step the physics allows for this section at these wavelengths (λ/(10 n)),
// and the smallest allowed by its thinnest body (half of it): the checks above, for callers
// that choose a resolution.
double minimum_resolution_px_per_um(const CrossSection2d& section,
                                    std::span<const double> lambdas_nm);

}  // namespace plumage::sim::fullwave
