// The virtual goniometer: measures the BRDF of any Scatterer on a list of
// (light, view) direction pairs, each cell with its standard error, progressively,
// with a convergence table of (wall time, samples, estimated error), resumable after
// an interruption. The record layout is documented in virtual_gonio/RECORD.md.
//
// Geometry: the patch frame of sim/scatterer/scatterer.h (+z normal). The light is a collimated
// beam of radius beam_radius_um (its footprint on the patch is the beam's cross-section
// projected along ω_i); each view direction has a detector: a cone C(ω_o) of half-angle α
// around it, solid angle Ω = 2π(1 − cos α), projected solid angle
// P(ω_o) = ∫_C cos θ dω = π sin²α cos θ_v (exact for a cone wholly above the patch plane).
//
// Aperture: what a cell is the average of.
//  - view_cone (default, the historical instrument): the light exactly along ω_i, the
//    detector cone around ω_o, cosine-weighted:
//        f̄(ω_i, ω_o) = (1/P(ω_o)) ∫_{C(ω_o)} f(ω_i, ω) cos θ dω.
//    NOT symmetric: for a lobe narrower than the cone, f̄(a, b) / f̄(b, a) → (cos θ_a /
//    cos θ_b)² near the specular pair, so a reciprocal scatterer reads non-reciprocal.
//  - both_cones (reciprocal): the light too comes from a cone of the same half-angle α
//    around ω_i (an extended source of uniform radiance), each direction weighted by the
//    irradiance it gives the patch (cos θ):
//        f̄(ω_i, ω_o) = (1/(P(ω_i) P(ω_o))) ∫_{C(ω_i)} ∫_{C(ω_o)} f(ω', ω) cos θ' cos θ dω dω'.
//    For a reciprocal f (f(a, b) = f(b, a)) this is symmetric under ω_i ↔ ω_o exactly (swap
//    the integration variables). Both directions of a pair must then stay above the patch
//    plane by the cone (cos θ > sin α); the beam footprint stays that of the central ω_i.
//  Directions over a cone are drawn (or integrated) by projected solid angle through
//  cone_direction_by_projected_area(): the cap C(a) projects orthographically onto the
//  patch plane as an ellipse (centre cos α·a_xy, semi-axes sin α·cos θ_a radially and sin α
//  across) of area P(a); a point uniform in it, lifted to the unit sphere, has density
//  cos θ / P(a) over the cap (Malley's method restricted to the cap).
//
// Estimators:
//  - photon: play quanta through sample() and count what enters each detector:
//    f̂ = mean(weight · 1[ω_o ∈ cone]) / (π sin²α cos θ_v). Unbiased for the cell's
//    average above; under both_cones each quantum first draws its own light direction ω'
//    from C(ω_i) by projected solid angle (two uniforms from its stream after the beam
//    position's). Works for every scatterer (the tracer too).
//    With share_wavelength_paths (and a scatterer with path_tracing(), sim/scatterer/scatterer.h)
//    a quantum is one path for every wavelength, carrying a weight per λ (sim/tracer.h,
//    spectral path sharing), drawing from Rng(derive_seed(seed, "goniometer/shared-quantum",
//    light direction), quantum index); each cell's estimate and standard
//    error are as before (the quanta are independent; one quantum's λs are correlated).
//    With split_paths as well, a quantum is the sum of its branches (sim/scatterer/scatterer.h,
//    path splitting): x per cell is the sum of the branches that enter its cone, then squared;
//    split_reflections splits the reflected branch again at its next film (sim/tracer.h).
//    Standard errors from the per-quantum variance. Quantum q (counted over all passes) of
//    light direction g and wavelength k draws from Rng(derive_seed(seed, "goniometer/quantum",
//    g · nλ + k), q) (common/seed.h), and partial sums are combined in a fixed
//    order: results do not depend on thread count, and a resumed run equals an
//    uninterrupted one bit for bit.
//    With connect_lights (view_cone, shared paths or one wavelength, a scatterer that
//    can_connect_lights(): the tracer) a cell is the sum of two independent estimates, a
//    bidirectional estimator of two strategies combined by multiple importance sampling
//    (sim/tracer.h, "Connections to collimated lights"):
//     - light side: the photon quanta above with BranchOptions::connected_light_side. A path whose
//       one diffuse event the light reached straight (after straight films) counts with the
//       balance heuristic's w_L = n_L ρ / (n_L ρ + n_D), every other path (the film reflections R,
//       the specular chains between barbules, for which no diffuse event can aim at a detector,
//       and paths with two diffuse events or more) with 1.
//     - detector side: per view direction v and pass, connected_quanta_per_pass walks, each in a
//       direction ω drawn over C(ω_o) by projected solid angle, start on the top plane at x with
//       density p(x | ω) (below) and connect at their first diffuse event to each light direction
//       paired with v. A connection to light j that enters within the beam's footprint F_j (a
//       point y of the top plane whose offset from the beam's axis through the origin, across ω_i,
//       is at most the beam radius r) adds
//           x_j = w_D · w / (π r² p(x | ω)),   w the connection's LightConnection weight,
//       to cell (ω_i,j, ω_o), w_D = n_D / (n_L ρ + n_D). Why: the detector sees radiance
//       L(x, ω) = w E⊥ from the lit paths, so Φ(C) = ∫∫ L cos θ dω dx is estimated by
//       L P(ω_o) / p(x | ω), and f̄ = Φ(C) / (E⊥ π r² P(ω_o)) (the beam carries E⊥ π r²), which
//       is w / (π r² p(x | ω)).
//     - the weights: n_L = quanta_per_pass, n_D = connected_walks_per_pass(), and for one path
//       ρ = p_L / p_D = g cos θ_l sin²α cos θ_v / (π r² p(x | ω)), with g cos θ_l the light
//       side's factor at the diffuse event (LightConnection::lit_diffuse_density, the same as
//       SpectralScatterEvent's) and (x, ω) where the detector side's walk for that path starts
//       (for a light-side path: its exit point and ω_o). w_L + w_D =
//       1 for every path both sides make, so the sum is unbiased. On the rock dove's bench (α = 5°,
//       r = 60 µm, 2000 quanta and 320 walks, g = 0.25) ρ is about 0.005 where the widened
//       footprints overlap (π r² p ≈ 0.2), so w_L is about 3 %: the connections carry those paths.
//       p(x | ω) = p(x) = (1 − ε) g(x) + ε s / (2π (s² + |x|²)^{3/2}), the same for every ω of the
//       cone: g piecewise constant on a grid of r/8 cells, each cell the mean over the m lights of
//       1[c ∈ E_j] / |E_j| at its centre c, averaged over the cone's axis and four directions on
//       its rim, normalised. E_j: where a walk along −ω sees light j's beam at the depths 0 … D of
//       the scene (PathTracing::depth_um()): the footprint ellipse (semi-axes r/cos θ_i + d along
//       the light's azimuth and r + d across, d = r: room for the light's lateral travel in the
//       patch) swept by h (t_ω − t_i), h ∈ [0, D], t = ω_xy/ω_z (a capsule in the ellipse's unit
//       coordinates). The heavy-tailed density over the whole plane (s = 2r + D, ε = 0.1) gives
//       every start that could connect into a footprint p > 0 (unbiased for any scene, whatever
//       its extent).
//       Stratified starts: a view's walks come in blocks of 64 (of a pass's walks, in order).
//       Walk i of a block takes point i of the block's Owen-scrambled Sobol' group
//       (sim/scatterer/stratified.h): dimensions 0 and 1 through g's inverse CDF (rows, then the
//       column within the row) for its start on the grid, 2 and 3 for its direction in the cone.
//       Each walk alone has the densities above, and the block's starts cover the grid evenly, so
//       how many of them see a light's footprint hardly varies (on the rock dove that count was
//       most of the connections' variance). Walk q of view v draws from
//       Rng(derive_seed(seed, "goniometer/connected-quantum", v), q), the block that starts at
//       walk b from Rng(derive_seed(seed, "goniometer/connected-block", v), b).
//    The light side's standard error is its per-quantum sample variance; the detector side's is
//    the spread of its independent blocks' sums (the walks within a block are not independent):
//    σ² = Σ_b (S_b − n_b m)² / n_b / (B − 1) over B blocks of n_b walks, the mean's variance σ²/N
//    (infinite with one block). The cell's is their quadrature sum (the halves are independent).
//    Lobes likewise. (Until 2026-12-01 the halves partitioned the paths, w_L ∈ {0, 1}; later that
//    day the starts, drawn until then one by one from a mixture of the capsules aimed at each ω,
//    became the stratified blocks. Checkpoints of the earlier runs do not resume into this one.)
//  - eval: for scatterers that can evaluate f, the cell's average by cubature; its error
//    is estimated against the rule with half the rings. Deterministic. view_cone: a
//    product rule over the detector cone (cosine-weighted; `eval_rings` Gauss rings in
//    projected area × 2·rings azimuths). both_cones: the same product rule on the unit
//    disc mapped onto both cones' ellipses (equal Jacobian, so the disc weights are the
//    projected-solid-angle weights) and taken as a double sum, (2·rings²)² evaluations of
//    f per cell and wavelength (1024 at the default 4 rings): fine for smooth models,
//    expensive for Huang's. Narrow lobes (Huang's R) need more rings than smooth ones.
//  automatic picks eval when available.
#pragma once

