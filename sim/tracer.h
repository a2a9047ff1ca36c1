// The spectral path tracer over explicit microgeometry: a Scatterer (sim/scatterer/scatterer.h)
// whose answers come from tracing light through a Scene (sim/scene.h).
//
// One path. sample(ω_i, λ, position, rng): the light enters on the plane just above the
// scene's bounds (z = top_z_um(), the "top plane") at `position` and travels along −ω_i
// (light from below the patch, ω_i.z < 0, enters on the bottom plane instead). At each
// surface it meets, the surface's event (sim/interface_events.h) decides what happens;
// between surfaces the medium on the arriving side may absorb or scatter (sim/medium.h).
// The path ends when the light escapes (no surface ahead: upward if ω_o.z > 0, downward
// otherwise), is absorbed, is ended by Russian roulette, or would need more than
// max_events events (its light is then dropped: the estimate of what leaves is low by the
// power of such paths; PathResult::reached_max_events reports them. In the test scenes
// none reach the default limit except rays that TIR traps for good inside a faceted
// sphere, 4 in 50 000).
//
// The returned ScatterEvent follows the Scatterer contract: ω_o the escape direction
// (away from the patch), weight the product of the events' throughputs (and roulette's
// 1/q): unbiased, E[weight · 1{ω_o ∈ Ω}] = fraction of the incident power leaving into Ω.
// exit_position_um is where the escaping light crosses the top plane (upward) or the
// bottom plane (downward); the rare path leaving exactly horizontally keeps the (x, y) of
// its last event.
//
// Lobes, by the path's event sequence (Huang 2022's names):
//   "R"     exactly one film reflection, nothing else
//   "TRT"   film transmission, diffuse (melanin) reflection, film transmission — nothing else
//   "T"     no event at all (passed between the barbules)
//   "multi" everything else (including single reflections at bare dielectric interfaces)
//   "volume" the light scattered at least once inside a scattering medium (sim/medium.h;
//            e.g. sim/scattering_medium.h), whatever else happened on its path
// The "volume" lobe exists only in scenes that can scatter in a volume: lobe_names() lists
// it (as the fifth name) when some surface names a medium other than the Beer–Lambert
// HomogeneousAbsorbingMedium, which never scatters; other scenes keep the four lobes above,
// so their records do not change.
//
// One wavelength per path (sample()), or one path for several (sample_spectral(), spectral
// path sharing, sim/scatterer/scatterer.h). A shared path is traced once for N wavelengths λ_1 …
// λ_N with a weight w_k per wavelength, all 1 at the start; at each event:
//  - film reflection or transmission (direction independent of λ when the indices on the two
//    sides are the same at every λ, e.g. the rock dove's keratin film in air): the walk for
//    λ_k alone chooses reflection with p_k = R_k/(R_k+T_k) and multiplies by R_k+T_k, so its
//    expected factor on the reflected branch is R_k (T_k on the transmitted one). The shared
//    path chooses with the mean p̄ = (1/N) Σ p_k and multiplies w_k by R_k/p̄ (reflected) or
//    T_k/(1 − p̄) (transmitted): each λ's expected factor is again R_k and T_k, so each w_k is
//    unbiased; p̄ >= p_k/N keeps the ratios below N.
//  - diffuse reflection (cosine direction, independent of λ): w_k ×= albedo_k.
//  - a bare dielectric interface whose indices are the same at every λ: the one Fresnel
//    factor for all.
//  - Reflection stays shared: a film or a bare interface whose indices differ with λ (keratin's
//    n(λ), a film over melanin) reflects every λ into the same direction when their events have
//    one regime (specular_regimes_agree, sim/interface_events.h: the same normal kept, light
//    able to pass at every λ or at none). The shared path then chooses the side as above, with
//    p̄ = (1/N) Σ R_k/(R_k+T_k) (Fresnel's for a bare interface) and w_k ×= R_k/p̄ or
//    T_k/(1 − p̄), and only a transmission goes on with the hero (below), whose own refraction
//    it takes; where the regimes differ (near a λ's critical angle) the hero takes the event
//    itself. Unbiased for each λ as both rules are. Why: the rooster's barbules are a film over
//    melanin; the hero used to take every event there, so each reflected path served one λ of
//    three. Its BTF's median per-pixel error at equal quanta fell from 23.8 % to 18.5 % (10–20 %
//    more time per quantum for the other λs' film responses); the parrot's 23.2 % → 20.3 %.
//  - an absorbing (non-scattering) medium along a segment: w_k ×= exp(−μ_k d).
//  - where the geometry depends on λ — refraction into a dispersive medium (keratin's n(λ)
//    at a bare dielectric or at a film between different media: the transmitted side of the
//    choice above, or the whole event where the regimes differ) and flights through a
//    scattering medium (μ_s(λ) sets the free paths) — the path continues for one wavelength
//    only, the hero h, drawn uniformly from {1 … N} by the quantum's own stream (one uniform
//    at the start of every shared path): w_h ×= N, every other w_k = 0, then the walk of λ_h
//    alone. Unbiased for each λ_k: with probability 1/N it is the hero and carries N times
//    what its own walk from that point would, so its expectation is that walk's (1/N · N = 1);
//    the variance grows by up to N for paths that reach such an event (each λ lives on 1/N of
//    them), which is the price of sharing the rest of the path.
//  - Russian roulette acts on w_max = max_k w_k in place of the weight: survive with
//    q = w_max / carried, then every w_k ×= 1/q (unbiased for each λ).
// Determinism as for sample(): everything comes from the Rng given.
// What it buys: the tracing (Embree queries, hit reconstruction, roulette) is done once for N
// wavelengths; a film hit still evaluates N table entries. Per-λ records receive correlated
// samples; each cell's standard error is still from independent quanta.

