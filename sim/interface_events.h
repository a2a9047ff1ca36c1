// What light does when it meets a surface: pure functions of the incoming direction, the
// surface normals and the optics at one wavelength (no Embree, no scene), so that each
// can be tested alone. The tracer (sim/tracer.h) calls them at every hit.
//
// Conventions:
//  - `direction` is the PROPAGATION direction (where the light travels), a unit vector;
//    it is not the Scatterer's "away from the patch" ω. Outgoing directions likewise.
//  - The geometric normal is the facet's unit normal; it points to the surface's
//    OUTSIDE (sim/scene.h: the side of the outward winding normal of
//    geometry/triangle_mesh.h; "above" for a film). Light arrives from the outside when
//    direction · geometric < 0.
//  - The shading normal (interpolated from the analytic surface) sets the local angle of
//    incidence and the specular directions. It is rejected in favour of the geometric
//    normal when it would be inconsistent with the facet: when it faces away from the
//    light while the facet faces it, or when a specular direction it gives would leave
//    on the wrong side of the facet (reflection into it, transmission back out). The
//    event is then evaluated entirely with the geometric normal (probabilities and
//    directions), so the choice stays unbiased for the facet actually hit.
//  - Indices are complex n + ik (sim/optics/fresnel.h). Fresnel and Airy need a lossless
//    incidence medium; when the light arrives from inside an absorbing medium the real
//    part of its index is used (exact as k → 0; with large k no light gets that far).
//    Directions of refraction use the real parts (Snell).
//
// Polarisation. The light is unpolarised and no polarisation state is carried along a
// path: at each interface the reflection and transmission probabilities are the means of
// the s and p intensities. This neglects the partial polarisation that one reflection or
// refraction imprints on the light and that changes the next interface's response
// (e.g. light refracted near Brewster's angle is mostly p-polarised and reflects less
// at the second surface of a slab than the unpolarised mean says). For single-event
// lobes (R) it is exact; for TRT the error is second order in the s–p difference, which
// is small at the near-normal angles where films are bright; multi-bounce paths in
// dielectric bodies are where it matters most. A Stokes/Mueller path state would fix it
// at 4–16× the cost per event.
//
// Choosing events: the reflection and transmission probabilities R and T are used as
// R/(R+T) and T/(R+T), and the path weight is multiplied by R+T (the part that neither
// the film nor the interface absorbs). For lossless interfaces R+T = 1 and the walk is
// analog; with absorption no path is killed at random for it.
#pragma once

#include <span>

#include <Eigen/Core>

#include "sim/optics/fresnel.h"
#include "sim/optics/multilayer.h"
#include "sim/optics/thin_film.h"
#include "sim/scatterer/random.h"

