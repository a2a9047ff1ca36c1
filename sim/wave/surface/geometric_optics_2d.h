// Geometric optics (ray optics + the local thin-film stack, level 1 of physics,
// docs/architecture.md) for the same 2D cross-sections and rows as physical optics
// (physical_optics_2d.h), and the detector window both are read through.
//
// Model. The surface is sampled exactly as physical optics samples it (sample_cross_section,
// the same step), lit by the same test (illuminated(): ω_i·n > 0 and no chord towards ω_i), and
// each lit element sends the power its width intercepts times the stack's reflectance,
//     p_j = |r(cos θ_local)|² (ω_i·n_j) ds_j                                [µm],
// into the mirror direction of its normal, ω_r = 2 (ω_i·n) n − ω_i, a single bounce. r is the
// same transfer-matrix amplitude (same stack, same polarisation, same 3D local angle under
// conical incidence) physical optics puts in its reflected part. So GO is PO's reflected part
// with the phases dropped: the same approximation level (single bounce, no transmission, the
// same lit/dark rule, optionally the same outgoing visibility: the mirror ray must leave without
// crossing a chord), and PO − GO isolates diffraction (finite apertures, interference between
// elements and cells, edge waves). Energy: Σ_j p_j is what PO's reflected part integrates to over
// all angles as the structure grows (tests).
//
// Frame and units as physical_optics_2d.h: x horizontal, z up, θ from +z towards +x, directions
// away from the object, lengths µm, wavelengths nm, angles rad. A ray's power is per unit length
// along y for a unit-intensity incident plane wave: the GO counterpart of ∫σ dθ_s.
//
// Detector window. A goniometer reads the power into a cone, not σ at a point: both levels are
// compared as W(θ) = ∫ K(θ − θ') dP(θ') [µm/rad], K a normalised kernel in θ (wrapped to
// (−π, π]): box of half-width w (K = 1/(2w) on |Δ| <= w; default w = 5°, the goniometer's cone
// half-angle), or a Gaussian with the box's variance (standard deviation w/√3), cut at 4 σ. For
// rays dP is a sum of deltas; for a PO scattering width sampled on a uniform grid of spacing δ
// each sample stands for its cell [θ_j − δ/2, θ_j + δ/2] (the box takes the cell's overlap with
// the window exactly; the Gaussian its value at θ_j times δ). δ must resolve σ's oscillations
// (at most π/(2 k R_max), R_max the largest |r'|, the Nyquist rate of |U|²): the caller chooses.
//
// Parameter table:
//  | name               | unit | range                                             |
//  |--------------------|------|---------------------------------------------------|
//  | incidence, row     |      | as physical_optics_2d.h                           |
//  | window half_angle  | rad  | (0, π/4] (the Gaussian's 4σ cut stays below π)    |
#pragma once

#include <span>
#include <vector>

#include "sim/wave/surface/physical_optics_2d.h"

namespace plumage::sim::wave {

// One reflected ray: its direction θ_s (rad) and power p (µm, per unit length along y).
struct GeometricRay2d {
    double theta_s_rad;
    double power_um;
};

struct GeometricOpticsOptions {
    double step_um = 0.0;  // 0: λ/10, as physical optics (a coarser step is refused)
    bool outgoing_visibility = false;
};

// The rays of the lit samples of a prepared reflected-part kernel (prepare_far_field with
// FarFieldPart::reflected, on `sampled`): the lower-level entry that shares one lit test and one
// set of stack amplitudes with the physical-optics sum. InputError when the kernel holds another
// part (its amplitudes would not be r).
std::vector<GeometricRay2d> geometric_rays(const FarFieldKernel2d& reflected_kernel,
                                           const SampledCrossSection2d& sampled,
                                           bool outgoing_visibility = false);
// One cross-section, sampled as physical optics samples it.
std::vector<GeometricRay2d> geometric_rays(const CrossSection2d& section,
                                           const Incidence2d& incidence,
                                           const GeometricOpticsOptions& options = {});
// A row: the rays of every realisation (place_row), each power divided by the number of
// realisations (the ensemble mean, as scattering_width's σ); one realisation without jitter.
std::vector<GeometricRay2d> geometric_rays(const Row2d& row, const Incidence2d& incidence,
                                           const GeometricOpticsOptions& options = {});

// Σ p over rays with |θ_s| < max_abs_theta_rad (default: every ray).
double total_power(std::span<const GeometricRay2d> rays, double max_abs_theta_rad = 4.0);

enum class WindowKernel { box, gaussian };

struct DetectorWindow {
    double half_angle_rad = 5.0 * 0.017453292519943295;  // the goniometer's cone half-angle
    WindowKernel kernel = WindowKernel::gaussian;
};

// W(θ_out) of the rays (header) at each theta_out, µm/rad.
std::vector<double> windowed(std::span<const GeometricRay2d> rays, const DetectorWindow& window,
                             std::span<const double> theta_out_rad);
// W(θ_out) of a scattering width sampled on a uniform, increasing grid (>= 2 points), µm/rad.
std::vector<double> windowed(std::span<const double> theta_grid_rad, std::span<const double> sigma,
                             const DetectorWindow& window, std::span<const double> theta_out_rad);

}  // namespace plumage::sim::wave
