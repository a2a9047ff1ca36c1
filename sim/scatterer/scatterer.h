// The one contract every scatterer meets: the ray tracer over explicit geometry and
// every analytic feather model. Instruments (virtual_gonio/) measure a Scatterer and do
// not care which kind it is, so simulated and analytic records compare cell by cell.
//
// Conventions (read before implementing):
//  - Patch frame: +z is the patch (barb-plane) normal, +x the barb axis, +y the
//    barbules' direction; azimuth φ is measured from +x towards +y.
//  - Directions are unit vectors pointing AWAY from the patch: ω_i towards the light,
//    ω_o towards the detector (pbrt's convention). Reflection: ω_o.z > 0; light passing
//    through the patch: ω_o.z < 0. The unhindered "T" lobe of Huang is ω_o = −ω_i.
//  - Wavelengths in nm (vacuum); positions on the patch in µm, in the z = 0 plane.
//  - f(ω_i, ω_o, λ) is the BSDF in 1/sr per unit projected patch area (radiance out per
//    irradiance on the patch plane); the cosine ⟨ω_o, z⟩ is NOT included.
//  - sample() plays one quantum of light: it returns where the quantum leaves and a
//    weight such that E[weight · 1{ω_o ∈ Ω}] = ∫_Ω f(ω_i, ω_o) |cos θ_o| dω_o, i.e. the
//    fraction of the power incident on the patch that leaves into Ω. With a density,
//    weight = f |cos θ_o| / pdf. No return value means the quantum was absorbed.
//  - Lobes: each scatterer names its lobes (lobe_names()); a sample carries the index
//    of the lobe that produced it, so records keep per-lobe values.
//  - Path tracing (optional: path_tracing(), the PathTracing interface below; the tracer and
//    its wrappers have it, analytic models do not):
//    - spectral path sharing: sample_spectral() plays one quantum for several wavelengths at
//      once: one escape direction and one weight per wavelength, each meeting sample()'s
//      contract for its own λ (the weights of one quantum are correlated across λ, those of
//      different quanta independent).
//    - path splitting (can_split_paths()): sample_spectral_branches() plays the quantum of
//      sample_spectral() as up to kMaxBranches branches, each an escape with its own weights;
//      the contract holds for their sum (a branch's weights already include the probability of
//      the branch, so no weight is divided by a choice probability there). An instrument adds
//      a quantum's branches before it squares (they are one quantum's parts). The same call
//      takes the instrument's detector cones (BranchOptions): a scatterer may draw its
//      directions towards them (importance sampling, unbiased for every direction).
//    - detector-side (adjoint) walks (can_trace_adjoint()): with BranchOptions::adjoint
//      the quantum of sample_spectral_branches() starts at a detector instead of at the light: wi
//      is the direction towards the detector, position_um the point it sees, and each escape is a
//      direction (and entry point) the light it sees came from. The weights then meet the contract
//      above for the light paths run backwards: E[Σ_b w_b · 1{ω_b ∈ Ω}] is the fraction of the
//      power entering at position_um from wi that the REVERSED scene would send into Ω. For a
//      reciprocal scene this is the forward contract with light and detector exchanged; the tracer
//      corrects its shading normals, which are not reciprocal (sim/tracer.h, "Detector-side
//      walks"). The cones of BranchOptions are then the light's cones.
#pragma once

#include <cmath>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>  // cross products are part of every direction computation

#include "sim/scatterer/random.h"

