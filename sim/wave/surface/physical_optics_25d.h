// Physical optics in 2.5D: a row of barbule cross-sections (physical_optics_2d.h) extruded along
// the barbules, with Huang's longitudinal tilt distribution, as a Scatterer with an importance
// sampler of its lobes ("Sampling", below), so that every instrument can measure it.
//
// Frames. Patch frame of scatterer.h: +z the patch normal, +x the barb axis (the row
// direction), +y along the barbules. The 2D row lies in the x–z plane (Row2d's frame, row along
// +x, tilt μ as there). A direction ω = (cos ε sin θ, sin ε, cos ε cos θ): θ its transverse angle
// (2D convention: from +z towards +x), ε its elevation out of the x–z plane.
//
// Derivation.
// 1. Straight extrusion (conical incidence). A y-invariant structure lit with e^{ik_y y}
//    scatters only into k_y' = k_y: ω_o,y = −ω_i,y (directions point away), the cone
//    ε_o = −ε_i. The transverse field solves the 2D Helmholtz equation with k_t = k cos ε_i;
//    Kirchhoff's surface fields are the 2D ones with r at the 3D local angle cos θ_local =
//    ω_i·n = cos ε_i (ω_i,t·n) (Incidence2d::cos_elevation). Transverse fluxes of the incident
//    and scattered waves both carry cos ε (|ε_o| = |ε_i|), so per unit length along y the power
//    into dθ_o is  dP = I cos ε_i σ_t(θ_i → θ_o) dθ_o, σ_t the 2D width at k_t (check: a flat
//    strip gives I R W (ω_i·n), the power it intercepts times R).
// 2. Longitudinal tilt (Huang 2022, Eq. 7; barbule.h): the cell's normals tilt out of the x–z
//    plane by θ_m, uniform on [−θ_d, θ_d] (the circular longitudinal arc has arc length ∝ dθ_m;
//    the (1 ± r_θ(1 − cos θ)/ρ) correction is dropped, as Huang's Eq. 7 does). A surface element
//    with tilt θ_m sends ω_i to directions whose half vector h = (ω_i + ω_o)/|ω_i + ω_o| has
//    longitudinal angle θ_h = asin h_y = θ_m (the mirror condition along y). As Huang factorises
//    D(h) = D_φ D_θ, the 2D far field fixes the transverse distribution and the tilt the
//    longitudinal one:  dP = I cos ε_i σ_t(θ_o) dθ_o · D_θ(θ_h) dθ_h,  D_θ = 1/(2θ_d).
//    Neglected: the tilt's O(θ_d²) change of the transverse angles and of σ_t (θ_d = 0.0785:
//    0.6 %), and the finite cell length's own diffraction (λ/L ≪ θ_d for L = 20 µm).
// 3. BSDF per unit projected patch area: the row of `count` cells spans W = count · spacing
//    along x, intercepting I |ω_i,z| W per unit length; with dω_o = cos ε_o dε_o dθ_o,
//        f(ω_i, ω_o) = cos ε_i σ_t(θ_o) D_θ(θ_h) |∂θ_h/∂ε_o| / (|ω_i,z| W |ω_o,z| cos ε_o),
//    so that ∫ f |ω_o,z| dω_o = cos ε_i ∫σ_t dθ_o / (|ω_i,z| W): the 2D reflected power per
//    intercepted patch width (the energy test). ∂θ_h/∂ε_o is analytic (eval()).
// Polarisation: unpolarised, σ_t = (σ_TE + σ_TM)/2 with r_s and r_p at the 3D local angle.
// At ε ≠ 0 the two couple (the local s/p basis turns along the cross-section); the scalar
// average ignores that coupling (cross-polarised power), exact at ε = 0 only.
// Lobe: "R" only, PO's reflected part (the shadow-forming wave is the missing unhindered
// light, not scattered light); what PO leaves out is listed in physical_optics_2d.h.
//
// Against the 3D ray tracer (tests/sim/wave/physical_optics_tracer_test.cpp): one cell per
// patch width H A (H = 6, no neighbour shadowing within 60°) against the tracer on the explicit
// barbule row (saddle cells of length 0.2 A, beam averaged over one period), both with keratin
// 0.59 µm directly on melanin, coherent, single bounce (tracer max_events = 1; the default row
// scene's Lambertian melanin sheet and PO's coherent air gap have no counterpart on the other
// side, so neither is used), measured by the goniometer (5° cones, in-plane lights 0°, ±30°, ±60°
// × views −60°…60°). Relative L1 at 550 nm: 0.147, 0.082, 0.044, 0.027 for A = 2, 5, 10, 20 µm
// (tracer noise floor 0.018; 450 nm: 0.153, 0.086, 0.045, 0.031), PO's summed BRDF 7.4 % high at
// A = 2 and 0.9 % at 20; L1 ∝ A^−0.75 raw, A^−0.87 (450 nm: −0.80) with the floor removed in
// quadrature. The same cells in 2D (PO against geometric_optics_2d) give 0.168, 0.076, 0.033,
// 0.016, A^−1.0: the 3D difference tracks the 2D diffraction (within 30 % of it or two noise
// floors at every A), i.e. O(λ/A); the shallower 3D rate is the A >= 10 residual sitting within
// one or two floors of the tracer's noise.
//
// Sampling. f's two factors are sampled apart: θ_o from σ_t(θ_o) tabulated at 1440 bin centres
// (0.25°) for this (ω_i, λ), piecewise constant, mixed with 10 % uniform in θ_o (so every θ_o has
// density); θ_h uniform on [−θ_d, θ_d] (D_θ); then ε_o solves h_y(ε_o) = sin θ_h at that θ_o:
// every root, bracketed on 64 steps of ε_o and bisected (h_y is not monotone where ω_o turns
// towards −ω_i), one of the n roots picked at random; a (θ_o, θ_h) with no root returns no
// event, which the estimator allows (every ω_o with f > 0 is reachable). The density over
// solid angle is p(θ_o) (1/(2θ_d)) |∂θ_h/∂ε_o| / (n cos ε_o) (pdf()), so the weight
// f |ω_o,z| / pdf = n cos ε_i σ_t(θ_o) / (|ω_i,z| W p(θ_o)) is bounded: σ_t over its own bin's
// tabulated value, times n.
// Tested: χ² of the sampled directions against pdf(), weights against eval() (the recipe of
// tests/analysis/chi_square.h) at three incidences and wavelengths. The table costs 1440
// σ_t evaluations per (ω_i, λ), built once on first use (std::call_once, shared by threads).
//
// Cost: eval() prepares the lit samples and stack amplitudes once per (ω_i, λ) and keeps σ_t of
// the last θ_o (to 1e-12 rad: atan2 of (cos ε sin θ, cos ε cos θ) varies in the last bit with ε),
// per thread (callers that sweep ω_o at fixed ω_i are fast; interleaved ω_i recompute,
// correctly; no lock, so threads measuring different cells do not wait for each other).
//
// Parameter table:
//  | name     | unit | range                                               |
//  |----------|------|-----------------------------------------------------|
//  | row      |      | as Row2d (physical_optics_2d.h); spacing_um > 0     |
//  | theta_d  | rad  | (0, π/4]                                            |
//  | step_um  | µm   | 0 (λ/10) or in (0, λ/10]                            |
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "sim/scatterer/scatterer.h"
#include "sim/wave/surface/physical_optics_2d.h"