#include <atomic>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

#include "common/interrupt.h"
#include "sim/scatterer/scatterer.h"
#include "virtual_gonio/direction_sets.h"
#include "virtual_gonio/pass_checkpoint.h"
#include "virtual_gonio/pass_loop.h"
#include "virtual_gonio/record/png_image.h"

namespace plumage::gonio {

enum class Estimator { automatic, photon, eval };

// See "Aperture" above. Study files: aperture = "view_cone" | "both_cones".
enum class Aperture { view_cone, both_cones };
const char* to_string(Aperture aperture);
// InputError naming `key` (e.g. "[goniometer] aperture") unless text is one of the names.
Aperture parse_aperture(std::string_view text, std::string_view key);

// The direction at the point (d1, d2) of the unit disc (d1² + d2² <= 1) for the cone of
// half-angle `half_angle_rad` around the unit vector `axis` (axis.z > sin(half_angle)):
// uniform points of the disc give directions distributed over the cone by projected solid
// angle, density cos θ / (π sin²α cos θ_axis). See "Aperture" above.
Vec3d cone_direction_by_projected_area(const Vec3d& axis, double half_angle_rad, double d1,
                                       double d2);
// The same from two numbers of [0, 1): the disc's point at radius √u and angle 2πv.
Vec3d cone_direction_from_square(const Vec3d& axis, double half_angle_rad, double u, double v);
// The same with a point uniform in the disc from two uniforms of rng (radius first).
Vec3d draw_cone_direction_by_projected_area(const Vec3d& axis, double half_angle_rad, Rng& rng);

struct GoniometerConfig {
    std::string direction_set = "custom";
    std::vector<DirectionPair> pairs;
    std::vector<double> wavelengths_nm = {550.0};
    double detector_half_angle_rad = 0.0436;  // 2.5°
    double beam_radius_um = 50.0;
    std::uint64_t seed = kDefaultSeed;
    Estimator estimator = Estimator::automatic;
    Aperture aperture = Aperture::view_cone;
    // Photon estimator, scatterers with path_tracing() (the tracer), 2 … 64 wavelengths:
    // one path per quantum for all wavelengths (sim/tracer.h); otherwise ignored.
    bool share_wavelength_paths = false;
    // With shared paths (or one wavelength) and a scatterer that splits paths (the
    // tracer): each quantum split at its first film event into a reflected and a transmitted
    // branch (sim/tracer.h, "Splitting"); otherwise ignored.
    bool split_paths = false;
    // With split_paths: the reflected branch splits again at its next event if that is a film
    // (BranchOptions::split_reflections), so that every quantum whose first reflection meets
    // another film carries the chain of two reflections; otherwise ignored.
    bool split_reflections = false;
    // With shared paths (or one wavelength) and a scatterer that splits paths: this share
    // of its paths' first diffuse directions aimed at the light direction's detector cones
    // (sim/tracer.h, "Guided diffuse reflection"), in [0, 1); 0: none.
    double guided_fraction = 0.0;
    // With shared paths (or one wavelength) and a scatterer that splits paths: at each
    // path's first diffuse event one branch by the cosine law and this many aimed within the
    // light direction's detector cones (sim/tracer.h, "Guided diffuse branches"), in place of
    // guided_fraction (set one of the two). 0 … 3; 0: none.
    std::size_t guided_branches = 0;
    // Connected lights ("Estimators" above): detector-side walks that connect to the lights at
    // their first diffuse event, weighed against the photon quanta by the balance heuristic.
    // Needs aperture view_cone, beam_radius_um > 0, shared paths (or one wavelength) and a
    // scatterer that can_connect_lights() (InputError naming the key otherwise).
    bool connect_lights = false;
    // Detector-side walks per view direction and pass; 0: quanta_per_pass.
    std::uint64_t connected_quanta_per_pass = 0;
    std::uint64_t connected_walks_per_pass() const {
        return connected_quanta_per_pass > 0 ? connected_quanta_per_pass : quanta_per_pass;
    }
    std::uint64_t quanta_per_pass = 20000;  // per light direction and wavelength
    int max_passes = 100;
    double time_budget_s = std::numeric_limits<double>::infinity();
    double target_relative_error = 0.0;  // stop once the estimated relative RMS error is below
    // The cells that carry signal, over which the estimated relative RMS error (convergence
    // table, target) is taken: value > 0 and value >= signal_fraction × the mean of all cells at
    // the same wavelength, judged on the current estimate at every pass (the record stores the
    // final set). 0: every cell with a positive value (the historical rule).
    double signal_fraction = 0.0;
    int eval_rings = 4;  // eval estimator: cubature rings (see above)
    // eval estimator, adaptive: 0 keeps the fixed rule of eval_rings. Above 0, per cell the
    // rings are doubled (eval_rings, 2·eval_rings, … up to eval_max_rings) until two doublings
    // in a row each move the value by at most HALF of eval_tolerance × |the value|: one
    // agreement can be chance (on Huang's R lobe a 4- and an 8-ring rule agreed to 0.24 % and
    // were both 1.4 % off), and the factor 2 keeps the finer rule's true error within
    // eval_tolerance (tests/analysis/huang2022_test.cpp: against a rule four times finer). The
    // error stated is the last difference. So a model's values are converged, not only
    // estimated, and a comparison's floor never has to carry them. A cell that reaches
    // eval_max_rings keeps its larger stated error. A scatterer that evaluates its lobes apart
    // (Scatterer::evaluates_lobes_apart: Huang's model) is refined lobe by lobe, each to half
    // the tolerance of its own value, and a settled lobe is no longer evaluated: the same bound
    // on the sum, and Huang's costly TRT quadrature stays at the rings it needs while the edges
    // of its R lobe take 64 (4.4× fewer TRT evaluations on the Filip set; the error stated is
    // the sum of the lobes' last differences).
    double eval_tolerance = 0.0;
    int eval_max_rings = 64;
    std::string config_text;  // the study text, for provenance