// Splitting at the first film (sample_spectral_branches(), sim/scatterer/scatterer.h): a shared
// path whose first event is a film hit is played as two branches from there, the reflected one with
// w_k ×= R_k and the transmitted one with w_k ×= T_k, both traced on (each then walks as above).
// The sum of the branches has the expectation of the single walk, which takes reflection with p̄ and
// weighs w_k ×= R_k/p̄ (T_k/(1 − p̄)): the same two terms, without the coin. Why: on a keratin film p̄
// is about 0.05–0.15, so a single walk sends only that share of its quanta into the R lobe, each
// carrying R_k/p̄; the reflected branch sends every quantum there with R_k, dividing the R lobe's
// variance by about 1/p̄ for one more ray per quantum. A path whose first event is not a film (it
// passes between the barbules, or meets a diffuse or bare surface first) is one branch, the
// transmitted branch's. The branches share the hero and, after the split, the random numbers:
// correlated parts of one quantum, which the instrument adds before it squares.
// With BranchOptions::split_reflections the reflected branch splits once more, at its next event
// if that is a film reached through no medium: it takes the reflected side (w_k ×= R_k) and
// leaves the transmitted side (w_k ×= T_k) as a third branch, which casts that ray again from
// the state before the event and walks on its own stream (two draws of the path's stream). Why:
// on the rock dove the chains of two film reflections between barbules ("RR", a barbule's
// reflection caught by its neighbour) carried 83 % of the multi lobe's second moment with the
// first film split (2026-12-01); a sampled choice makes them with probability p̄, the split from
// every reflected branch whose reflection meets a film. Measured: the multi lobe's ε² × t halves,
// not more, because p̄ is large at those grazing second reflections and the rest of the variance
// is which 5° cone the chain ends in (bench/README.md).
//
// Guided diffuse reflection (BranchOptions::guided_fraction f, sim/scatterer/scatterer.h): at a
// path's first diffuse event the direction is drawn from a mixture of the cosine lobe (1 − f) and
// the instrument's detector cones (f, one cone at random, uniform within it), and every λ's weight
// takes albedo_k · (cos θ/π)/p_mixture (sim/interface_events.h, guided_diffuse_event): unbiased
// for every direction. Why: on the rock dove the TRT lobe held 60 % of the BRDF's variance; a
// cosine direction enters a given 5° detector about 0.3 % of the time, a guided one about f/m
// of the time for each of the m detectors of the light direction. In the film-in-air scenes the
// film does not bend the light, so a direction aimed at a detector leaves towards it when
// nothing blocks it. Where the event lies inside a dielectric of index n > 1 (a white medulla
// under a clear cortex), the light refracts on its way out, so the cones are aimed at through
// an interface parallel to the event's facet (sim/interface_events.h, refracted_cone_axis): a
// concentric cortex leaves close to that parallel. The aim only moves the cones; the mixture's
// density uses the same cones, so it stays unbiased for any aim (on the stork's BTF, 1.10× less
// variance at the same time). Only the first diffuse event is guided, later ones follow the cosine
// law: a guided event can multiply the weight by up to albedo/(1 − f), and a path with many of them
// (the stork's white medulla, three layers of diffuse bounces) had weights so heavy-tailed at
// f = 0.8 that its values and their error bars were off (χ²/dof 1.47 against the plain walk,
// not shrinking with 20× the quanta) while one guided event per path stays clean.
//
// Guided diffuse branches (BranchOptions::guided_branches k, in place of guided_fraction): a
// path's first diffuse event goes on as 1 + k branches instead of one direction: one drawn by
// the cosine law, k uniformly within the detector cones, every direction d weighed by the
// multi-sample balance heuristic, albedo_k · (cos θ/π) / (p_c(d) + k p_g(d))
// (sim/interface_events.h, guided_diffuse_branches): their sum is unbiased for every direction,
// and no weight grows. Each guided branch walks on from the event on its own stream (two draws
// of the path's stream, branch index); later diffuse events follow the cosine law. Why: the
// one-sample mixture weighs a direction that no cone holds by 1/(1 − f) (5 at f = 0.8); on the
// rock dove such directions that a neighbouring barbule blocks and reflects into a detector
// ("tdtr" paths) carried 31 % of the second moment at f = 0.8 against 3.5 % unguided. The
// balance heuristic weighs them by exactly the albedo, as an unguided event does, and still
// sends k directions per event into the cones; the price is the rays of the k branches (about
// 2.4 more per quantum on the rock dove, 1.45× the instructions at k = 1).
//
// Reflections aimed at the detectors (BranchOptions::split_aimed_reflections, sim/scatterer/
// scatterer.h): at a bare dielectric interface where the mirror direction of the walk's direction
// about the shading normal lies within a detector cone, the walk takes both sides, as splitting
// at a film does: the reflected side goes on as a branch of its own (each λ × R_k, the path still
// shared where every λ's regime agrees, else the hero's; its own stream, two draws of the path's)
// and the walk takes the transmitted side (× T_k, then the hero through λ-dependent indices). The
// sum of the two has the expectation of the sampled choice, whatever decides where to split.
// Total internal reflection is no choice and is left alone. A branch waits in the walk's list of
// pending branches (1 + kMaxGuidedBranches of them), and an aimed interface splits only while
// room is left there for the branches the walk may still leave (its first diffuse event's guided
// ones, a reflected branch's split at its next film); after that it chooses as usual. Branches
// themselves choose as usual. Why: on the flamingo's BTF the detector walks meet keratin, where
// Fresnel reflects 4–5 %; the walks whose partial reflection heads for a light carried 56 % of the
// bright tiles' signal and 64 % of its second moment, each such reflection taken 1 time in 20–25.
// Measured on the species BTFs (bench/README.md): error² × time 1.15–1.19× lower on the flamingo,
// 1.12× on the stork, 1.36× on the rooster, 5–10 % higher on the parrot (its noise is in the
// spongy medium; it pays for the branches). Raising the reflection's probability instead (to 0.25
// where the mirror aims within 20° of a light, weights R_k/p and T_k/(1 − p); not kept) helped
// the flamingo as much but cost the parrot 1.4×: the blue of its medulla comes through the barbs'
// cortex on the transmitted side, whose walks it thinned; the split thins none. Splitting only
// where the walk arrives from the air (the aim is approximate inside keratin, which bends the
// light again on its way out) lost part of the rooster's and the flamingo's gain: reflections
// aimed inside a barbule do leave through its curved far side towards the light. Only where a
// detector walk has lights to aim at (the BTF camera's detector estimator).
//
// Detector-side walks (BranchOptions::adjoint, sim/scatterer/scatterer.h): the same walk started at
// a detector, for instruments that image (virtual_gonio/btf.h). Every event of the tracer moves
// power symmetrically — Fresnel and film R and T are the same both ways, a Lambertian event
// about the facet normal and a medium's phase function are symmetric, absorption along a segment
// is — except a specular event about an interpolated shading normal on a flat facet: it maps a
// beam's étendue by the factor sim/interface_events.h states (adjoint_shading_factor), so the
// reversed walk would estimate the transpose of the forward kernel, f(b, a) · (b·n_g)/(a·n_g)
// per such event. The detector-side walk multiplies its weights by that factor at every such
// event and so estimates the forward walk's light paths: with the entry and exit planes
// exchanged, E[w · 1{exit ∈ U, ω ∈ Ω}] / cos θ_Ω of the walk from (x, ω_d) equals the forward
// walk's E[w · 1{exit near x, ω near ω_d}] / cos θ_d from U and Ω (reciprocity of the
// radiance kernel; btf.h turns it into pixel values). Tested against the forward walk on faceted
// spheres, films and media (tests/virtual_gonio/btf_detector_test.cpp).
//
// Connections to collimated lights (trace_connected(), BranchOptions::connected_light_side,
// sim/scatterer/scatterer.h): next-event estimation at the first diffuse event of a detector-side
// walk, weighed against the light side by multiple importance sampling. At the first diffuse
// event v that the walk from the detector reaches, with weights w_k (the adjoint walk above), for
// each light direction l with cos θ_l = l · n > 0 (n the facet normal on the walk's side) a ray is
// cast from v towards the light. It may pass films whose outside and inside are the same material
// with no medium on either side at every λ ("straight" films: the rock dove's keratin sheets in
// air, which keep a direction), each weighing by its T_k at the cos θ and side that
// thin_film_event would use for light travelling the other way (film_incidence()); any other
// surface blocks it. Unblocked, it reports w_k · albedo_k · cos θ_l / π · Π T_k, the point where
// it crosses the top plane, and g cos θ_l (below). Why this is the light: a collimated beam of
// irradiance E⊥ along l lights v through those films with E⊥ cos θ_l Π T_k (the films' T is the
// expected factor of their transmitted side, both ways), v's Lambertian layer sends albedo/π of it
// per steradian, and the adjoint weight w carries that radiance to the detector. The connections
// so make the light paths with exactly one diffuse event, lit straight from the source (after
// straight films, with no medium on v's lit side); the walk ends at v.
// The light side makes the same paths: with connected_light_side a path lit straight at its first
// diffuse event goes on from it with probability g = kGoOnLit = 0.25 (weights ÷ g; tracer.cpp says
// why 0.25) and, as long as that stays its only diffuse event, escapes with
// SpectralScatterEvent::lit_diffuse_density = g cos θ_l. The instrument weighs the two by the
// balance heuristic, which needs only the ratio of the two densities of one path, and that ratio
// is the same number on both sides: measured over the diffuse point and the direction leaving it,
// the light side's density is (cos θ_l / π r²) · g · (cos θ_o / π) (a uniform beam of radius r,
// the cosine lobe), the detector side's p(x | ω) cos θ_o / (π sin²α cos θ_v) (the start density
// times the cone's projected-solid-angle density, carried through the specular events in between
// by the conservation of étendue), so ρ = p_L/p_D = g cos θ_l sin²α cos θ_v / (π r² p(x | ω))
// (virtual_gonio/goniometer.h). The film choices on the lit segment (T ≥ 0.9 on films in air) and
// the diffuse albedo are left out of both densities alike: weights that add to 1 for every path
// keep the sum unbiased whatever they are; the balance heuristic's are the near-optimal ones.
// Paths that only one side makes (those whose first event is a film reflection, the chains of
// specular events between barbules, paths with two diffuse events or more) keep that side's
// weight 1. Why the light side walks the lit paths at all (g > 0): its paths with a second diffuse
// event have no other estimator, and for the others it is the balance heuristic's second sample.
// Why one diffuse event only: a connection at the walk's k-th diffuse event would reach the light's
// beam far from where the walk started once the light has crossed the scene k times (a film 40 µm
// over a plate: 80 tan θ per bounce), where the walks rarely start; with the partition of the
// paths used before the balance heuristic, those connections gave heavy-tailed, low cells
// (χ²/dof 2.5–3.8 against the forward walk, growing with the quanta). The balance heuristic would
// tame them, but on the rock dove connecting at every diffuse event gained nothing (the light
// side's paths with two diffuse events hold 0.1 % of its second moment) and cost 15 % more per
// pass (2026-12-01). The whole path's lobe: TRT when the connection passed one film and the walk
// one film transmission before v, "volume" after a medium scatter, "multi" otherwise. A connection
// is not made when the whole path would exceed max_events.
//
// Leaving out what the scene does not need: a scene without films never evaluates Airy;
// surfaces whose media do not absorb at λ (k = 0) run no medium code; max_events = 1 (an
// "R only" request) stops every path at its first event (a path that would meet a second
// surface is dropped; what is returned is exactly the single-event lobes with their
// masking). Per wavelength, the materials' indices, albedos, media activity and the film
// tables are computed once and cached (thread-safe), so a path does no per-λ set-up.
//
// Russian roulette after `roulette_after_events` events: the path survives with
// probability q = min(1, weight) and its weight is divided by q (unbiased). Lossless
// scenes keep weight 1 (to round-off) and practically never lose a path to it.
// Before that, a path whose weight falls below w_min = `roulette_below_weight` (after an
// event, or on arriving through an absorbing medium, before its event is evaluated) survives
// with probability weight / w_min and carries w_min on (unbiased; its second moment grows from
// w² to w · w_min, at most w_min² = 10⁻⁴ of a unit-weight path's). Why: light refracted into
// melanin (a barbule core, the medulla's core) is attenuated to 10⁻⁹ and less within a few
// µm but was traced on until the 8th event, each hit from inside a film evaluated directly
// (its table is refused there, sim/film_table.h): 23 % of the parrot's rays and 44 % of the
// rooster's carried a weight below 10⁻³ (species study, 2026-11-26). 0 turns it off.
//
// Determinism: sample() draws only from the Rng it is given, so a path depends on
// (scene, ω_i, λ, position, rng state) alone; trace_many() seeds one stream per sample
// index, so results are bit-identical for any thread count.
//
// Parameter table:
//  | name                  | default | valid range   | meaning                                 |
//  |-----------------------|---------|---------------|-----------------------------------------|
//  | max_events            | 1000    | [1, 10⁶]      | events per path (1: single-event lobes) |
//  | roulette_after_events | 8       | >= 1          | events before Russian roulette starts   |
//  | roulette_below_weight | 0.01    | [0, 1)        | w_min of the low-weight roulette        |
//  | tabulate_films        | true    |               | per-λ film tables (sim/film_table.h)    |
//  | film_table_tolerance  | 1e-5    | (0, 0.01]     | absolute R, T error of the tables       |
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