namespace plumage::sim::wave {

struct PhysicalOptics25dParams {
    Row2d row;
    double theta_d = 0.0785;
    double step_um = 0.0;
};

class PhysicalOptics25d final : public Scatterer {
public:
    explicit PhysicalOptics25d(PhysicalOptics25dParams params);  // InputError naming the value
    std::string name() const override { return "physical_optics_25d"; }
    const std::vector<std::string>& lobe_names() const override;
    // Importance sampling of f's lobes (header, "Sampling"); weight f |ω_o,z| / pdf.
    std::optional<ScatterEvent> sample(const Vec3d& wi, double lambda_nm, const Vec2& position_um,
                                       Rng& rng) const override;
    bool can_evaluate() const override { return true; }
    double eval(const Vec3d& wi, const Vec3d& wo, double lambda_nm,
                std::span<double> per_lobe = {}) const override;
    double pdf(const Vec3d& wi, const Vec3d& wo, double lambda_nm) const override;

    // The 2D side of the energy identity: cos ε_i ∫σ_t dθ_o / (|ω_i,z| W) (see the header).
    double reflected_fraction_2d(const Vec3d& wi, double lambda_nm, int angles) const;
    double patch_width_um() const;

private:
    struct Prepared;
    std::shared_ptr<const Prepared> prepare(const Vec3d& wi, double lambda_nm) const;
    const Prepared& sampler_table(const std::shared_ptr<const Prepared>& prepared) const;
    // pdf() with the number of elevations sharing ω_o's (θ_o, θ_h) already known.
    double density(const Vec3d& wi, const Vec3d& wo, double lambda_nm, std::size_t roots) const;
    double sigma_t(const Prepared& prepared, double theta_o) const;
    struct ThreadCache;
    ThreadCache& cache() const;  // this thread's, for this object

    PhysicalOptics25dParams params_;
    std::uint64_t generation_;  // distinguishes objects that reuse an address, for the cache
};

}  // namespace plumage::sim::wave
