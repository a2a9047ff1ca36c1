// Physical optics (Kirchhoff surface fields) for 2D cross-sections: the far field of barbule
// cross-sections and rows of them, with each surface element's planar film stack (level 3 of
// physics, docs/architecture.md). Ray optics + thin film (level 1) misses diffraction, which
// matters when a barbule is only a few wavelengths wide; this is the wave level for such barbules.
//
// Frame: x horizontal, z up; the structure is invariant along y. Directions are unit
// 2-vectors (x, z) pointing AWAY from the object (scatterer.h's convention): light comes from
// ω_i = (sin θ_i, cos θ_i), the far field is observed towards ω_s = (sin θ_s, cos θ_s),
// θ_s ∈ (−π, π]. A horizontal mirror sends θ_i to θ_s = −θ_i. Lengths µm, wavelengths nm
// (vacuum; the ambient is air, n = 1), angles rad.
//
// Polarisation (Polarisation2d of born_2d.h, here with y the invariant axis). TE: E along y,
// u = E_y, which is s-polarised for every surface normal in the x–z plane, so the local
// reflection coefficient is the stack's r_s. TM: H along y, u = H_y (p). The stack's r_p of
// fresnel.h, (n₂² q₁ − n₁² q₂)/(n₂² q₁ + n₁² q₂), is exactly the ratio of reflected to incident
// H_y (boundary conditions: H_y and ∂_z H_y / ε continuous give r_H = (q₁/ε₁ − q₂/ε₂)/(q₁/ε₁ +
// q₂/ε₂), the same expression; at normal incidence r_p = (n₂ − n₁)/(n₂ + n₁) = −r_s, as H flips
// relative to E on reflection). So TM uses r = r_p unchanged; no extra sign. Both transfer-
// matrix amplitudes are referred to the stack's top surface, which is the sampled curve.
//
// Derivation. Time dependence e^{−iωt}; the incident wave u_inc = e^{−ik ω_i·r}, unit
// amplitude, k = 2π/λ. Outside the body the scattered field is the Kirchhoff–Helmholtz
// integral over the surface C (outward normal n) with the 2D Green's function
// G = (i/4) H₀⁽¹⁾(k|r − r'|):  u_s(r) = ∫_C [u ∂G/∂n' − G ∂u/∂n'] ds'. In the far field
// G → (i/4) √(2/(πkR)) e^{i(kR − π/4)} e^{−ik ω_s·r'} and ∂G/∂n' → −ik (ω_s·n) G. Kirchhoff
// (physical optics): on the illuminated part u = (1 + r) u_inc and ∂u/∂n = (1 − r) ∂u_inc/∂n
// = −(1 − r) ik (ω_i·n) u_inc, with r the stack's amplitude at the local cos θ = ω_i·n; on the
// dark part u = ∂u/∂n = 0. Then
//     u_s → (i/4) √(2/(πkR)) e^{i(kR − π/4)} (−ik) U,
//     U(ω_s) = ∫_lit [(1 + r) ω_s·n − (1 − r) ω_i·n] e^{−ik (ω_i + ω_s)·r'} ds',
// and the differential scattering width (power per unit length through R dθ_s over the
// incident intensity; TE and TM alike, as |E|² and |H|² differ by the same impedance in
// both waves) is
//     σ(θ_s) = R |u_s|² = k/(8π) |U|²                          [µm/rad].
// Check: a flat strip of width W, reflection r, sends ∫σ dθ_s = |r|² W cos θ_i into its
// specular lobe (tests). The integrand splits as
//     [(ω_s − ω_i)·n] + r [(ω_s + ω_i)·n]  =  shadow part + reflected part:
// the shadow part is what a black body (r = 0) scatters, i.e. the forward wave that forms the
// shadow plus its edge diffraction (its integral over all angles is the projected width, the
// extinction paradox's second half); the reflected part is the reflected light. FarFieldPart
// picks either or the sum.
//
// Quadrature. Each curve is cut into N pieces of equal arc length ds ≤ step (step ≤ λ/10 in
// the ambient); each piece is one sample at its arc-length midpoint, with the analytic point
// and outward normal there. The phase is integrated exactly across the piece's tangent line:
//     ∫_piece e^{−ik q·r} ds ≈ ds e^{−ik q·r_j} sinc(k (q·t_j) ds/2),  q = ω_i + ω_s,
// exact for a straight piece (the flat strip's far field is then its closed form to rounding);
// on a curve the error is the sagitta's phase, k |q| ds²/(8ρ) ≤ (π/200) λ/ρ rad (|q| ≤ 2,
// ds ≤ λ/10). The sinc's argument is at most k · 2 · (λ/10)/2 = 2π/10 ≈ 0.63, where its Taylor
// series to x¹⁰ is exact to 1e-12.
//
// Illumination: a sample is lit when ω_i·n > 0 and the ray from it towards ω_i crosses no
// chord of any curve (its own piece's chord excluded). The chords are grouped 32 at a time
// (consecutive pieces are spatially close) under bounding boxes: a ray tests ~N/32 boxes and
// the chords of the few it enters, so N samples cost O(N²/32) slab tests (0.8 M for the
// 5000-sample benchmark row) with no build step, cheaper here than a uniform grid, whose cell
// size would have to adapt to rows that are long and thin.
//
// What physical optics leaves out (validity; state it with any result):
//  - outgoing visibility, by default: light reflected by a lit element towards ω_s is counted
//    even when another part of the cross-section (a neighbouring barbule) stands in its way.
//    This over-counts at grazing exit and along a row (tests: a row of three shells reflects
//    3.2–3.4× one shell over all angles, 3.0× within 60° of the zenith; with visibility
//    2.5–2.9×, as geometric optics under the same rule within 5 %; geometric_optics_2d.h is that
//    level, ray_optics_validity.h the comparison).
//    PhysicalOpticsOptions::outgoing_visibility removes it, at a cost (see there);
//  - multiple reflections between surfaces (barbule to barbule, or inside a concave part);
//  - transmission through the body: no light crosses the cross-section; the far side's
//    half-space holds only the shadow-forming wave and its diffraction, and the reflected part
//    there is ~0 for an opaque (absorbing melanin) body. physical_optics_hybrid_2d.h carries the
//    light through films in air and melanin bodies that transmit, and radiates from every
//    interface it lights;
//  - edge and creeping-wave diffraction beyond Kirchhoff's abrupt lit/dark boundary (the
//    Kirchhoff boundary is exact for a flat strip only in the paraxial sense);
//  - the stack is planar at each point (curvature radius ≫ film thickness and λ).
// Against full wave (Meep, tests/reference/barbule_2d/README.md "Against full wave";
// physical_optics_fullwave_test.cpp): for the 10.6 × 4.6 µm reference shell (θ_i 0° and 30°,
// TE/TM, 450–650 nm) the back hemisphere in 10° bins agrees to a relative L1 of 1.6–5.5 % and
// in power within 3 %, at or below Meep's own resolution error; only the grazing exits fed by
// the tips and creeping waves (bins with 1–4 % of the power) are off by up to 61 %. The
// forward lobe and C_sca agree within 4 % / 6 %, mostly low: PO's extinction is exactly 2W, Meep's
// exceeds it by up to 2.8 % (the edge term). A row of three, 0.4 µm apart: L1 2.4–8.2 %
// within 60° of θ_i, 4.3–18 % overall, the rest being the neighbours' blocking and multiple
// reflection at grazing exit. The 2.6 µm (4–6 λ) shell is outside PO: L1 53–83 %, its
// reflected power 0.17–0.79 of Meep's, its C_sca 0.55–1.06 (a resonant extinction).
// Reciprocity: r is taken at the incidence angle (by default), so σ(ω_i → ω_s) and
// σ(ω_s → ω_i) differ away from stationary (specular) points, and the lit/dark boundary of
// one direction is not that of the other; FresnelAngle::bisector is the symmetric variant.
//
// Rows: the cell is repeated `count` times at centres (m − (count − 1)/2)·spacing·direction,
// each rotated by the tilt μ (the rotation R(α): (x, z) ↦ (x cos α + z sin α, −x sin α +
// z cos α), i.e. about +y, as barbule.cpp's to_patch: Huang's barbule frame with u =
// (cos μ, sin μ) is mapped onto the patch frame, row along +x), then per cell jittered by a
// Gaussian rotation (σ_rot) and a Gaussian displacement (σ_pos per coordinate). The far field of
// one realisation is the coherent sum over all cells; σ is the incoherent mean over
// `realisations` (a row without jitter is computed once: its realisations are identical).
// Realisation m, cell c draws from Rng(derive_seed(seed, "wave/physical_optics_2d/jitter", m),
// c), three standard normals by Box–Muller (dx, dz, rotation): results do not depend on
// threads. Cells may overlap under large jitter; nothing checks it.
//
// Parameter table:
//  | name                   | unit | range                                                 |
//  |------------------------|------|-------------------------------------------------------|
//  | lambda_nm              | nm   | finite, > 0, in the materials' range                  |
//  | theta_i                | rad  | finite                                                |
//  | step_um                | µm   | 0 (use λ/10) or in (0, λ/10]                          |
//  | curve length           | µm   | >= the step                                           |
//  | radius of curvature    | µm   | >= the step everywhere on a curve                     |
//  | film thickness         | µm   | finite, >= 0                                          |
//  | count, realisations    | 1    | >= 1                                                  |
//  | spacing_um             | µm   | finite, >= 0                                          |
//  | tilt, jitter_rotation  | rad  | finite; jitter >= 0                                   |
//  | jitter_position_um     | µm   | finite, >= 0                                          |
#pragma once

