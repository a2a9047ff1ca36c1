// Weizhen Huang, Sebastian Merzbach, Clara Callenberg, Doekele Stavenga and Matthias Hullin,
// "Rendering Iridescent Rock Dove Neck Feathers", SIGGRAPH '22 Conference Proceedings, ACM, 2022,
// Article 43: the elliptical barbule BSDF with thin-film interference, R + TRT + T lobes
// (Eqs. 1–3, 5–7, 13–17, Algorithm 1), as a Scatterer.
//
// Frames: the model lives in Huang's barbule frame (y along the barbule, direction
// ω = (sin φ cos θ, sin θ, cos φ cos θ)); the Scatterer interface uses the patch frame
// (+z barb-plane normal, +x barb axis). patch = R_y(μ) · barbule, as in
// geometry/barbule.h, so ⟨ω, n⟩ = ω_patch.z = cos θ cos(φ + μ) (Eq. 13).
//
// Lobes:
//  R    thin-film reflection, Eq. 14: f_R = I_R D(ω_m) G / (4 ⟨ω_i,n⟩⟨ω_o,n⟩), ω_m the
//       half vector, D of Eq. 7, G exact binary visibility of the arc point with
//       normal ω_m from ω_i and ω_o (2D, against every neighbouring barbule that can
//       reach, not only the two adjacent ones of the paper: at grazing angles the
//       second neighbours matter for H = 1.25).
//  TRT  background through the film, off the melanin, back out, Eqs. 3, 16–17:
//       f_TRT = P_hit ⟨T(ω_i·ω_m) R_m T(ω_o·ω_m) 1[ω_o·ω_m > 0]⟩ / π, the average taken
//       over the illuminated visible area (the paper's ρ, Eq. 17, computed by
//       quadrature instead of one random h, l per evaluation), multiplied by the
//       fraction P_hit = Δh'/Δh of the light that hits a barbule at all (the paper's
//       A_i normalisation leaves this implicit; without it the lobe would reflect
//       light that passed between the barbules). Not reciprocal (as published): the
//       average is weighted by visibility from ω_i only.
//       Outgoing blocking is ignored: the light leaving a facet towards ω_o is not masked
//       by the neighbouring barbules (only 1[ω_o·ω_m > 0] is applied), and the lobe is zero
//       below the barb plane (ω_o,z ≤ 0). The explicit patch masks both: there a blocked
//       exit meets a second barbule and is counted in its "multi" lobe, not in TRT. What
//       that costs, measured on the default rock-dove study's BRDF (Filip 2024 set, 5°
//       detector cones): TRT relative L1 simulation against model 0.131, the same before
//       and after the quadrature fix of issue 15 (those cones do not reach the grazing
//       views along the barbule axis where the old quadrature failed); the model's TRT
//       is 6 % above the simulated one in total (9 % above for views within 60° of the
//       normal, 8 % below beyond 60°), and the simulation's statistical error alone,
//       Σσ/Σf, is 0.08. The tracer files a blocked TRT exit under "multi" with every other
//       multiple path (sim/tracer.h). What separates them (analysis/models/huang2022_trt_exit.h):
//       the simulated melanin is a Lambertian sheet, whose facets a view sees foreshortened by
//       ⟨ω_o, ω_m⟩/cos θ_o and masked by the neighbours; with that exit law in place of this
//       lobe's the default study's TRT deficit goes from −6.4 % (−8.6 % for views within 60°,
//       +7.9 % beyond) to −2.2 % at every view angle, and the masking alone holds back 6.5 % of
//       the light (the rock-dove report's "Where and why the model departs").
//       Quadrature (eval): E_q ∈ [0, 1] to a relative error ≤ 1e-3 wherever E_q ≥ 1e-2 and
//       an absolute one ≤ 1e-4 below (as a fraction of the scale P_hit R_m / π), measured
//       against a dense reference including grazing views along the barbule axis, where
//       the former two-node θ_m rule was off by up to 30 %: composite Gauss–Legendre with
//       the θ_m support cut where ω_o·ω_m = 0 (T_o's kink), and the film's T(cos θ)
//       tabulated per wavelength over the whole of [0, 1], grazing facets included, to a
//       relative 5e-7 (the TRT lobe within 1e-6 relative of the same rule with direct Airy
//       evaluation, eval_reference; details at Huang2022Bsdf::eval_in_frame). Where every facet
//       of two adjacent φ_m pieces faces both ω_i and ω_o by cos ≥ 0.05 (no kink there), one
//       rule covers the pair (within 6e-8 relative of the per-piece rule, measured).
//       Near a wavelength whose film resonance sits at grazing incidence (≈ 471 and 694 nm
//       at d = 0.59 µm) T(c) steps from 0 to ≈ 1 over a small c; there the φ_m piece at ω_o's
//       terminator is graded per call (without it TRT was off by up to 1.2e-2). The model's
//       values on the Filip 2024 set at 400–700 nm are within 2e-5 of a converged rule, and
//       within 3e-4 at ±2 nm of those resonances (test
//       Huang2022.PointTableOnTheFilipSetIsConvergedTo1e4).
//       pdf() keeps a fixed rule (2 θ_m nodes): its integrand does not depend on ω_o.
//  T    light passing between barbules unchanged, Eq. 15: a Dirac lobe at ω_o = −ω_i
//       with mass 1 − Δh'/Δh. eval() cannot return a Dirac; sample() produces it.
//
// Choices the paper leaves open:
//  - Polarisation: unpolarised light; I_R and the film transmittance T are the means of
//    the s and p intensities (Airy film of sim/optics, air | keratin d | air).
//  - The melanin reflectance R_m: the unpolarised Fresnel reflectance of air → melanin
//    at normal incidence (the granules' orientation is random; ≈ 0.07 with sim/optics/material.h's
//    melanin dispersion, the paper quotes about 5 %).
//  - Longitudinal hits: within a cell, the hit density in θ_m is the projected-area
//    weight ⟨ω_i, ω_m⟩ (clipped at 0) under D_θ uniform in θ_m.
//
// Parameter table (defaults: the published rock-dove fit):
//  | name     | unit | default | valid range                         |
//  |----------|------|---------|-------------------------------------|
//  | b        | 1    | 0.25    | [1e-3, 1] semi-minor / semi-major   |
//  | phi0     | rad  | −0.37   | phi0 < phi1 <= phi0 + 2π            |
//  | phi1     | rad  | 2.64    |                                     |
//  | H        | 1    | 1.25    | > 0, spacing / semi-major axis      |
//  | d        | µm   | 0.59    | [0, 50] keratin film thickness      |
//  | theta_d  | rad  | 0.0785  | (0, π/4] longitudinal half-opening  |
//  | mu       | rad  | −0.35   | (−π/2, π/2) barb-plane tilt         |
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <numbers>
#include <vector>

