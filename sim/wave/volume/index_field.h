// The keratin indicator and the permittivity contrast of a spongy volume on its voxel grid.
//
// Source: a level set from geometry/spongy_volume.h (generated, or read back with
// load_level_set): an openvdb::FloatGrid, negative inside keratin, whose N³ voxels
// (i, j, k) ∈ [0, N)³ of size h hold one period of the structure, voxel values at the
// centres (i + ½) h. The box is read from the grid's metadata ("plumage_voxels_per_side",
// "plumage_voxel_um", as measure_power_spectrum does); a grid without them is refused.
// The indicator χ = 1 where the stored value is < 0 (keratin), else 0, voxel by voxel:
// exactly the indicator whose fraction and spectrum geometry/ reports.
//
// Layout: flat index (i N + j) N + k (k fastest), the layout of power_spectrum.h.
//
// Contrast: Δε(r) = ε(r) − ε_eff with ε(r) = ε_keratin χ + ε_air (1 − χ) (relative
// permittivities, ε = n², complex, e^{−iωt}: Im >= 0 absorbs), ε_eff the Bruggeman
// permittivity at the measured filling fraction (effective_index.h).
//
// Validity (InputError naming value and limit): the structure must have contrast (0 < f <
// 1 and ε_keratin ≠ ε_air), and voxels must resolve the shortest wavelength inside the
// densest component, h <= λ / (4 n_max), so that the grid's largest wavenumber π/h
// covers backscattering, q = 2 k n_eff <= 4π n_max / λ.
#pragma once

#include <complex>
#include <cstdint>
#include <vector>

#include <openvdb/openvdb.h>

#include "sim/optics/material.h"

namespace plumage::sim::wave {

struct IndicatorField {
    int voxels_per_side = 0;            // N
    double voxel_um = 0.0;              // h
    std::vector<std::uint8_t> keratin;  // χ, N³ values, k fastest

    double box_um() const { return voxels_per_side * voxel_um; }
    double filling_fraction() const;  // mean of χ
    std::vector<double> as_doubles() const;
};

IndicatorField sample_indicator(const openvdb::FloatGrid& level_set);

struct ContrastField {
    std::complex<double> eps_keratin, eps_air, eps_eff;
    double filling_fraction = 0.0;
    std::vector<std::complex<double>> delta_eps;  // Δε, N³ values, k fastest
};

// Refuses f = 0 or 1, equal indices, and voxels coarser than λ / (4 n_max).
ContrastField index_contrast(const IndicatorField& field, const optics::Material& keratin,
                             const optics::Material& air, double lambda_nm);

// The voxel limit alone (used by born_medium.h too): throws InputError naming h, λ, n_max
// and the limit λ / (4 n_max) if h exceeds it.
void require_resolved(double voxel_um, double lambda_nm, double n_max);

}  // namespace plumage::sim::wave