namespace plumage {

using Vec2 = Eigen::Vector2d;
using Vec3d = Eigen::Vector3d;

struct ScatterEvent {
    Vec3d wo;               // unit, away from the patch
    double weight;          // see the conventions above; >= 0, finite
    int lobe;               // index into lobe_names()
    Vec2 exit_position_um;  // where the light leaves the patch (entry point for models)
};

// One quantum's escape for all the wavelengths of sample_spectral(); the weights are
// returned separately, one per wavelength.
struct SpectralScatterEvent {
    Vec3d wo;               // unit, away from the patch
    int lobe;               // index into lobe_names()
    Vec2 exit_position_um;  // as ScatterEvent
    // The light side of a connected measurement (BranchOptions::connected_light_side): for a path
    // whose one diffuse event the light reached straight, g · cos θ_l there (g the share that goes
    // on from it, θ_l between the light and the facet normal), the light side's factor in the two
    // strategies' density ratio (PathTracing::trace_connected()); 0 for every other path, which
    // only the light side can make.
    double lit_diffuse_density = 0.0;
};

// What an instrument asks of sample_spectral_branches().
struct BranchOptions {
    // Split the path at its first film event into a reflected and a transmitted branch.
    bool split_first_film = false;
    // With split_first_film: the reflected branch splits again at its next event when that is a
    // film, into a reflected and a transmitted branch (each λ's weight × its R or T there), so
    // that the chains of two film reflections between barbules, which a sampled choice makes
    // with probability R, come from every such quantum.
    bool split_reflections = false;
    // The detectors the instrument reads (unit axes, away from the patch; cones of
    // detector_half_angle_rad). With guided_fraction f in (0, 1), a scatterer may draw a path's
    // first diffuse direction from a mixture: with 1 − f from its own density, with f uniformly
    // within one of the cones, each weighed by its own density over the mixture's (sim/tracer.h,
    // "Guided diffuse reflection"). Unbiased for every direction, covered by a cone or not.
    std::span<const Vec3d> detector_axes;
    double detector_half_angle_rad = 0.0;
    double guided_fraction = 0.0;
    // With k = guided_branches in 1 … kMaxGuidedBranches, a scatterer may instead branch at a
    // path's first diffuse event: one branch in its own direction and k aimed within the cones,
    // all weighed by the multi-sample balance heuristic (sim/tracer.h, "Guided diffuse
    // branches"); it then takes precedence over guided_fraction. 0: no such branches.
    std::size_t guided_branches = 0;
    static constexpr std::size_t kMaxGuidedBranches = 3;
    // Reflections aimed at the detectors (sim/tracer.h, "Reflections aimed at the detectors"):
    // at a bare dielectric interface whose mirror direction lies within a detector cone, a
    // scatterer may take both sides: the reflected one as a branch of its own (each λ × R_k),
    // the transmitted one as the walk (× T_k).
    bool split_aimed_reflections = false;
    // The path starts at a detector (see the conventions above); only for scatterers that
    // can_trace_adjoint().
    bool adjoint = false;
    // The light-side half of a connected measurement (PathTracing::trace_connected()): a path
    // whose first diffuse event the light reached straight from the source (through films in one
    // medium only) goes on from it with probability g (its weights ÷ g) and, if no second diffuse
    // event follows, reports SpectralScatterEvent::lit_diffuse_density, with which the instrument
    // weighs it against the detector-side connections that make the same path (multiple
    // importance sampling). Only for scatterers that can_connect_lights().
    bool connected_light_side = false;
};

// One connection of a detector-side walk to a collimated light (PathTracing::trace_connected()).
struct LightConnection {
    std::size_t light;  // index into the lights asked for
    // Where the light that the connection carries enters: the top plane's point (bottom plane for
    // light from below) on the ray from the diffuse event towards the light, patch frame, µm.
    Vec2 entry_position_um;
    int lobe;  // the whole path's lobe (index into lobe_names())
    // Per wavelength: w · albedo · cos θ_l / π · T_films, where w is the detector-side walk's
    // weight on arriving at the diffuse event, θ_l the angle between the light direction and the
    // facet normal on the walk's side, T_films the films' transmittances along the connection.
    std::span<const double> weights;
    // g · cos θ_l: what the light side reports for the same path
    // (SpectralScatterEvent::lit_diffuse_density), for the instrument's weights.
    double lit_diffuse_density;
};

class LightConnectionSink {
public:
    // Whether a connection to `light` entering at entry_position_um counts at all (e.g. inside the
    // beam): asked before the connection's ray is cast, so that no ray is cast for one that would
    // not count. The entry point is exact: the connection's ray keeps its direction.
    virtual bool accepts(std::size_t light, const Vec2& entry_position_um) const = 0;
    virtual void connect(const LightConnection& connection) = 0;

protected:
    ~LightConnectionSink() = default;
};

// Two unit vectors completing the unit vector a to a right-handed orthonormal frame.
inline void orthonormal_frame(const Vec3d& a, Vec3d& e1, Vec3d& e2) {
    e1 = (std::abs(a.z()) < 0.9 ? Vec3d::UnitZ() : Vec3d::UnitX()).cross(a).normalized();
    e2 = a.cross(e1);
}

// Path tracing, the optional interface of the scatterers that trace light paths (the explicit
// tracer, and the wrappers of one): one path for several wavelengths, its branches, and walks
// that start at a detector (the conventions above). Scatterer::path_tracing() gives it, or
// nullptr: analytic models draw directions from their lobes and trace no path, so an
// instrument's path options do not apply to them.
class PathTracing {
public:
    static constexpr std::size_t kMaxSharedWavelengths = 64;
    // One quantum for every wavelength of lambdas_nm (1 … kMaxSharedWavelengths of them) at
    // once; weights (same size) receives one weight per wavelength with sample()'s contract:
    // E[weights[k] · 1{ω_o ∈ Ω}] = ∫_Ω f(ω_i, ω_o, λ_k) |cos θ_o| dω_o. No return value: no
    // light left at any wavelength (weights then all 0).
    virtual std::optional<SpectralScatterEvent> sample_spectral(
        const Vec3d& wi, std::span<const double> lambdas_nm, const Vec2& position_um, Rng& rng,
        std::span<double> weights) const = 0;

