// Physical optics that lets light through (a GO–PO hybrid, level 3 of physics,
// docs/architecture.md): the far field of 2D cross-sections whose interfaces transmit, such as a
// keratin film over a separate melanin layer with an air gap of varying thickness, or a melanin
// body thin enough to let a tenth of the light through. physical_optics_2d.h radiates only from
// the lit outer surface and makes every body opaque; here the incident field is carried through
// each transparent interface by rays (geometric optics, with the interface's complex Fresnel or
// film coefficients and the phase of every path), and every interface the rays light radiates,
// inner ones included. Frame, polarisations, directions, units and the normalisation
// σ = k/(8π)|U|² are physical_optics_2d.h's, so the two compare point by point.
//
// Scene. The curves of a CrossSection2d, each with air (the ambient) on its + side (its outward
// normal's side) and its stack's films under it:
//  - a curve whose substrate is air (index exactly 1) is a free-standing film, a SHEET: air on
//    both sides (a keratin cortex over an air gap; open or closed);
//  - any other curve bounds a BODY of its substrate material (melanin, keratin): the body's
//    curves must close it, and a ray inside travels in that material, absorbing, until it meets
//    one of them from inside.
// Nested bodies (a medulla inside a cortex: a curve with a body on its + side) are left out: a
// ray that meets a curve from a side the scene does not allow ends there, counted as truncated.
//
// Derivation. Outside all bodies the total field is the incident wave plus the radiation of the
// boundary values of the total field on every face that touches the ambient (the exterior
// Green's representation, physical_optics_2d.h's Kirchhoff integral). In the GO approximation
// the field on a face is a sum of local plane waves, and a wave u of travel direction d at a
// face of unit normal n_f (pointing into the ambient) contributes
//     u (ω_s + d)·n_f e^{−ik ω_s·r'} ds'            to U(θ_s)
// (its value and normal derivative in the integrand of physical_optics_2d.h). So:
//  - where the incident wave lights an outer face directly, the existing physical-optics term,
//    [(1 + r) ω_s·n − (1 − r) ω_i·n] u_inc, computed on the surface samples with the exact
//    incident field (physical_optics_2d.cpp's kernel); on a sheet the wave it transmits leaves
//    through the other face, so the term becomes [(1 + r − t) ω_s·n − (1 − r − t) ω_i·n] u_inc
//    (the shadow of a sheet is partial: t = 1, r = 0 radiates nothing);
//  - every later wave that reaches an ambient face (through a sheet, after a reflection,
//    leaving a body) radiates there in the same way, its incoming and reflected (and, through a
//    sheet, transmitted) parts together: u [(1 + r − t) ω_s·n_f − (1 − r − t) w·n_f], w = −d
//    (t = 0 on a body, whose transmitted wave goes inside);
//  - a wave leaving a body radiates its exit wave: u t (ω_s + d_out)·n.
// Each wave in the ambient is so counted at both ends of its path (where it starts and where it
// ends on a face); a wave that leaves for infinity only where it starts.
//
// Rays. The incident beam is cut into parallel rays launch_step apart across the scene's
// shadow; each ray carries its complex amplitude (the incident phase at its launch, k n L along
// each leg, every interface's coefficient), its power, and its width as planar interfaces would
// leave it (a refraction scales it by cos θ_t / cos θ_i). At each interface it splits into the
// reflected and the transmitted ray; a path ends after max_events interfaces or below min_power
// of its launch power (counted in truncated_width_um). Where the rays light a face, the face's
// element is a ray's footprint there: half the distance between the hits of its two neighbours
// (launch index ± 1) that took the same path (the same sequence of curves, sides and branches);
// the field is the ray's amplitude times √(planar width / actual width), which carries the
// spreading and focusing of curved interfaces (GO's intensity law; finite at a caustic, where
// the element's strength √(width) goes to 0). An element radiates with its phase gradient along
// the face, integrated exactly across its footprint (a sinc), as physical_optics_2d.h's pieces.
//
// Interfaces. The coefficients r and t of a curve's stack are computed at the local Snell
// invariant β (the wave's tangential wavenumber over k) by the transfer matrix with any complex
// incidence medium (stack_response, below; multilayer.h keeps its ambient lossless): from the +
// side air / films / substrate; from a body's inside, or a sheet's − side, the reverse. The films
// are not drawn: the curve is the stack's top, and the coefficients are moved to it (a wave that
// would have crossed the films' thickness D in the medium q: r e^{−2ik q D}, t e^{−ik q D}), so
// phases are those of the planar stack; the lateral shift D tan θ is left out. In an absorbing
// body the ray's direction follows Re q and its amplitude e^{ik ν L} with ν = (q Re q + β²) /
// √(β² + (Re q)²), which gives a planar slab the transfer matrix's phase and attenuation exactly
// (tests), and differs from n + ik by O(k²) elsewhere.
//
// Sampling. The rays sample the field on the inner faces as the surface samples do the lit
// surface, a step (λ/10) apart by default. Halving or quartering the launch step moves σ_scat,
// σ_ext, σ_abs and the back-scattered power of tests/reference/po_transmission's cases by up to
// 2 %, with no trend (the rays fall differently on the caustics of the curved faces), and a
// specular spike in a deep interference null by up to 16 %: the level's own sampling error,
// below its errors against full wave there (README.md of that folder). min_power stays at 1e-6:
// a path of that power carries a thousandth of the incident amplitude, half a per cent of a
// weak lobe's (a melanin slab's R ≈ 0.04), and the coherent sum adds such paths.
//
// Powers (µm, over the incident intensity): extinction by the optical theorem, −Re U(forward)
// (physical_optics_2d.h's normalisation: a black strip gives 2W); scattering ∫σ dθ over the
// circle; absorption by the rays' power book (1 − R − T at each interface, the loss along each
// leg in a body). For a planar strip, slab or film the three obey extinction = scattering +
// absorption to the strip's edge terms (tests).
//
// Kept: every path of up to max_events interfaces, reflections and transmissions in any order
// (the film–gap–melanin multiple reflections, light through a melanin body and back). Left out:
// waves reflected or transmitted at grazing angles beyond TIR's evanescent coupling; edge and
// creeping-wave diffraction (as physical_optics_2d.h); the films' lateral shift; nested
// bodies; the interfaces' curvature within a footprint (planar stack per element); rays that
// meet a curve within a sampling step of another (refused, below). Only in-plane incidence
// (cos_elevation = 1): the 2.5D extrusion is physical_optics_25d.h's.
//
// Where it is the wrong level: a gap that follows the film (a barbule whose cortex, gap and
// melanin are offsets of one another) is the planar stack of physical_optics_2d.h, which keeps
// the stack's interference exactly; the rays here carry film and gap as separate interfaces and
// miss the depth of its minima (the rock dove's endless row: band-mean R +38 % against full
// wave, where the planar stack is +5 %; docs/full_wave.md, "Physical optics through interfaces").
// A film of a few wavelengths (6.4 µm) tilted against a separate layer under it keeps the powers
// but not the layer's specular spike seen through the film: 21–37 % low in TM at tilts of 3–12°,
// where the same film parallel to the layer is within 8 %. It is the film's ends (its sheet's
// sharp edges against the layer's reflected beam, part of which passes beside a tilted film):
// 19.2 µm long and tilted by 3° or (lifted) by 6°, the film is within every one of issue 36's
// targets (the reference's README, tests/reference/po_transmission, "Wider"). Where the specular
// window is a dim fringe of two reflections (the film's own and the layer's through it), the
// level's window is darker than full wave's: the arc over its layer, 19 µm wide, misses its
// spike by 16–28 % as drawn, in its fringe's dark half, and is within target lifted by 0.08–0.16
// µm onto its bright half; at every lift its spike is within 11 % of the fringe's brightest.
// Judged on such wide sections (that arc, and the 1 µm melanin ellipse 10 µm long) at 450, 550
// and 650 nm, the level is within issue 36's targets on 62 of 72 quantities, and the other 10 are
// the arc's dim windows (check_wide.csv there).
//
// Refused (InputError naming the limit): two curves closer than the sampling step where one
// faces the other (an inner interface the surface sampling cannot separate), anything
// physical_optics_2d.h refuses, a scene reaching more than kSinCosLimit/(2π) ≈ 2.5·10⁵
// wavelengths from the origin (common/fast_trig.h's range), a launch step that would cut the
// beam into 2^32 rays or more, and the options outside the table.
//
// Cost: the rays (a cast per leg through ChordIndex2d) and the far-field sum, O(elements ×
// angles), each term a branch-free sin/cos (common/fast_trig.h) so that the sum runs in SIMD
// lanes; the direct term's lit samples are elements of the same sum. TE and TM together
// (hybrid_far_field_pair) share both. bench/README.md has the times.
//
// Parameter table:
//  | name            | unit | range                                              |
//  |-----------------|------|----------------------------------------------------|
//  | step_um         | µm   | 0 (λ/10) or in (0, λ/10]                           |
//  | launch_step_um  | µm   | 0 (the surface step) or in (0, step]               |
//  | max_events      | 1    | in [1, 64]                                         |
//  | min_power       | 1    | in [0, 1)                                          |
//  | circle_angles   | 1    | 0 (scattering not integrated) or >= 360            |
#pragma once