#include "sim/film_table.h"
#include "sim/interface_events.h"
#include "sim/scatterer/scatterer.h"
#include "sim/scene.h"

namespace plumage::sim {

struct TracerOptions {
    int max_events = 1000;
    int roulette_after_events = 8;
    double roulette_below_weight = 0.01;
    bool tabulate_films = true;
    double film_table_tolerance = FilmTable::kDefaultTolerance;

    void validate() const;  // InputError naming the option
};

// One ray cast by the tracer (for benchmarks that replay the same rays on bare Embree).
struct RaySegment {
    Vec3d origin;
    Vec3d direction;
};

// Everything about one path, for tests and diagnostics; sample() keeps only `event`.
struct PathResult {
    static constexpr int kRecordedEvents = 8;

    std::optional<ScatterEvent> event;  // empty: absorbed, dropped or ended by roulette
    int events = 0;
    std::array<EventKind, kRecordedEvents> kinds{};  // the first events, in order
    int rays = 0;                                    // Embree queries
    int self_hits_rejected = 0;  // hits on the facet just left (Scene::intersect)
    int medium_mismatches = 0;   // arrived on a side whose index is not the one it left into
    int medium_scatters = 0;     // scattering events inside media (all, not only the first 8)
    bool reached_max_events = false;
    bool ended_by_roulette = false;
    double lit_diffuse_density = 0.0;  // SpectralScatterEvent's, when it escaped
};

class ExplicitScatterer final : public Scatterer, public PathTracing {
public:
    enum Lobe : int { kR = 0, kTRT = 1, kT = 2, kMulti = 3, kVolume = 4 };