#include <complex>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "geometry/elliptical_arc.h"
#include "sim/optics/material.h"
#include "sim/optics/multilayer.h"
#include "sim/scatterer/random.h"
#include "sim/wave/volume/born_2d.h"  // Polarisation2d

namespace plumage::sim::wave {

struct FilmLayer2d {
    std::shared_ptr<const optics::Material> material;
    double thickness_um;
};

// The planar stack under a curve: air above, films top to bottom, then the substrate.
struct SurfaceStack2d {
    std::vector<FilmLayer2d> films;
    std::shared_ptr<const optics::Material> substrate;
};

// An analytic curve r(t), t ∈ [t0, t1], with its unit outward normal (pointing into the air).
// A closed curve has point(t0) == point(t1).
struct Curve2d {
    std::function<Eigen::Vector2d(double)> point;
    std::function<Eigen::Vector2d(double)> normal;
    double t0 = 0.0, t1 = 1.0;
    SurfaceStack2d stack;
};

struct CrossSection2d {
    std::vector<Curve2d> curves;
};

// (a) A flat film strip of width W centred at the origin along x, normal +z.
CrossSection2d flat_strip(double width_um, const SurfaceStack2d& stack);
// (b) The barbule cell's cross-section (barbule.h): the arc carries keratin d over an air gap g
// over melanin (stack keratin d / air g / melanin).
CrossSection2d barbule_arc(const geometry::EllipticalArc& arc, double film_um, double gap_um);
// (c) The full-wave reference shape: a melanin elliptical core (semi-axes a_x, a_z, centred at
// the origin) in a keratin shell of thickness d; the outer surface is the core offset by d
// along its normal, closed; stack keratin d / melanin.
CrossSection2d coated_ellipse(double a_x_um, double a_z_um, double shell_um);

// One surface sample: midpoint of a piece of arc length ds.
struct SurfaceSample2d {
    Eigen::Vector2d point, normal, tangent;
    double ds_um;
    int curve;  // index into CrossSection2d::curves (the stack)
};

// Samples plus the chords used for shadowing (chord j runs a[j] → b[j], piece j's own).
struct SampledCrossSection2d {
    std::vector<SurfaceSample2d> samples;
    std::vector<Eigen::Vector2d> chord_a, chord_b;
};

// Cuts every curve into pieces of equal arc length <= step_um. InputError when a curve is
// shorter than the step or its radius of curvature drops below it (naming value and limit).
SampledCrossSection2d sample_cross_section(const CrossSection2d& section, double step_um);

// The step a sampling of this wavelength uses: step_um, or λ/10 when it is 0. InputError when
// the wavelength is not finite and positive or the step exceeds λ/10 (naming both).
double physical_optics_step(double lambda_nm, double step_um);

// Ray casts against the chords of a sampled cross-section (the lit test's, above): chords grouped
// 16 at a time under bounding boxes, the boxes in a binary tree (split at the median of their
// centres; a cast descends nearer child first and skips boxes beyond its nearest hit, so it costs
// about the logarithm of the boxes plus the chords near the hit). Keeps its own copy of the
// chords: `sampled` may go after construction.
class ChordIndex2d final {
public:
    explicit ChordIndex2d(const SampledCrossSection2d& sampled);
    struct Hit {
        std::size_t chord;  // index of the chord (= its sample)
        double t;           // distance along the unit direction
    };
    // Whether the ray o + t d, t > 0, crosses any chord but `skip` (the sample's own piece).
    bool blocked(const Eigen::Vector2d& o, const Eigen::Vector2d& d, std::size_t skip) const;
    // The nearest chord the ray crosses (`skip` excluded), if any.
    std::optional<Hit> first_hit(const Eigen::Vector2d& o, const Eigen::Vector2d& d,
                                 std::size_t skip) const;

private:
    template <bool kFirst>
    std::optional<Hit> cast(const Eigen::Vector2d& o, const Eigen::Vector2d& d,
                            std::size_t skip) const;
    static constexpr std::size_t kNoBlock = static_cast<std::size_t>(-1);
    struct Node {
        Eigen::Vector2d lo, hi;
        std::size_t left = 0, right = 0;
        std::size_t block = kNoBlock;  // a leaf's block, else kNoBlock
    };
    std::size_t build(std::vector<std::size_t>& order, std::size_t from, std::size_t to);
    std::vector<Eigen::Vector2d> lo_, hi_;   // a box per block of chords
    std::vector<double> ax_, az_, ex_, ez_;  // chord j from (ax, az) along (ex, ez); whole blocks
    std::vector<Node> nodes_;                // a tree of the boxes, root first
};

// Per sample: 1 when lit from omega_i (see the header), else 0.
std::vector<unsigned char> illuminated(const SampledCrossSection2d& sampled,
                                       const Eigen::Vector2d& omega_i);

// Per ray m: 1 when the ray from sample from[m] towards directions[m] (unit) crosses no chord
// (that sample's own piece excluded): the lit test's ray cast for any direction (geometric
// optics' outgoing visibility, geometric_optics_2d.h). OpenMP over the rays.
std::vector<unsigned char> rays_unblocked(const SampledCrossSection2d& sampled,
                                          std::span<const std::size_t> from,
                                          std::span<const Eigen::Vector2d> directions);

struct Row2d {
    CrossSection2d cell;
    int count = 1;
    double spacing_um = 0.0;
    Eigen::Vector2d direction = Eigen::Vector2d::UnitX();  // unit; row axis
    double tilt_rad = 0.0;                                 // μ, every cell
    double jitter_position_um = 0.0;                       // σ per coordinate
    double jitter_rotation_rad = 0.0;                      // σ
    int realisations = 1;
    std::uint64_t seed = kDefaultSeed;
};

enum class FarFieldPart { total, reflected, shadow };

struct Incidence2d {
    double lambda_nm;
    double theta_i_rad;
    Polarisation2d polarisation = Polarisation2d::te;
    // Conical incidence (the 2.5D extrusion, physical_optics_25d.h): the cosine of the angle
    // between the 3D incident direction and the x–z plane, in (0, 1]. The transverse problem
    // then has k cos_elevation in every phase and σ, and each stack sees the 3D local angle,
    // cos θ_local = cos_elevation · (ω_i·n); the stack's wavelength stays λ.
    double cos_elevation = 1.0;
};

// Where the stack's r is evaluated. incidence: at ω_i·n (Kirchhoff's choice, the default).
// bisector: at the local angle of the facet that mirrors ω_i into ω_s, whose normal is
// h = (ω_i + ω_s)/|ω_i + ω_s|: cos θ_local = ω_i·h = |ω_i + ω_s|/2 (times cos_elevation in
// 2.5D), as microfacet models evaluate Fresnel; on samples lit from ω_i AND facing ω_s
// (ω_s·n > 0); with the reflected part only (InputError otherwise). Its integrand
// r(ω_i·h) (ω_i + ω_s)·n e^{−ik(ω_i + ω_s)·r} is symmetric in ω_i ↔ ω_s, so for one convex curve
// (where both masks are just n·ω > 0) σ is exactly reciprocal; at a specular (stationary) point
// h = n, ω_i·h = ω_i·n and it equals the default (a flat strip reflects R(θ_i) W cos θ_i with
// either: tested). One transfer matrix per curve and angle.
enum class FresnelAngle { incidence, bisector };

struct PhysicalOpticsOptions {
    double step_um = 0.0;  // 0: λ/10; a coarser step is refused
    FarFieldPart part = FarFieldPart::total;
    FresnelAngle fresnel = FresnelAngle::incidence;
    // Drop a lit sample's radiation towards ω_s when it faces away (ω_s·n <= 0) or a chord
    // stands between it and ω_s (the same ray cast as the lit test, once per sample and angle:
    // O(N² angles/32) box tests, ~100× the sum's cost for a row). Reflected part only. With
    // the bisector r the reflected integrand and its mask (lit from ω_i, seen from ω_s) are then
    // symmetric in ω_i ↔ ω_s for any cross-section: exact reciprocity, rows included.
    bool outgoing_visibility = false;
};

// σ(θ_s) in µm/rad at each theta_s (rad), for a unit-intensity plane wave. OpenMP over the
// angles (each angle's sum is sequential: identical for any thread count).
std::vector<double> scattering_width(const Row2d& row, const Incidence2d& incidence,
                                     std::span<const double> theta_s_rad,
                                     const PhysicalOpticsOptions& options = {});
std::vector<double> scattering_width(const CrossSection2d& section, const Incidence2d& incidence,
                                     std::span<const double> theta_s_rad,
                                     const PhysicalOpticsOptions& options = {});

// The complex far-field integral U(θ_s) of one already sampled and placed cross-section (σ =
// k/(8π)|U|²); lower-level entry for tests and for callers that reuse a sampling.
std::vector<std::complex<double>> far_field_integral(const CrossSection2d& section,
                                                     const SampledCrossSection2d& sampled,
                                                     const Incidence2d& incidence,
                                                     std::span<const double> theta_s_rad,
                                                     const PhysicalOpticsOptions& options = {});

// The cells of one realisation of a row, placed (rotation, jitter) in the row frame.
SampledCrossSection2d place_row(const Row2d& row, const SampledCrossSection2d& cell,
                                int realisation);

// The lit samples of one placed cross-section for one incidence, with their stack amplitudes:
// U(θ_s) for any θ_s then costs one pass over them (far_field_at; σ = k/(8π)|U|² with this k).
struct FarFieldKernel2d {
    double k = 0.0;  // transverse wavenumber, µm⁻¹
    Eigen::Vector2d wi = Eigen::Vector2d::UnitY();
    double lambda_nm = 0.0, cos_elevation = 1.0;
    Polarisation2d polarisation = Polarisation2d::te;
    std::vector<double> px, pz, nx, nz, tx, tz, ds;
    std::vector<int> curve;
    std::vector<std::size_t> index;          // the sample's index in the SampledCrossSection2d
    std::vector<std::complex<double>> a, b;  // amplitude = a ω_s·n + b, ds included
    std::vector<std::vector<optics::StackLayer>> layers;
    std::vector<std::complex<double>> substrate;
};
FarFieldKernel2d prepare_far_field(const CrossSection2d& section,
                                   const SampledCrossSection2d& sampled,
                                   const Incidence2d& incidence, FarFieldPart part,
                                   bool bisector = false);
std::complex<double> far_field_at(const FarFieldKernel2d& kernel, double theta_s_rad);
// far_field_at of two kernels prepared on the same samples for the same wavelength and incidence
// that differ in their amplitudes only (TE and TM): one phase, sinc and sin/cos per sample and
// angle serve both, half the cost of two passes. InputError when the kernels' samples or k
// differ. OpenMP over the angles (each sum sequential: identical for any thread count).
void far_field_pair(const FarFieldKernel2d& first, const FarFieldKernel2d& second,
                    std::span<const double> theta_s_rad, std::vector<std::complex<double>>& u_first,
                    std::vector<std::complex<double>>& u_second);

}  // namespace plumage::sim::wave
