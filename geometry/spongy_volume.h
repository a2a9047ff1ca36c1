// Spongy keratin volumes: the quasi-ordered keratin/air networks inside blue barbs (dominant
// length scale a ≈ 0.15–0.25 µm, keratin filling fraction f ≈ 0.4–0.6: R. O. Prum, R. Torres,
// S. Williamson and J. Dyck, "Two-dimensional Fourier analysis of the spongy medullary keratin of
// structurally coloured feather barbs", Proc. R. Soc. B 266, 1999; V. Saranathan et al.,
// "Structure and optical function of amorphous photonic nanostructures from avian feather
// barbs: a comparative small angle X-ray scattering (SAXS) analysis of 230 bird species",
// J. R. Soc. Interface 9, 2012), in the two morphologies of the literature:
//
//  - channel-type: a Gaussian random field whose power spectrum is a thin spherical
//    shell around k0 = 2π/a, thresholded. A shell spectrum is the simplest field with
//    one dominant length scale and no long-range order, which is what the measured
//    (SAXS) ring-shaped structure factors of channel-type barbs show. The field is
//    built in Fourier space: every mode gets the amplitude √S(|k|) of a Gaussian shell
//    S(k) ∝ exp(−(k − k0)² / (2 (w k0)²)) and a seeded random phase, with Hermitian
//    symmetry so that the inverse FFT is real. Fixed amplitudes (rather than Rayleigh
//    ones) make the realised spectrum equal S exactly; with thousands of shell modes
//    the field is Gaussian by the central limit theorem. The threshold is the quantile
//    that makes exactly round(f N³) voxels keratin.
//  - sphere-type: air spheres of radius r in keratin, placed by random sequential
//    addition (uniform centres, rejected if closer than a minimum centre separation s
//    to an earlier centre) until the air volume fraction of the voxels reaches 1 − f.
//    s < 2r lets neighbouring spheres overlap into the interconnected cavities seen in
//    sphere-type barbs; s = 2r gives disjoint spheres (whose random sequential addition
//    jams near an air fraction of 0.38). The last sphere is kept only if that brings the
//    fraction closer to the target.
//
// Voxel grid and frames. The volume is a periodic cube of side L = N h (N voxels of
// size h per side) in world coordinates (µm), [0, L]³. Voxel (i, j, k) is the cell
// [i h, (i + 1) h] × …, its centre (i + ½) h is where values live (the OpenVDB
// transform is a uniform scale by h followed by a translation of h/2).
//
// The keratin indicator χ of a voxel is 1 if its centre is keratin, else 0; the keratin
// filling fraction is defined as the mean of χ over the N³ voxels of the box. It is
// measured on the returned level set (value < 0 means keratin), so it describes
// exactly the stored volume.
//
// The level set is an openvdb::FloatGrid of class GRID_LEVEL_SET, negative inside
// keratin, in world units (µm), with active voxels where |φ| < half_width h and the
// background ±half_width h. It describes the sample "keratin ∩ box": inside the box φ
// is the periodic field, outside it is max(φ_periodic, d_box) with d_box the signed
// distance to the box, so the keratin body is closed at the box faces (its cut faces lie
// on the faces of the box) and a mesher produces a closed surface. The N³ voxels of
// the box hold one full period, so a periodic field can be read back from them.
//   - sphere-type: φ = max_i (r − |x − c_i|) over all spheres and their periodic
//     images: the exact signed distance on the keratin side; on the air side it is the
//     distance to the surface of the nearest sphere, exact except near the circles
//     where two spheres intersect.
//   - channel-type: first φ = (t − g) / |∇g| (g the field, t the threshold, ∇g exact by
//     spectral differentiation), the first-order distance to the iso-surface g = t. The
//     field bends on the scale 1/k0 = a/2π (1.6 voxels at a = 10 voxels), so this is off
//     by tens of per cent a voxel away; the band is therefore redistanced by fast
//     sweeping (openvdb::tools::sdfToSdf): voxels next to the surface take their distance
//     from the interpolated crossings, the others solve |∇φ| = 1. Measured (central
//     differences at |φ| < h): median |∇φ| 1.01, quartiles 0.96–1.05 (first-order
//     estimate alone: 1.06, 1.00–1.16).
// Every voxel's sign equals its indicator (values that would round to zero are pushed
// to ±1e-6 h; checked voxel by voxel), so the fraction and spectrum measured on the grid
// are those of the indicator built during generation.
//
// Power spectrum of the indicator. With χ̂(k) = h³ Σ_x (χ(x) − f) e^{−i k·x} over the
// N³ voxel centres, the power spectral density is S(k) = |χ̂(k)|² / L³ (µm³), so that
// Σ_k S(k) / L³ = f (1 − f), the indicator's variance. It is averaged over the modes
// of each spherical shell j = 1 … ⌊N/2⌋ of width Δk = 2π/L around |k| = j Δk (beyond
// N/2 the shells are cut by the grid's cube of wavevectors). The peak wavenumber is the
// vertex of the parabola through the largest shell and its two neighbours (so it is not
// quantised to Δk); the dominant length scale is 2π / k_peak. For channel volumes it is
// within about 1 % of a (10 seeds × f = 0.4, 0.5, 0.6 × a = 0.15, 0.2, 0.25 µm in boxes
// of 8–10 a). Sphere packings by random sequential addition are only weakly ordered at
// air fractions 0.4–0.6: the packing stops far below jamming, and the sphere form factor
// falls steeply towards its first zero (k r = 4.49) across the structure-factor peak at
// k ≈ 2π/spacing. Their spectrum has a weak maximum near the sphere spacing over a
// raised low-k floor, and the largest shell can be one of the first few: read the whole
// spectrum there, not the peak alone.
//
// Determinism: all random numbers come from std::mt19937_64 seeded through
// std::seed_seq from (seed, item, stream), and uniform variates are taken from the raw
// 64-bit output (not from std::uniform_real_distribution, whose algorithm the standard
// leaves to the library). The same parameters give bit-identical grids on any thread
// count.
//
// clang-format off
// Parameter table (lengths in µm):
//  | name                      | unit | default | valid range                                          |
//  |---------------------------|------|---------|------------------------------------------------------|
//  | box_um (L)                | µm   | 2.0     | finite, a whole number N of voxels, 4 <= N <= 512    |
//  | voxel_um (h)              | µm   | 0.02    | finite, > 0                                          |
//  | half_width_voxels         | 1    | 3       | [1, 16]: narrow-band half-width                      |
//  | keratin_fraction (f)      | 1    | 0.5     | (0, 1)                                               |
//  | seed, item                | —    | 1, 0    | any                                                  |
//  channel-type:
//  | length_scale_um (a)       | µm   | 0.2     | > 2 h (k0 = 2π/a below the Nyquist wavenumber π/h),  |
//  |                           |      |         | <= L/2                                               |
//  | shell_relative_width (w)  | 1    | 0.15    | (0, 1]: σ_k = w k0                                   |
//  sphere-type:
//  | sphere_radius_um (r)      | µm   | 0.1     | > h, <= L/4 (no sphere meets its own image)          |
//  | min_separation_diameters  | 1    | 0.8     | (0, 2], and s = 2 r · value <= L/2                   |
//  | max_attempts              | 1    | 2·10⁶   | >= 1: random sequential addition attempts            |
// clang-format on
// An unreachable air fraction (jammed packing) is an InputError that says what was
// reached.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include <openvdb/openvdb.h>
#include <Eigen/Core>

