// A slab of a scattering medium (sim/scattering_medium.h) for the tracer, and its closed-form
// single-scattering reflectance and transmittance (the tests' reference and a fast path).
//
// Frame (patch frame of sim/scatterer/scatterer.h): the slab fills |x|, |y| <= half_width_um and
// −thickness_um <= z <= 0, its top face at z = 0 facing +z (the light arrives from above).
// The optional backing (melanin beneath a medulla) fills the same |x|, |y| range and
// −thickness_um − backing thickness <= z <= −thickness_um, directly under the slab.
//
// Surfaces (one unit, all DielectricInterface, sim/scene.h):
//  - "slab": top and sides (and the bottom without a backing): ambient air outside, inside
//    the medium's effective material (n_eff(λ), real: Fresnel and total internal reflection
//    in the effective index) and the scattering medium as the inside medium. Index-matched
//    slabs have air inside instead: the boundary neither reflects nor refracts, and n_eff is
//    not used.
//  - with a backing, "slab on backing": the slab's bottom face, n_eff (or air) inside,
//    the backing's material outside, whose k attenuates by Beer–Lambert (sim/medium.h);
//    "backing": the backing's sides and bottom, its material inside, air outside. Light
//    that crosses the backing leaves below (transmission).
// The lateral faces are far (half_width_um ≫ thickness) so that the slab stands for an
// infinite one; light that reaches them leaves through them (with Fresnel, and counted by
// its direction as up or down), so energy is still conserved.
//
// Parameter table (InputError names the parameter and value):
//  | name                   | unit | default  | valid range                           |
//  |------------------------|------|----------|---------------------------------------|
//  | thickness_um           | µm   | 10       | finite, > 0                           |
//  | half_width_um          | µm   | 1000     | finite, >= 10 × thickness_um          |
//  | index_matched          |      | false    |                                       |
//  | backing.material       |      | melanin  | non-null                              |
//  | backing.thickness_um   | µm   | 1        | finite, > 0                           |
#pragma once

#include <memory>
#include <optional>
#include <span>
#include <vector>

#include "sim/scattering_medium.h"
#include "sim/scene.h"

namespace plumage::sim {

struct SlabBacking {
    std::shared_ptr<const optics::Material> material = optics::melanin();
    double thickness_um = 1.0;
};

struct ScatteringSlabParams {
    double thickness_um = 10.0;
    double half_width_um = 1000.0;
    bool index_matched = false;
    std::optional<SlabBacking> backing;

    void validate() const;  // InputError naming the parameter
};

SceneDescription scattering_slab_scene(std::shared_ptr<const ScatteringMedium> medium,
                                       const ScatteringSlabParams& params = {});

// Single scattering in an index-matched slab (no boundary reflection or refraction) of
// thickness d, light arriving from ω_i (away from the slab, ω_i.z > 0, μ_i = ω_i.z) and
// leaving towards ω_o (reflection ω_o.z > 0, transmission ω_o.z < 0; μ_o = |ω_o.z|): the
// fraction of the incident power per steradian around ω_o (the Scatterer's sample()
// convention, sim/scatterer/scatterer.h: |cos θ_o| included; divide by μ_o for the BRDF/BTDF). With
// τ = μ_t d, ω = μ_s / μ_t and the phase function's cos Θ = (−ω_i) · ω_o:
//     reflection:   ω p(cos Θ) μ_o / (μ_i + μ_o) · (1 − e^{−τ (1/μ_i + 1/μ_o)})
//     transmission: ω p(cos Θ) μ_o / (μ_o − μ_i) · (e^{−τ/μ_o} − e^{−τ/μ_i})
//                   (→ ω p τ / μ_i e^{−τ/μ_i} as μ_o → μ_i),
// the depth integral of the beam attenuated on its way in (e^{−μ_t z/μ_i}), scattered once
// (μ_s p per unit volume and solid angle) and attenuated on its way out. Exact for the
// single-scattered light of an infinite slab; the multiply scattered rest is O(τ²) for
// τ ≪ 1. ω_o in the slab plane (μ_o = 0) gives 0. InputError for ω_i.z <= 0, d <= 0,
// non-unit directions.
double slab_single_scattering(const ScatteringMedium& medium, double lambda_nm, double thickness_um,
                              const Vec3d& wi, const Vec3d& wo);

// Its integrals over the upper (reflectance) and lower (transmittance) hemispheres, by
// composite Gauss–Legendre in μ_o and φ_o (relative error below 1e-6 for the tables of
// born_medium.h).
struct SlabSingleScattering {
    double reflectance = 0.0;
    double transmittance = 0.0;
};
SlabSingleScattering slab_single_scattering_totals(const ScatteringMedium& medium, double lambda_nm,
                                                   double thickness_um, const Vec3d& wi);
// The totals at each wavelength, the wavelengths shared out over the OpenMP threads (each one
// the scalar call above, so the same bits for any thread count). The quadrature is 2 × 512²
// nodes per wavelength: serial, it was most of the spongy study's slab stages.
std::vector<SlabSingleScattering> slab_single_scattering_totals(
    const ScatteringMedium& medium, std::span<const double> wavelengths_nm, double thickness_um,
    const Vec3d& wi);

// The geometric-optics counterpart of a scattering slab: an explicit keratin/air volume
// (geometry/spongy_volume.h's closed mesh of one periodic cube, keratin inside, normals into
// air, its box [0, L]³) traced as interfaces. The cube is tiled: copies side by side in x
// and y and `layers` copies stacked in z, each separated from its neighbours by an air gap
// of `gap_um` (the copies' cut faces would otherwise coincide, which a float tracer cannot
// resolve; the gaps add one keratin/air/keratin crossing per cube crossed, against the
// several per length scale inside). The tiles fill |x|, |y| <= half_width (rounded up to
// whole cubes) and −T <= z <= 0 with T = layers L + (layers − 1) gap; the top face at z = 0
// as in the slab above. With a backing, its box lies `gap_um` beneath the lowest layer, over
// the same |x|, |y| range ("backing": its material inside, air outside). Every surface is a
// DielectricInterface; ambient air.
//
// Parameter table (InputError names the parameter and value):
//  | name           | unit | valid range                                                  |
//  |----------------|------|--------------------------------------------------------------|
//  | cell           |      | non-empty, inside the box [0, cell_um]³ (to 1e-6 cell_um)    |
//  | cell_um (L)    | µm   | finite, > 0                                                  |
//  | layers         |      | [1, 64]                                                      |
//  | gap_um         | µm   | finite, (0, L / 10]                                          |
//  | half_width_um  | µm   | finite, >= L / 2; at most 201 cubes per side                 |
//  | backing        |      | as ScatteringSlabParams (material non-null, thickness > 0)   |
struct TiledVolumeSlabParams {
    int layers = 1;
    double gap_um = 0.01;
    double half_width_um = 30.0;
    std::optional<SlabBacking> backing;
};
struct TiledVolumeSlab {
    SceneDescription scene;
    double thickness_um = 0.0;   // T
    double half_width_um = 0.0;  // of the tiled area (whole cubes)
    int cubes_per_side = 0;      // in x and in y
};
TiledVolumeSlab tiled_volume_slab_scene(geometry::TriangleMesh cell, double cell_um,
                                        const TiledVolumeSlabParams& params);

}  // namespace plumage::sim