namespace plumage::sim {

using Vec3d = Eigen::Vector3d;

enum class EventKind : unsigned char {
    film_reflect,               // reflected by a thin-film-coated interface
    film_transmit,              // through a thin-film-coated interface
    specular_reflect,           // partial reflection at a bare dielectric interface
    refract,                    // transmission through a bare dielectric interface
    total_internal_reflection,  // at a bare dielectric interface beyond the critical angle
    diffuse_reflect,            // Lambertian layer
    absorb,                     // absorber, or nothing left to reflect or transmit
    medium_scatter,             // scattering inside a participating medium (sim/medium.h)
};

const char* to_string(EventKind kind);

struct SurfaceNormals {
    Vec3d shading;    // unit; may differ from geometric (see above)
    Vec3d geometric;  // unit; points to the surface's outside
};

struct InterfaceEvent {
    EventKind kind;
    Vec3d direction;             // propagation direction after the event (zero when absorbed)
    double throughput;           // factor on the path weight, in [0, 1]
    bool to_outside;             // the light continues on the outside of the facet (spawn side)
    bool used_geometric_normal;  // the shading normal was rejected (see above)
};

// A thin film (Airy, or by intensity when incoherent) at one wavelength: indices of the
// medium on the outside (above the film), of the film and of the inside (below it).
struct FilmOptics {
    optics::Complex outside;
    optics::Complex film;
    optics::Complex inside;
    double thickness_um;
    optics::Coherence coherence = optics::Coherence::coherent;
};

struct FilmResponse {
    double reflectance;    // unpolarised
    double transmittance;  // unpolarised, normal-flux ratio (fresnel.h)
};

// Unpolarised R and T of the film for light arriving from the outside (or the inside) at
// cos θ ∈ [0, 1]: Airy (sim/optics/thin_film.h) when coherent, the transfer-matrix
// solver with the film flagged incoherent (sim/optics/multilayer.h) otherwise.
FilmResponse film_response(const FilmOptics& film, bool from_outside, double lambda_nm,
                           double cos_theta);

// Source of film responses: direct evaluation, or a table (sim/film_table.h).
class FilmResponseSource {
public:
    virtual ~FilmResponseSource() = default;
    virtual FilmResponse response(bool from_outside, double cos_theta) const = 0;
};

class DirectFilmResponse final : public FilmResponseSource {
public:
    DirectFilmResponse(const FilmOptics& film, double lambda_nm)
        : film_(film), lambda_nm_(lambda_nm) {}
    FilmResponse response(bool from_outside, double cos_theta) const override {
        return film_response(film_, from_outside, lambda_nm_, cos_theta);
    }

private:
    FilmOptics film_;
    double lambda_nm_;
};

// Thin-film-coated interface. The film has no geometric thickness: the transmitted light
// leaves from the hit point, refracted as between the outside and inside media (parallel
// film faces conserve the tangential wavevector), straight on when they are equal.
InterfaceEvent thin_film_event(const Vec3d& direction, const SurfaceNormals& normals,
                               const FilmOptics& film, const FilmResponseSource& source, Rng& rng);
// Convenience: direct evaluation at lambda_nm.
InterfaceEvent thin_film_event(const Vec3d& direction, const SurfaceNormals& normals,
                               const FilmOptics& film, double lambda_nm, Rng& rng);

// Where thin_film_event evaluates a film for light along `direction`: the side it arrives from
// and cos θ about the normal the event accepts ("Conventions": the shading normal, or the
// geometric one where the shading normal is rejected); eta = n_incident / n_transmitted (the
// film's outside and inside indices' real parts). A connection to a light through a film with one
// medium on both sides (sim/tracer.h, "Connections to collimated lights") weighs by the film's T
// there, which is the expectation of the event's factor on the transmitted side.
struct FilmIncidence {
    bool from_outside;
    double cos_i;
};
FilmIncidence film_incidence(const Vec3d& direction, const SurfaceNormals& normals, double eta);

// Bare dielectric interface between the outside and inside media: unpolarised Fresnel
// reflection or refraction; total internal reflection when no refracted direction exists.
InterfaceEvent dielectric_event(const Vec3d& direction, const SurfaceNormals& normals,
                                optics::Complex outside, optics::Complex inside, Rng& rng);

// The same event with the reflection and transmission probabilities of `source` (its R and T
// at the event's cos θ) and the indices' real parts for the geometry: a shared path's choice
// over several wavelengths (sim/tracer.h, "Reflection stays shared"). Total internal reflection
// as above, without a draw.
InterfaceEvent dielectric_event(const Vec3d& direction, const SurfaceNormals& normals,
                                double outside, double inside, const FilmResponseSource& source,
                                Rng& rng);

// Whether every wavelength's specular event at this hit has one regime: the same normal kept (the
// shading normal is rejected where a direction it gives leaves on the wrong side, see
// "Conventions", and the transmitted direction depends on the index ratio) and light able to be
// transmitted at all of them or at none (the critical angle). Wavelengths with one regime reflect
// about one normal, at one cos θ, into one direction; only their transmitted directions differ.
// outside[k], inside[k]: the real parts of the indices at wavelength k (geometry uses the real
// parts, as the events do). A few multiplications and one square root per wavelength: it is
// asked at every event of a shared path on a dispersive surface.
bool specular_regimes_agree(const Vec3d& direction, const SurfaceNormals& normals,
                            std::span<const double> outside, std::span<const double> inside);

// Lambertian reflection with the given albedo, on whichever side the light arrives.
// Cosine-distributed about the geometric normal: a diffuse layer has no preferred
// direction within a facet, and sampling about the facet normal keeps every sample on the
// correct side (the shading normal differs from it by the tessellation's normal error).
InterfaceEvent diffuse_event(const Vec3d& direction, const SurfaceNormals& normals, double albedo,
                             Rng& rng);

// Lambertian reflection guided towards detector cones (sim/tracer.h, "Guided diffuse
// reflection"): the direction d is drawn from the mixture
//     p(d) = (1 − f) · max(0, d·n)/π + f · (1/m) Σ_j 1[d·a_j >= cos α] / (2π(1 − cos α))
// (n the facet normal on the arriving side; m = cone_axes.size() cones of half-angle α, each
// picked with probability 1/m and sampled uniformly in solid angle) and the event carries
// throughput (max(0, d·n)/π) / p(d) for an albedo of 1 (the caller multiplies by its albedo):
// an unbiased estimate of the cosine lobe for every direction. The throughput can exceed 1
// (at most 1/(1 − f)); a direction below the facet carries 0 (kind absorb). f in [0, 1).
InterfaceEvent guided_diffuse_event(const Vec3d& direction, const SurfaceNormals& normals,
                                    std::span<const Vec3d> cone_axes, double cos_half_angle,
                                    double fraction, Rng& rng);

// Lambertian reflection as 1 + k directions at once (sim/tracer.h, "Guided diffuse
// branches"): events[0] drawn by the cosine law about the facet normal, events[1 … k] each
// uniformly within one of the cones (picked with probability 1/m, as above). Every direction d
// carries the multi-sample balance heuristic's throughput, for an albedo of 1,
//     (max(0, d·n)/π) / (p_c(d) + k p_g(d)),
// p_c the cosine density and p_g the cones' (the guided_diffuse_event mixture's second term):
// unbiased for their sum, E[Σ_i throughput_i g(d_i)] = ∫ g(d) cos θ/π dω for every g, and
// never above 1 (a direction outside every cone carries exactly 1, as a plain diffuse event;
// inside one, much less). A direction below the facet carries 0 (kind absorb). Returns 1 + k;
// cone_axes not empty, events.size() >= 1 + k.
std::size_t guided_diffuse_branches(const Vec3d& direction, const SurfaceNormals& normals,
                                    std::span<const Vec3d> cone_axes, double cos_half_angle,
                                    std::size_t guided, Rng& rng, std::span<InterfaceEvent> events);

// Where a diffuse event inside a dielectric of index n should aim to leave towards a cone axis
// a in air: the inside direction that Snell's law refracts into a through a flat interface of
// unit normal `out` (pointing out of the dielectric, towards a's side),
//     d = a_t/n + sqrt(1 − |a_t|²/n²) out,  a_t = a − (a·out) out.
// An aim for guided_diffuse_branches' cones, never a constraint: the branches' balance heuristic
// is unbiased for any axes, and the aim's quality only sets how many guided directions leave
// through the light's cone. An axis with a·out <= 0 (behind the interface), or n <= 1, is
// returned as it is.
Vec3d refracted_cone_axis(const Vec3d& a, const Vec3d& out, double n);

// The factor a detector-side (adjoint) walk multiplies its weight by at an event, so that it
// estimates the light paths of the forward walk and not their transpose (sim/tracer.h,
// "Detector-side walks"). A specular event about a shading normal n_s on a facet of geometric
// normal n_g maps a beam's étendue dA |cos θ_g| dω by |d_out·n_g| |d_in·n_s| /
// (|d_in·n_g| |d_out·n_s|) (reflection and refraction alike; Veach 1997, Sect. 5.3), so the
// forward kernel is the reversed one times
//     C = |d_out·n_g| |d_in·n_s| / (|d_in·n_g| |d_out·n_s|),
// d_in the adjoint walk's arriving propagation direction and d_out its new one. Diffuse events
// (about n_g), events evaluated with the geometric normal and absorption: C = 1.
double adjoint_shading_factor(const Vec3d& arriving, const InterfaceEvent& event,
                              const SurfaceNormals& normals);

// Opaque black surface.
InterfaceEvent absorber_event(const Vec3d& direction, const SurfaceNormals& normals);

// Geometry helpers, exposed for tests.
Vec3d reflect(const Vec3d& direction, const Vec3d& normal);
// Refraction of `direction` through a surface with unit `normal` (either orientation),
// eta = n_incident / n_transmitted; false when totally internally reflected.
bool refract(const Vec3d& direction, const Vec3d& normal, double eta, Vec3d* refracted);
// Cosine-weighted direction about the unit normal (density cos θ / π).
Vec3d sample_cosine_hemisphere(const Vec3d& normal, Rng& rng);
// Unpolarised Fresnel R and T from the lossless medium n_in at cos_i ∈ [0, 1] into the
// lossless medium n_out, in real arithmetic: optics::fresnel_intensities_unpolarised with
// k = 0 on both sides (to round-off; T = 1 − R). dielectric_event takes it when neither
// side absorbs.
optics::FresnelIntensities lossless_fresnel_unpolarised(double n_in, double n_out, double cos_i);

}  // namespace plumage::sim