    ExplicitScatterer(std::shared_ptr<const Scene> scene, const TracerOptions& options = {});
    explicit ExplicitScatterer(SceneDescription description, const TracerOptions& options = {});

    std::string name() const override { return "explicit"; }
    const std::vector<std::string>& lobe_names() const override;
    std::optional<ScatterEvent> sample(const Vec3d& wi, double lambda_nm, const Vec2& position_um,
                                       Rng& rng) const override;
    const PathTracing* path_tracing() const override { return this; }
    bool can_split_paths() const override { return true; }
    bool can_trace_adjoint() const override { return true; }
    bool can_connect_lights() const override { return true; }
    double depth_um() const override { return top_z_ - bottom_z_; }
    void trace_connected(const Vec3d& wo, std::span<const double> lambdas_nm,
                         const Vec2& position_um, Rng& rng, std::span<const Vec3d> lights,
                         LightConnectionSink& sink) const override;
    std::size_t sample_spectral_branches(const Vec3d& wi, std::span<const double> lambdas_nm,
                                         const Vec2& position_um, Rng& rng,
                                         const BranchOptions& options,
                                         std::span<SpectralScatterEvent> events,
                                         std::span<double> weights) const override;
    std::optional<SpectralScatterEvent> sample_spectral(const Vec3d& wi,
                                                        std::span<const double> lambdas_nm,
                                                        const Vec2& position_um, Rng& rng,
                                                        std::span<double> weights) const override;
    // The first film event of a shared path: chosen at random (sample_spectral()), or one of
    // the two branches of sample_spectral_branches(). The reflected branch ends without an
    // event when the path's first event is not at a film (that path has no such branch).
    enum class FirstFilm { sampled, reflect, transmit };
    // The same path as sample_spectral(), with its diagnostics (event->weight: the hero's
    // weight, or the largest when the path stayed shared). guide: the detector cones that
    // diffuse events aim at (guided diffuse reflection), or none.
    PathResult trace_spectral(const Vec3d& wi, std::span<const double> lambdas_nm,
                              const Vec2& position_um, Rng& rng, std::span<double> weights,
                              FirstFilm first_film = FirstFilm::sampled,
                              const BranchOptions* guide = nullptr) const;

