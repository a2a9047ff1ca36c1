// Full wave in 3D: a slab of material, periodic laterally (a voxel volume from the spongy
// generators, a lattice of spheres, any body given by an inside test), on air or a substrate,
// lit at normal incidence from air above; its specular and diffuse reflectance and
// transmittance (all diffraction orders), unpolarised (or under E_x alone: Slab3d::e_x_only).
//
// Frame: x, y lateral, z up; the slab fills 0 <= z <= thickness where `inside` holds, repeated
// with the period along x and y (inside is asked at x, y in [0, period)); the substrate, if
// any, fills z < 0. Meep's grid is ours with z shifted (centre of the cell at Meep's origin),
// one lateral period wide in whole grid cells (the resolution is raised to the nearest such
// grid), PML above and below, periodic sides (Bloch k = 0). Lengths µm, wavelengths nm.
//
// Method: a plane source of E_x (or E_y, the other polarisation; unpolarised = their mean) over
// the whole cell above the slab, a Gaussian pulse over the wavelengths asked; on a plane above the
// slab the scattered field (total minus the incident wave, which comes from a cell four columns
// wide each way with the same rows) and on a plane under it the total field, E_x, E_y, H_x, H_y
// from Meep's DFT on its centred grid. Powers are the planes' mean of Re(E* × H)·ẑ; the specular
// (transmitted straight-through) part is the power of the plane-averaged fields, i.e. diffraction
// order (0, 0), the diffuse part the rest (Fourier orders are orthogonal over the period, so
// the powers add). Reflectance and transmittance are over the incident wave's power.
// R + T = 1 for lossless bodies (tested), and a uniform slab against the transfer matrix.
//
// Stop: when |E|² at a probe under the slab has fallen to `decay` of its peak, or max_time
// after the source has ended (if > 0). Measured (the spongy reference's channel network at
// n = 1.10, 1.2 µm period, 400–700 nm): the planes' 50-nm band sums of diffuse power hold within
// ±4 % from 15 to about 85 time units after the source, then drift by about −1 % per 10 time
// units at 400–550 nm, fastest near 540 nm (the (2, 1) order's grazing wavelength,
// period/√5 = 537 nm), where the diffuse power turns negative, which no physical field does: a
// field that does not decay (its source is not identified; near-grazing orders, which the PML
// absorbs slowly, are the suspects), holds the probe above 1e-4, and shows only beside weak
// scattering (at n = 1.55, with 25–70 times the diffuse light, the same band sums hold within
// 0.2 % in the blue from 100 to 500 time units, while the 650–700 nm sum, the cell's slow
// resonances, rises by half until about 400).
// Such runs take max_time.
//
// Smoothing: Kottke's anisotropic average over every pixel that a 3 × 3 × 3 test finds cut, on
// a 5 × 5 × 5 lattice of samples, the boundary normal being the direction of ε's first moment
// (full_wave_2d.h's rule in 3D). Dispersion: per wavelength (one run each, a D conductivity for
// Im ε) or fitted (one run for all wavelengths, Lorentz poles; lorentz_fit.h).
//
// Refused before any work (InputError naming the limit): an empty or non-finite geometry, a grid
// coarser than λ/(10 n), a feature (thinnest_um, stated by the caller) under two cells, a period
// under four cells, Re ε < 1, the memory the grid needs beyond memory_limit(). The stop flag
// ends a run between time steps (Interrupted).
//
// Parameter table:
//  | name          | unit | range                                            |
//  |---------------|------|--------------------------------------------------|
//  | period_um     | µm   | finite, >= four grid cells, <= 100               |
//  | thickness_um  | µm   | finite, > 0, <= 100                              |
//  | thinnest_um   | µm   | finite, > 0: the smallest feature of the body    |
//  | lambda_nm     | nm   | (200, 2000], in the materials' range             |
#pragma once

#include <functional>
#include <memory>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "sim/fullwave/full_wave_2d.h"
#include "sim/optics/material.h"

namespace plumage::sim::fullwave {

struct Slab3d {
    double period_um = 0.0;                              // lateral period along x and y
    double thickness_um = 0.0;                           // the slab: 0 <= z <= thickness
    double thinnest_um = 0.0;                            // the body's smallest feature
    std::function<bool(const Eigen::Vector3d&)> inside;  // x, y in [0, period), z in the slab
    std::shared_ptr<const optics::Material> material;    // where inside holds
    std::shared_ptr<const optics::Material> substrate;   // z < 0; nullptr: air
    // true: the E_x run alone (half the cost). One realisation's result is then that
    // polarisation's, not the unpolarised one; over realisations of a statistically isotropic
    // medium its mean is the unpolarised mean (E_x and E_y are alike in distribution).
    bool e_x_only = false;
};

struct SlabSpectrum {
    double lambda_nm = 0.0;
    double specular_reflectance = 0.0, diffuse_reflectance = 0.0;
    // NaN under an absorbing substrate (the power decays there)
    double specular_transmittance = 0.0, diffuse_transmittance = 0.0;
};

struct FullWaveSlabResult {
    double resolution_px_per_um = 0.0;      // the grid's: the period in whole cells
    std::vector<SlabSpectrum> wavelengths;  // in the order asked, unpolarised
    std::size_t grid_cells = 0;
    double time_steps = 0.0;  // of the longest run
    double seconds = 0.0;
    std::vector<LorentzFit> dispersion_fits;  // Dispersion::fitted: one per material
};

FullWaveSlabResult full_wave_slab(const Slab3d& slab, std::span<const double> lambdas_nm,
                                  const FullWave2dOptions& options);

}  // namespace plumage::sim::fullwave
