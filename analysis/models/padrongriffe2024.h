// Juan Raúl Padrón-Griffe, Dario Lanza, Adrián Jarabo and Adolfo Muñoz, "A Surface-based
// Appearance Model for Pennaceous Feathers", SIGGRAPH Posters '24, ACM, 2024,
// doi:10.1145/3641234.3671065: the surface feather BSDF that mixes barb and barbule fibre
// scattering, weighted by the analytic barb/barbule masking term
// (analysis/models/padrongriffe2024_masking.h), as a Scatterer.
//
// The poster gives the ingredients, not the equations: "barbs and barbules represented as
// elliptical dielectric fibers [after Yan et al. 2015] and a non-concentric diffuse medulla for
// the barbs; the scattered radiance for each component is weighted based on their respective
// projected visible area"; it ignores wave optics, multiple scattering between barbs and
// barbules, and the shadowing term. What follows is our reading, at the level we can test.
//
// Frames. Patch frame of sim/scatterer/scatterer.h (+z normal, +x barb axis, directions away from
// the patch). Three fibres, each with a frame (axis, up, side) of analysis/models/fibre_baseline.h:
//   barb               axis +x,                         up +z,          side +y
//   distal barbule     axis (cos i cos r,  cos i sin r, sin i), up = the row's normal, side =
//   across proximal barbule   axis (cos i cos r, −cos i sin r, sin i), likewise
// (i = barbule_inclination, r = barbule_rotation, the barbules' direction in the vane; the rows'
// frames of the masking term, the authors' FeatherBase; for r = 90° the distal barbule is
// axis (0, cos i, sin i), up (0, −sin i, cos i), side −x, as geometry/barb.h's instanced meshes).
// Cross-sections (geometry/barb.h, the authors' meanings): the barb's ellipse has semi-axis
// w/2 × barb_axis_ratio along up (turned by barb_rotation) and w/2 along side; a barbule's has
// w_b/2 × barbule_axis_ratio along up and w_b/2 along side.
//
// The model. A quantum arriving from ωi first meets the barb, a distal or a proximal barbule, or
// nothing, with the masking fractions G_c(ωi) of the extruded cross-section (exact for that
// geometry; they sum to 1). Meeting nothing it passes straight through: the "T" lobe, a Dirac at
// ωo = −ωi of mass G_gap(ωi) (eval() cannot return it; sample() does). Meeting fibre c at an offset
// uniform across its projected width, it scatters as that fibre would alone:
//   f(ωi, ωo) = Σ_c G_c(ωi) [Σ_p M_cp(θo | θi) N_cp(ψo | ωi) / cos θo
//                            + [c = barb] Ā_med / 4π] / |ωo·z|
// with θ, ψ in fibre c's frame, p ∈ {R, TT, TRT}, and M the normalised longitudinal Gaussian of
// analysis/models/fibre_baseline.h (Marschner's shifts and widths per component). The azimuthal
// tables N_cp come from tracing the fibre's elliptical cross-section in 2D with Bravais' index η' =
// √(η² − sin² θi)/cos θi (exact projected refraction for a straight fibre of any cross- section),
// unpolarised Fresnel at the true 3D angle (sim/optics), absorption σ_a over the 3D path length, up
// to two internal reflections; a quantum whose internal path meets the medulla (an ellipse scaled
// and offset inside the barb's cortex, as geometry/barb.h builds it) is taken there: a fraction
// medulla_albedo of it is re-emitted isotropically ("diffuse"; the cortex's attenuation on the way
// out is folded into the albedo), the rest absorbed. Offsets are a deterministic quadrature, exit
// azimuths deposited into one-degree bins and convolved with the azimuthal roughness, exactly as
// for the circular baseline (with eccentricity 0 and no medulla the trace reproduces the baseline's
// closed form: tested).
//
// Choices the paper leaves open:
//  - Which direction's visibility weights the components. The poster weights by the view and
//    drops shadowing. sample() plays light forward from ωi, so we weight by the fractions of the
//    INCIDENT beam that first meet each component: the same masking function, at the light's
//    direction. They partition the incident power exactly, so energy is conserved (directional
//    albedo = Σ_c G_c(ωi) Ā_c(ωi) <= 1 − G_gap(ωi)) and sample() picks the component with
//    probability G_c(ωi). Light leaving a fibre is not masked on its way out (no multiple
//    scattering, as in the paper). Consequence: the model is NOT reciprocal — f(ωi, ωo) carries
//    G(ωi), f(ωo, ωi) carries G(ωo); tests/analysis/padrongriffe2024_test.cpp shows it, lobe by
//    lobe. Weighting by G(ωo) instead (the poster's view weighting without shadowing) would be
//    equally non-reciprocal and would not bound the albedo by 1.
//  - Masking in 3D: the masking term with see-through barbule rows (analysis/
//    padrongriffe2024_masking.h): light that passes between the barbules of a row goes on and
//    meets what lies behind, or leaves through the vane as the T lobe.
//  - Medulla re-emission is isotropic over the sphere (a diffuse source inside the fibre seen
//    from far away); Yan 2015's layered medulla tables are not reproduced.
//  - Refractive index: keratin n(λ) = 1.532 + 5890/λ² (sim/optics keratin()); absorption
//    wavelength-independent.
//  - Sampling is analog: sample() returns weight 1 (or nothing: absorbed), so pdf() = f |cos θo|,
//    a sub-density whose mass is the directional albedo (the T lobe's mass is outside it).
//
// Readings of the authors' Mitsuba plugin (juanraul8/PennaceousFeathersRendering,
// feather_plugin/src/bsdfs/feather.cpp class Feather, and its fibre BCSDF Pigmentation:
// pigmentation.cpp, fiber_tracer.cpp), and where we differ:
//  - Parameters: barbule_azimuthal_angle is the rotation r, barbule_longitudinal_angle the
//    inclination i, barbule_separation and barbule_length as in the masking term; the masking's
//    barb and barbule excentricities are the b_outer of the barb's and the barbules' fibre
//    BCSDFs (getMasking): the axis ratio of the same ellipse the fibre is traced with. Ours too:
//    one barb_axis_ratio and one barbule_axis_ratio set both the masking and the traced sections.
//  - Which direction is masked: getMasking takes bRec.its.wi, the direction towards the camera
//    (Mitsuba traces from the camera), as the propagation direction of the masking code with its
//    normal component negated; there is no shadowing term for the light (a wo variant in
//    measureBRDF is commented out). We weight by the light's direction ωi (above: energy
//    conservation and sample()); for a view-weighted model swap ωi and ωo.
//  - Frames (setLocalFrames, getBarbulesFrame): the plugin turns the barb frame by +β (the barb
//    direction from its texture) but the barbule frames by −β, tilts barbules about the fixed
//    shading x axis after their azimuth (for r = 90° that rolls the frame instead of lifting the
//    barbule), and its fibre BCSDF (vector2polar: θ = asin v_x) takes local x as the fibre axis,
//    90° from the axis y the masking assumes, for barbs and barbules alike. We use one frame per
//    fibre, whose axis is the axis the masking term and the explicit geometry use; the plugin's
//    frames agree with ours only for β = 0, i = 0.
//  - Fibre lobes (FiberTracer::rayTrace, PigmentationSolver::computeBCSDF): an elliptical cortex
//    (η 1.55), Beer–Lambert absorption over the 3D path, Fresnel splitting into R, TT, TRT (then
//    Russian roulette), each exit direction spread by normalised Gaussians in θ (β_m) and φ (β_n),
//    divided by cos θo; offsets h drawn at random in every eval, so eval is stochastic. Ours: the
//    same trace with a deterministic offset quadrature, up to two internal reflections, and
//    Marschner's shifted and widened longitudinal lobes per component (α, β per fibre type).
//  - Medulla: the plugin scatters a path that hits a diffuse medulla into a cosine-weighted
//    direction about the medulla's normal and keeps tracing it; ours re-emits isotropically
//    (above). An absorbing medulla (absorption_inner) is not modelled.
//  - Combination (featherEval): Σ rate_c f_c over barb ranges and the two barbules, the
//    transmittance rate unused in eval, the per-range h limits not applied in eval (sampling
//    applies the barbule's hmin); ours applies neither (hits spread uniformly across a fibre).
//
// clang-format off
// Parameter table. `geometry` is a geometry::BarbulePatchParams (table in geometry/barb.h, ranges
// checked by the masking term): the geometry defaults plus a non-concentric medulla
// (medulla_scale 0.6, medulla_offset_z_um 2).
//  | name                        | unit | default | valid range                                 |
//  |-----------------------------|------|---------|---------------------------------------------|
//  | geometry                    | —    | below   | geometry/barb.h's table; medulla inside the cortex |
//  | barb_absorption_per_um      | 1/µm | 0.02    | [0, 10]                                     |
//  | barbule_absorption_per_um   | 1/µm | 0.1     | [0, 10] (pigmented barbules absorb more)    |
//  | medulla_albedo              | 1    | 0.8     | [0, 1]                                      |
//  | barb_alpha_r_rad            | rad  | −0.05   | [−0.35, 0.35] (R shift; TT, TRT: Marschner) |
//  | barb_beta_r_rad             | rad  | 0.1     | [0.01, 0.5]                                 |
//  | barbule_alpha_r_rad         | rad  | −0.05   | [−0.35, 0.35]                               |
//  | barbule_beta_r_rad          | rad  | 0.15    | [0.01, 0.5]                                 |
//  | azimuthal_roughness_rad     | rad  | 0.15    | [0.03, 1.5]                                 |
//  | fibre_offsets               | 1    | 512     | [16, 65536] (quadrature nodes across a fibre) |
// clang-format on
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "analysis/models/fibre_baseline.h"
#include "analysis/models/padrongriffe2024_masking.h"
#include "geometry/barb.h"
#include "sim/scatterer/scatterer.h"