    // The same path as sample(), with its diagnostics; `rays` (optional) receives every
    // ray cast.
    PathResult trace(const Vec3d& wi, double lambda_nm, const Vec2& position_um, Rng& rng,
                     std::vector<RaySegment>* rays = nullptr) const;

    const Scene& scene() const { return *scene_; }
    const TracerOptions& options() const { return options_; }
    double top_z_um() const { return top_z_; }
    double bottom_z_um() const { return bottom_z_; }

    struct Spectral;     // per-wavelength optics of every surface
    struct SpectralSet;  // the optics at several wavelengths, and what a shared path may share

private:
    // Where the light enters: on the top plane, or the bottom plane for light from below.
    Vec3d entry_origin(const Vec2& position_um, const Vec3d& wi) const {
        return {position_um.x(), position_um.y(), wi.z() > 0.0 ? top_z_ : bottom_z_};
    }
    // The entry ray's hit, cast once for the two branches of a split path.
    struct FirstHit {
        std::optional<SurfaceHit> hit;
        int skipped = 0;
    };
    // A shared walk's state between events: where a guided diffuse branch goes on from.
    struct WalkState {
        Vec3d origin = Vec3d::Zero(), direction = Vec3d::Zero();
        PrimitiveRef skip;
        optics::Complex expected;
        std::array<double, kMaxSharedWavelengths> w;  // set before use (walk_spectral)
        bool single = false;
        std::size_t hero = 0;
        bool diffuse_met = false;  // its path has had a diffuse event (guiding acts at the first)
        // Every event so far a transmission through a straight film, every flight through no
        // medium ("Connections to collimated lights").
        bool lit_straight = true;
        // g · cos θ_l at its first diffuse event when that was lit straight, else 0
        // (BranchOptions::connected_light_side).
        double lit_diffuse_density = 0.0;
        // BranchOptions::split_reflections: the next event splits if it is a film; a branch
        // left there takes that film's forced side (1 reflect, 0 transmit; −1 none).
        bool split_next_film = false;
        int forced_film = -1;
        PathResult path;
        std::uint64_t stream_seed = 0, stream_item = 0;  // a branch's own stream: Rng(seed, item)
    };
    // The guided branches a walk left at its first diffuse event, to be walked on.
    struct PendingBranches {
        std::array<WalkState, BranchOptions::kMaxGuidedBranches + 1> at;
        std::size_t count = 0;
    };
    // trace_spectral(), from `first`'s entry hit when given (it must be the entry ray's), or
    // on from `resume` (a pending branch; rng its own stream); with `pending`, the first diffuse
    // event branches (guide->guided_branches) and the guided branches are left there.
    PathResult walk_spectral(const Vec3d& wi, std::span<const double> lambdas_nm,
                             const Vec2& position_um, Rng& rng, std::span<double> weights,
                             FirstFilm first_film, const BranchOptions* guide,
                             const FirstHit* first, const WalkState* resume = nullptr,
                             PendingBranches* pending = nullptr) const;
    class SpectralWalk;  // walk_spectral()'s state and steps (tracer.cpp)
    struct Connections;  // what a connected walk connects to (tracer.cpp)
    // The shared walk's start state for light (or a detector) along −wi entering at position_um.
    WalkState start_state(const SpectralSet& set, const Vec3d& wi, const Vec2& position_um,
                          std::size_t n, Rng& rng) const;
    // trace()'s scattering inside a medium after a free flight of distance_um: the event, the
    // new direction and weight; false when the path ends there (max_events, or no weight left).
    bool scatter_in(const Medium& medium, double lambda_nm, double distance_um, Vec3d& origin,
                    Vec3d& direction, double& weight, PathResult& path, Rng& rng) const;
    const Spectral& spectral(double lambda_nm) const;
    std::shared_ptr<const Spectral> lookup_spectral(double lambda_nm) const;
    const SpectralSet& spectral_set(std::span<const double> lambdas_nm) const;
    std::shared_ptr<const Spectral> build_spectral(double lambda_nm) const;