    void validate() const;  // InputError naming the field
};

struct BrdfRecord {
    GoniometerConfig config;
    std::string scatterer;
    std::vector<std::string> lobes;
    Estimator estimator_used = Estimator::photon;
    bool wavelength_paths_shared = false;  // share_wavelength_paths took effect
    bool paths_split = false;              // split_paths took effect
    bool reflections_split = false;        // split_reflections too
    bool diffuse_guided = false;           // guided_fraction or guided_branches took effect
    bool lights_connected = false;         // connect_lights took effect
    // Row-major [pair][wavelength]; lobe_values [lobe][pair][wavelength], 1/sr.
    std::vector<double> value, standard_error, lobe_values, lobe_standard_error;
    std::vector<std::uint8_t> signal_cells;  // [pair][wavelength]: 1 if in the error's set
    std::vector<ConvergenceRow> convergence;
    int passes = 0;
    std::uint64_t quanta = 0;
    double wall_time_s = 0.0;
    double cpu_time_s = 0.0;  // process CPU time (all threads), summed over resumed runs as wall
    int threads = 1;
    // Stopped by an interrupt with a checkpoint: the completed passes (the checkpoint holds
    // them). Without a checkpoint an interrupt throws Interrupted (common/interrupt.h) instead.
    bool interrupted = false;
    double detector_solid_angle_sr = 0.0;