namespace plumage::analysis {

// An elliptical fibre cross-section in its frame's (side, up) plane: semi-axis `up_semi_axis_um`
// along the direction at `rotation_rad` from up towards side, `side_semi_axis_um` across;
// optionally a medulla: the same ellipse scaled by medulla_scale, centred at (medulla_side_um,
// medulla_up_um).
struct EllipticalCrossSection {
    double up_semi_axis_um = 1.0;
    double side_semi_axis_um = 1.0;
    double rotation_rad = 0.0;
    double medulla_scale = 0.0;  // 0: none
    double medulla_side_um = 0.0;
    double medulla_up_um = 0.0;
};

// The trace described above for light arriving from (sin θi, ψi) in the fibre frame: tables over
// the absolute exit azimuth ψo, and the re-emitted medulla fraction (albedo applied).
void elliptical_fibre_azimuthal(const EllipticalCrossSection& section, double eta,
                                double absorption_per_um, double medulla_albedo, double sin_theta_i,
                                double psi_i, double azimuthal_roughness_rad, int offsets,
                                FibreAzimuthalScattering& out);

struct PadronGriffe2024Params {
    geometry::BarbulePatchParams geometry = default_geometry();
    double barb_absorption_per_um = 0.02;
    double barbule_absorption_per_um = 0.1;
    double medulla_albedo = 0.8;
    double barb_alpha_r_rad = -0.05;
    double barb_beta_r_rad = 0.1;
    double barbule_alpha_r_rad = -0.05;
    double barbule_beta_r_rad = 0.15;
    double azimuthal_roughness_rad = 0.15;
    int fibre_offsets = 512;