#include "common/parameter_spec.h"
#include "geometry/barbule.h"
#include "sim/optics/material.h"
#include "sim/scatterer/scatterer.h"

namespace plumage::analysis {

// The parameters' table (common/parameter_spec.h), in the order of Huang2022Params and of the
// fit's vector (analysis/fits/huang2022_fit.h, Huang2022ParameterIndex): the model's validation,
// the fit's bounds, the ablation study's sweeps and the Python names take their ranges from here.
// φ1 is further bound to φ0 < φ1 ≤ φ0 + 2π (an arc).
// clang-format off
inline constexpr std::array<ParameterSpec, 7> kHuang2022ParameterTable = {{
    {.name = "b", .unit = "1", .default_value = 0.25, .min = 1e-3, .max = 1.0,
     .meaning = "the cross-section's semi-minor over semi-major axis"},
    {.name = "phi0", .unit = "rad", .default_value = -0.37, .meaning = "arc start, normal azimuth"},
    {.name = "phi1", .unit = "rad", .default_value = 2.64, .meaning = "arc end, normal azimuth"},
    {.name = "H", .unit = "1", .default_value = 1.25, .min = 0.0, .min_open = true,
     .meaning = "a barbule spacing in semi-major axes"},
    {.name = "d_um", .unit = "µm", .default_value = 0.59, .min = 0.0, .max = 50.0,
     .meaning = "a keratin film thickness"},
    {.name = "theta_d", .unit = "rad", .default_value = 0.0785, .min = 0.0,
     .max = 0.25 * std::numbers::pi, .min_open = true, .meaning = "a longitudinal half-opening"},
    {.name = "mu", .unit = "rad", .default_value = -0.35, .min = -0.5 * std::numbers::pi,
     .max = 0.5 * std::numbers::pi, .min_open = true, .max_open = true,
     .meaning = "a barb-plane tilt"},
}};
// clang-format on

struct Huang2022Params {
    double b = kHuang2022ParameterTable[0].default_value;
    double phi0 = kHuang2022ParameterTable[1].default_value;
    double phi1 = kHuang2022ParameterTable[2].default_value;
    double H = kHuang2022ParameterTable[3].default_value;
    double d_um = kHuang2022ParameterTable[4].default_value;
    double theta_d = kHuang2022ParameterTable[5].default_value;
    double mu = kHuang2022ParameterTable[6].default_value;
};

class Huang2022Bsdf final : public Scatterer {
public:
    enum Lobe : int { kR = 0, kTRT = 1, kT = 2 };