    double at(std::size_t pair, std::size_t wavelength) const {
        return value[pair * config.wavelengths_nm.size() + wavelength];
    }
    double error_at(std::size_t pair, std::size_t wavelength) const {
        return standard_error[pair * config.wavelengths_nm.size() + wavelength];
    }
};

// Checkpoints (RunControl::checkpoint): the pass loop's (virtual_gonio/pass_checkpoint.h). The
// goniometer's parts: the build, the study file (GoniometerConfig::config_text), the instrument's
// configuration (directions, wavelengths, seed, quanta per pass, estimator and its options) and
// RunControl::checkpoint_inputs (the content hash of every input file the scene was built from).
struct RunControl {
    // Polled between chunks of work; by default the process-wide flag that a
    // ScopedInterruptHandler sets on SIGINT/SIGTERM (never set while none is installed).
    const std::atomic<bool>* interrupt = &interrupt_flag();
    std::function<void(const ConvergenceRow&)> on_pass;     // after each completed pass
    std::function<void(const BrdfRecord&)> on_pass_record;  // the same moment, with the values
    std::filesystem::path checkpoint;  // empty: none; else resumed from and written after each pass
    std::vector<CheckpointPart> checkpoint_inputs;  // beyond the configuration: see above
    bool progress = false;                          // progress line on stderr
};

BrdfRecord measure_brdf(const Scatterer& scatterer, const GoniometerConfig& config,
                        const RunControl& control = {});

// Filip et al. 2024, Fig. 7: the "BRDF fingerprint" of a light-major pair list (pair =
// light × views + view): one block of `block` × `block` pixels per pair, rows the light
// directions, columns the view directions, each the pair's colour under D65 (a flat
// spectrum is neutral on any wavelength grid). exposure <= 0: brightest cell → Y = 1.
record::RgbImage brdf_fingerprint(const BrdfRecord& record, int lights, int views, int block = 4,
                                  double exposure = 0.0);

// Self-describing HDF5 (RECORD.md); written under a temporary name and renamed.
void write_brdf_record(const BrdfRecord& record, const std::filesystem::path& path);

}  // namespace plumage::gonio