    std::shared_ptr<const Scene> scene_;
    TracerOptions options_;
    double top_z_ = 0.0, bottom_z_ = 0.0;
    std::vector<std::string> lobe_names_;
    std::uint64_t id_;  // distinguishes scatterers in the per-thread wavelength cache
    mutable std::mutex cache_mutex_;
    mutable std::unordered_map<std::uint64_t, std::shared_ptr<const Spectral>> cache_;
};

// Positions drawn uniformly over an axis-aligned rectangle of the patch (µm).
struct BeamFootprint {
    Vec2 min_um;
    Vec2 max_um;
};

// count samples of any scatterer: sample i (i = 0 … count−1) uses Rng(seed, first_index + i),
// draws its position from the footprint with that stream, then calls sample(). OpenMP
// over samples with `threads` threads; the result is indexed by sample, so it is the same
// for any thread count. The first exception thrown by any sample is rethrown.
std::vector<std::optional<ScatterEvent>> trace_many(const Scatterer& scatterer, const Vec3d& wi,
                                                    double lambda_nm,
                                                    const BeamFootprint& footprint,
                                                    std::uint64_t seed, std::uint64_t first_index,
                                                    std::size_t count, int threads);

// Per-lobe sums of weights, in sample order (so they are bit-identical whenever the
// samples are). Absorbed samples count in `samples` and nowhere else.
struct LobeTally {
    std::size_t samples = 0;
    std::vector<double> weight;     // Σ weight per lobe
    std::vector<double> weight_sq;  // Σ weight² per lobe
    std::vector<std::size_t> count;
    double up = 0.0, down = 0.0;  // Σ weight with ω_o.z > 0 and < 0

    // Fraction of the incident power in a lobe, and its standard error (sample variance).
    double mean(int lobe) const;
    double standard_error(int lobe) const;
    double total() const { return (up + down) / static_cast<double>(samples); }
};
LobeTally tally(const std::vector<std::optional<ScatterEvent>>& samples, std::size_t lobes);

}  // namespace plumage::sim