    explicit Huang2022Bsdf(const Huang2022Params& params);  // InputError names the parameter

    std::string name() const override { return "huang2022"; }
    const std::vector<std::string>& lobe_names() const override;
    std::optional<ScatterEvent> sample(const Vec3d& wi, double lambda_nm, const Vec2& position_um,
                                       Rng& rng) const override;
    bool can_evaluate() const override { return true; }
    double eval(const Vec3d& wi, const Vec3d& wo, double lambda_nm,
                std::span<double> per_lobe = {}) const override;
    // R alone costs a few hundred instructions, TRT its quadrature (thousands): a cubature that
    // refines R's edges past TRT's convergence asks for R alone.
    bool evaluates_lobes_apart() const override { return true; }
    double eval_lobes(const Vec3d& wi, const Vec3d& wo, double lambda_nm, std::uint32_t wanted,
                      std::span<double> per_lobe) const override;
    // Density of sample()'s non-Dirac directions (R and TRT), including samples that
    // come back with weight 0 (blocked); the T lobe's mass is t_lobe_mass().
    double pdf(const Vec3d& wi, const Vec3d& wo, double lambda_nm) const override;

    // eval() by a slow reference path, for tests and benchmarks: no frame cache, every film
    // factor by direct Airy evaluation instead of eval()'s tables, and TRT's φ_m pieces and θ_m
    // panels trt_refine times finer (1: eval()'s rule; in [1, 64]).
    double eval_reference(const Vec3d& wi, const Vec3d& wo, double lambda_nm, int trt_refine,
                          std::span<double> per_lobe = {}) const;

    // The keratin film's unpolarised transmittance T(cos θ) as eval()'s TRT quadrature takes it,
    // from a per-wavelength table: relative error ≤ 5e-7 against direct Airy evaluation at
    // every cos θ ∈ [0, 1], grazing included (its definition in huang2022.cpp).
    double tabulated_film_transmittance(double cos_theta, double lambda_nm) const;