#include <complex>
#include <cstddef>
#include <span>
#include <vector>

#include "sim/optics/fresnel.h"
#include "sim/optics/multilayer.h"
#include "sim/wave/surface/physical_optics_2d.h"

namespace plumage::sim::wave {

struct HybridOptions {
    double step_um = 0.0;         // surface sampling, as PhysicalOpticsOptions::step_um
    double launch_step_um = 0.0;  // ray spacing across the beam; 0: the surface step
    int max_events = 16;          // interfaces on one path
    double min_power = 1e-6;      // of a ray's launch power: a path below it ends
    int circle_angles = 7200;     // for scattering_width_um; 0: not computed (NaN)
};

struct HybridFarField2d {
    double k = 0.0;                        // µm⁻¹
    std::vector<std::complex<double>> u;   // U(θ_s) at the angles asked
    std::vector<double> sigma_um_per_rad;  // k/(8π)|U|²
    double scattering_width_um = 0.0;      // ∫σ dθ over the circle
    double extinction_width_um = 0.0;      // optical theorem, −Re U(θ_i + π)
    double absorption_width_um = 0.0;      // the rays' power book
    double truncated_width_um = 0.0;       // power in paths ended by max_events or min_power
    double beam_width_um = 0.0;            // the launched beam's width (its power)
    std::size_t rays = 0, elements = 0;    // launched rays; radiating elements of all paths
};

// The far field and widths of a cross-section with transparent interfaces (header). OpenMP over
// the rays and the angles; results do not depend on the thread count.
HybridFarField2d hybrid_far_field(const CrossSection2d& section, const Incidence2d& incidence,
                                  std::span<const double> theta_s_rad,
                                  const HybridOptions& options = {});

// TE and TM at once (in-plane incidence): one set of rays carries both polarisations' amplitudes
// and one sum serves both (the paths and the phases do not depend on the polarisation), about
// half the cost of two calls. A path ends when both polarisations' powers are below min_power,
// so each result keeps at least the paths a call for its polarisation alone keeps (the two
// differ by less than that call's truncated_width_um).
struct HybridFarFieldPair {
    HybridFarField2d te, tm;
};
HybridFarFieldPair hybrid_far_field_pair(const CrossSection2d& section, double lambda_nm,
                                         double theta_i_rad, std::span<const double> theta_s_rad,
                                         const HybridOptions& options = {});

// A barbule with its air gap as the hybrid sees it (fullwave::barbule_row's cell): a melanin core,
// the ellipse of semi-axes (A − d − g, b·A − d − g), a body that may transmit; around it, the
// core's outward offset by g + d as a closed keratin sheet of thickness d (its films over air),
// so that the gap g between the film and the core is uniform. InputError when the core would
// vanish (b·A <= d + g) or a value is not finite and positive (g may be 0: then the film lies on
// the core and the arc of physical_optics_2d.h's barbule_arc is the better model).
CrossSection2d barbule_with_gap(double semi_major_um, double b, double film_um, double gap_um);

// The cells of a row without jitter (count, spacing, direction, tilt as physical_optics_2d.h's
// rows) as one cross-section, for hybrid_far_field. InputError for a jittered row (its
// realisations are physical_optics_2d.h's business).
CrossSection2d row_cross_section(const Row2d& row);

// r and t (electric-field amplitudes, fresnel.h's signs) of a planar stack lit from a medium
// that may absorb: n_in, films top to bottom (as met by the wave), n_out, at the Snell invariant
// β (real; q = √(n² − β²) on the decaying branch in every medium). r is referred to the first
// interface, t to the last. Powers as fresnel.h's fluxes; for an absorbing incidence medium
// they are the usual approximation (the incident and reflected waves' cross terms left out).
struct StackResponse2d {
    std::complex<double> r, t;
    double reflectance = 0.0, transmittance = 0.0;
    std::complex<double> q_in, q_out;
};
StackResponse2d stack_response(std::complex<double> n_in,
                               std::span<const optics::StackLayer> layers,
                               std::complex<double> n_out, double beta, double lambda_nm,
                               optics::Polarisation pol);

}  // namespace plumage::sim::wave