    static geometry::BarbulePatchParams default_geometry() {
        geometry::BarbulePatchParams g;
        g.barb.medulla_scale = 0.6;
        g.barb.medulla_offset_z_um = 2.0;
        return g;
    }
};

class PadronGriffe2024Bsdf final : public Scatterer {
public:
    enum Lobe : int {
        kBarbR = 0,
        kBarbTT,
        kBarbTRT,
        kBarbMedulla,
        kBarbuleR,
        kBarbuleTT,
        kBarbuleTRT,
        kT,
        kLobeCount
    };
    // The fibres, in the order of their masking components.
    enum Fibre : int { kBarb = 0, kDistalBarbule = 1, kProximalBarbule = 2 };

    explicit PadronGriffe2024Bsdf(
        const PadronGriffe2024Params& params);  // InputError names the parameter

    std::string name() const override { return "padrongriffe2024"; }
    const std::vector<std::string>& lobe_names() const override;
    std::optional<ScatterEvent> sample(const Vec3d& wi, double lambda_nm, const Vec2& position_um,
                                       Rng& rng) const override;
    bool can_evaluate() const override { return true; }
    double eval(const Vec3d& wi, const Vec3d& wo, double lambda_nm,
                std::span<double> per_lobe = {}) const override;
    double pdf(const Vec3d& wi, const Vec3d& wo, double lambda_nm) const override;

    // G_c(ωi): the masking fractions that weight the components.
    MaskingFractions fractions(const Vec3d& wi) const;
    // Albedo of each fibre on its own for light from wi: R, TT, TRT, medulla (re-emitted).
    std::array<double, 4> fibre_albedos(Fibre fibre, const Vec3d& wi, double lambda_nm) const;
    // Σ_c G_c Ā_c: the directional albedo of eval() (without the T lobe).
    double albedo(const Vec3d& wi, double lambda_nm) const;

    const PadronGriffe2024Masking& masking() const { return masking_; }
    const FibreFrame& frame(Fibre fibre) const { return frames_[fibre]; }
    const EllipticalCrossSection& cross_section(Fibre fibre) const { return sections_[fibre]; }
    const PadronGriffe2024Params& params() const { return params_; }

private:
    struct State;
    const State& state_for(const Vec3d& wi, double lambda_nm) const;
    double density(const State& s, const Vec3d& wo, std::span<double> per_lobe) const;

    PadronGriffe2024Params params_;
    PadronGriffe2024Masking masking_;
    std::array<FibreFrame, 3> frames_;
    std::array<EllipticalCrossSection, 3> sections_;
    std::uint64_t generation_;
};

}  // namespace plumage::analysis