    // Fraction of light from wi that passes between the barbules: 1 − Δh'/Δh (Eq. 15).
    double t_lobe_mass(const Vec3d& wi) const;
    // Fraction that reaches the concave underside of an arc (possible only when the
    // barbules leave gaps, H > the arc's width, at oblique light): Eq. 15 counts it as
    // hit, Eq. 14's front-facing NDF cannot reflect it, so the model absorbs it.
    double back_hit_fraction(const Vec3d& wi) const;
    // Δh' / Δh from the closed form: min(W(φ), Δh(φ)) / Δh(φ).
    double hit_fraction_closed_form(const Vec3d& wi) const;
    // The same fraction by quadrature of the visible NDF: ∫ D ⟨ω_i, ω_m⟩ G_1 dω_m / ⟨ω_i, n⟩.
    double hit_fraction_by_quadrature(const Vec3d& wi) const;
    // The front-facing φ_m ranges of the arc that the light from wi reaches (rad, within
    // [phi0, phi1], barbule frame): the φ support of the hit-normal density q.
    std::vector<std::array<double, 2>> visible_arc(const Vec3d& wi) const;
    // ∫ D(ω_m) ⟨ω_m, n⟩ dω_m over the whole arc (no visibility): exceeds 1 when the arc's
    // projected width exceeds H (the rock-dove case).
    double ndf_projected_integral() const;
    // Eq. 7 in the barbule frame; 0 outside the arc's (φ, θ) range.
    double ndf(double phi_m, double theta_m) const;
    const Huang2022Params& params() const { return params_; }

private:
    struct Frame;     // ω_i-dependent quantities (barbule frame, visible intervals)
    struct Spectral;  // λ-dependent ones (film table, melanin reflectance), per thread
    const Spectral& spectral(double lambda_nm) const;
    // The frame of ω_i, computed into f (its vectors' capacity kept): compute_frame's parts.
    void compute_frame(const Vec3d& wi_patch, int trt_refine, Frame& f) const;
    void scan_visible_intervals(Frame& f) const;          // the visible front-facing φ_m ranges
    void measure_shadow(Frame& f) const;                  // Δh' and the T lobe's mass
    const Frame& frame_for(const Vec3d& wi_patch) const;  // per-thread cache of the last ω_i
    void build_nodes(const Frame& f) const;      // pdf()'s rule, on its first call per ω_i
    void build_trt_pieces(Frame& f) const;       // TRT's pieces and pairs, per ω_i (eval_in_frame)
    void build_trt_nodes(const Frame& f) const;  // their nodes, stored once a second eval asks
    // eval() in a frame, with the melanin reflectance r_m and the film's T(c) given (tables in
    // eval(), direct evaluation in eval_reference()); its TRT term E_q[T(ω_i·ω_m) T(ω_o·ω_m)
    // 1(ω_o·ω_m > 0)] and that term's error are described at its definition.
    // `wanted`: the lobes computed (eval_lobes(); the others are 0).
    template <typename Transmittance>
    double eval_in_frame(const Frame& f, const Vec3d& wo, double lambda_nm, double r_m, bool steep,
                         const Transmittance& transmittance, std::span<double> per_lobe,
                         std::uint32_t wanted = ~0u) const;
    double film_reflectance(double cos_theta, double lambda_nm) const;
    double film_transmittance(double cos_theta, double lambda_nm) const;
    double melanin_reflectance(double lambda_nm) const;
    bool visible(double phi_m, double dir_x, double dir_z) const;
    // visible() for a direction (dx, dz) already of unit length (the frame's scan normalises once).
    bool visible_along(double phi_m, double dx, double dz) const;
    // Per-wavelength film factors at the frame's quadrature nodes of q(ω_m).
    void prepare_nodes(const Frame& f, double lambda_nm) const;

    Huang2022Params params_;
    double cos_mu_, sin_mu_;  // of the barb-plane tilt: visible() asks for them ~10⁴ times per ω_i
    // Held, not fetched per call: optics::keratin() returns a shared_ptr by value, and the
    // atomic reference count that every copy increments is one cache line that all threads
    // write; at ~150 film evaluations per eval() it stopped the model tables scaling.
    std::shared_ptr<const optics::Material> keratin_, melanin_;
    std::uint64_t generation_;  // distinguishes objects that reuse an address, for the cache
};

// The Huang model of the same barbules: b, φ0, φ1, θ_d, H, μ and the film thickness.
Huang2022Params huang_params_of(const geometry::BarbuleRowParams& row);

}  // namespace plumage::analysis