    // Path splitting: whether sample_spectral_branches() can return more than one branch.
    virtual bool can_split_paths() const { return false; }
    // Two film branches, each with up to 1 + kMaxGuidedBranches more: a path's branches wait in a
    // list of that many (sim/tracer.h): the diffuse ones (BranchOptions::guided_branches), the
    // reflected branch's split at its next film (split_reflections) and the aimed reflections
    // (split_aimed_reflections) while there is room.
    static constexpr std::size_t kMaxBranches = 2 * (2 + BranchOptions::kMaxGuidedBranches);
    // The quantum of sample_spectral() as branches b = 0 … count−1 (count returned, at most
    // kMaxBranches): events[b] its escape, weights[b·n + k] its weight at lambdas_nm[k]
    // (n = lambdas_nm.size(); events.size() >= kMaxBranches, weights.size() >= kMaxBranches·n),
    // with E[Σ_b weights[b·n + k] · 1{ω_o,b ∈ Ω}] = ∫_Ω f(ω_i, ω_o, λ_k) |cos θ_o| dω_o.
    // Default: sample_spectral() as the one branch, options ignored.
    virtual std::size_t sample_spectral_branches(const Vec3d& wi,
                                                 std::span<const double> lambdas_nm,
                                                 const Vec2& position_um, Rng& rng,
                                                 const BranchOptions& options,
                                                 std::span<SpectralScatterEvent> events,
                                                 std::span<double> weights) const;

    // Detector-side walks: whether sample_spectral_branches() honours BranchOptions::adjoint.
    virtual bool can_trace_adjoint() const { return false; }

    // Connections to collimated lights (next-event estimation at a diffuse event): a detector-side
    // walk, as with BranchOptions::adjoint (wo the direction towards the detector, position_um the
    // point on the top plane it starts from), that at its first diffuse event connects to each
    // light direction lights[j] (unit, away from the patch): a ray from the event towards the light
    // that passes only films with one medium on both sides (each weighs by its T, the direction
    // kept) and no other surface. Each connection that the sink accepts (asked before its ray is
    // cast) and nothing blocks reaches the sink with the power factors of LightConnection. For a
    // collimated beam of irradiance E⊥ (per area across the beam) along lights[j], entering at
    // entry_position_um, w E⊥ is the radiance the detector sees at (position_um, wo) from the
    // light paths whose one diffuse event is this one, reached straight from the light (after such
    // films). The light side (BranchOptions::connected_light_side) makes the same paths too; the
    // instrument weighs the two (sim/tracer.h, "Connections to collimated lights"). The walk ends
    // there, or escapes with nothing (a collimated light is never hit). Draws only from rng.
    virtual bool can_connect_lights() const { return false; }
    // How deep the scene reaches below the plane where light enters (µm; 0 when unknown): where
    // an instrument sees a beam's light at depth h is shifted by h (ω_o,xy/ω_o,z − ω_i,xy/ω_i,z),
    // which is where it starts its detector-side walks.
    virtual double depth_um() const { return 0.0; }
    virtual void trace_connected(const Vec3d& wo, std::span<const double> lambdas_nm,
                                 const Vec2& position_um, Rng& rng, std::span<const Vec3d> lights,
                                 LightConnectionSink& sink) const;

protected:
    ~PathTracing() = default;  // owned as the Scatterer that implements it
};

class Scatterer {
public:
    virtual ~Scatterer() = default;
    virtual std::string name() const = 0;
    virtual const std::vector<std::string>& lobe_names() const = 0;

    // One quantum of wavelength lambda_nm arriving from wi at position_um.
    virtual std::optional<ScatterEvent> sample(const Vec3d& wi, double lambda_nm,
                                               const Vec2& position_um, Rng& rng) const = 0;

    // Whether eval() and pdf() are available (analytic models: yes; the tracer: no).
    virtual bool can_evaluate() const { return false; }
    // f(ωi, ωo, λ) in 1/sr, summed over lobes; per-lobe values into per_lobe when given
    // (size lobe_names().size()).
    virtual double eval(const Vec3d& wi, const Vec3d& wo, double lambda_nm,
                        std::span<double> per_lobe = {}) const;
    // Whether eval() is the sum of its lobes, none of them negative, and eval_lobes() skips the
    // work of the lobes not asked for: then an instrument may refine one lobe's cubature past
    // another's (the goniometer's adaptive eval estimator: a narrow lobe's edges need many more
    // directions than a smooth lobe, virtual_gonio/goniometer.h).
    virtual bool evaluates_lobes_apart() const { return false; }
    // The lobes whose bit is set in `wanted` (bit k: lobe_names()[k]) into per_lobe (size
    // lobe_names().size(); the other entries unspecified), and their sum. By default eval() of
    // every lobe.
    virtual double eval_lobes(const Vec3d& wi, const Vec3d& wo, double lambda_nm,
                              std::uint32_t wanted, std::span<double> per_lobe) const;

    // The scatterer's path tracing (shared wavelengths, branches, detector-side walks), or
    // nullptr when it traces no paths (above).
    virtual const PathTracing* path_tracing() const { return nullptr; }

    // Solid-angle density of sample()'s ωo (including any discrete T lobe's share as a
    // separate mass, which pdf() does not report).
    virtual double pdf(const Vec3d& wi, const Vec3d& wo, double lambda_nm) const;
};

// scatterer.path_tracing(), or InvariantError naming the scatterer when it traces no paths.
const PathTracing& checked_path_tracing(const Scatterer& scatterer);

}  // namespace plumage