#include "geometry/triangle_mesh.h"

namespace plumage::geometry {

struct ChannelVolumeParams {
    double length_scale_um = 0.2;
    double shell_relative_width = 0.15;
    double keratin_fraction = 0.5;
    double box_um = 2.0;
    double voxel_um = 0.02;
    double half_width_voxels = 3.0;
    std::uint64_t seed = 1;
    std::uint64_t item = 0;
};

struct SphereVolumeParams {
    double sphere_radius_um = 0.1;
    double min_separation_diameters = 0.8;
    double keratin_fraction = 0.5;
    double box_um = 2.0;
    double voxel_um = 0.02;
    double half_width_voxels = 3.0;
    std::int64_t max_attempts = 2'000'000;
    std::uint64_t seed = 1;
    std::uint64_t item = 0;
};

enum class SpongyMorphology { channel, sphere };

// Radially averaged power spectral density of the keratin indicator (header comment).
struct RadialPowerSpectrum {
    std::vector<double> wavenumber_per_um;  // mean |k| of each shell's modes, µm⁻¹
    std::vector<double> power_um3;          // mean S(k) over each shell, µm³
    std::vector<std::size_t> modes;         // number of wavevectors in each shell
    double shell_width_per_um = 0.0;        // Δk = 2π / L
    double peak_wavenumber_per_um = 0.0;    // parabolic vertex at the largest shell
    double peak_length_um = 0.0;            // 2π / peak_wavenumber_per_um
};

struct SpongyVolume {
    SpongyMorphology morphology = SpongyMorphology::channel;
    openvdb::FloatGrid::Ptr level_set;  // named "keratin", with the metadata below
    double box_um = 0.0;
    double voxel_um = 0.0;
    int voxels_per_side = 0;
    double keratin_fraction = 0.0;  // measured: mean of the voxel indicator
    RadialPowerSpectrum spectrum;
    std::vector<Vec3> air_sphere_centres_um;  // sphere-type only, in [0, L)³
};

// Both validate their parameters first and throw InputError naming the parameter, its
// value and what was expected (and why, where the limit is physical).
SpongyVolume make_channel_volume(const ChannelVolumeParams& params);
SpongyVolume make_sphere_volume(const SphereVolumeParams& params);

// Measurements of a level set written by the functions above (or loaded from a .vdb
// they wrote): they read the box from the grid's metadata ("plumage_voxels_per_side",
// "plumage_voxel_um"; the voxel size as written, since a transform read back from a .vdb
// can differ in its last bits) and throw InputError if it is missing. Other metadata
// (provenance): plumage_box_um, plumage_morphology, plumage_requested_keratin_fraction,
// plumage_seed, plumage_item, plumage_units and the morphology's parameters.
double measure_keratin_fraction(const openvdb::FloatGrid& level_set);
RadialPowerSpectrum measure_power_spectrum(const openvdb::FloatGrid& level_set);

// The keratin of a volume written by the functions above (or loaded from a .vdb they wrote) as
// the periodic body it samples: inside(p) for any point p (µm) wrapped into the box [0, L)³,
// by trilinear interpolation of φ between the voxel centres (φ < 0: keratin), the box's N³
// values copied once (4 N³ bytes). The full-wave slab (sim/fullwave/full_wave_slab.h) asks it
// at every grid point and subpixel sample. InputError as measure_keratin_fraction.
std::function<bool(const Eigen::Vector3d&)> periodic_keratin_test(
    const openvdb::FloatGrid& level_set);

// .vdb files. save_level_set writes one grid (named "keratin" if it has no name) to a
// temporary name in the target's folder and renames it into place; IoError on failure.
// load_level_set reads the named FloatGrid and throws InputError naming the file and the
// grid if the file is missing or unreadable, holds no such grid (the message lists the
// grids it holds), the grid is not a FloatGrid, not of class level set, or its voxels are
// not uniform cubes.
void save_level_set(const openvdb::FloatGrid& level_set, const std::filesystem::path& path);
openvdb::FloatGrid::Ptr load_level_set(const std::filesystem::path& path,
                                       const std::string& grid_name = "keratin");

// The zero iso-surface of a level set (openvdb::tools::volumeToMesh, quads split along
// their shorter diagonal), wound as TriangleMesh requires: geometric normals point from
// the negative side (keratin) into the positive side (air). OpenVDB winds its polygons
// the other way (normals towards negative values), so every polygon is reversed.
// adaptivity in [0, 1] (0: one vertex per voxel crossed by the surface). For a volume
// from this file the mesh is closed: it bounds keratin ∩ box.
TriangleMesh level_set_to_mesh(const openvdb::FloatGrid& level_set, double adaptivity = 0.0);

}  // namespace plumage::geometry
