// The spongy-keratin study (`study = "spongy"`): the structural colour of spongy keratin
// (channel-type, or packings of air spheres) computed from the volume itself. For every keratin
// fraction f and length scale (channel Λ or sphere radius a): a generated volume
// (geometry/spongy_volume.h), its scattering tables at every wavelength of the spectrum by the
// study's route (first Born on the indicator power spectrum, or Mie × S(q) for sphere packings;
// sim/wave/volume/born_medium.h), a slab of that medium (sim/scattering_slab.h) traced by the
// tracer at normal incidence; for the base case also at other incidence angles, and the
// geometric-optics baseline: the base volume's own keratin/air mesh, tiled into a slab of about
// the same thickness on the same backing and traced as interfaces (sim/scattering_slab.h's
// tiled_volume_slab_scene), which has no length scale and so no structural colour.
//
// read → build → measure → compare → report, each a named step below.
//
// Study file keys (units, ranges):
//   name, seed                                       (studies/sections.h)
//   [spectrum] first_nm, last_nm, step_nm            380–780 nm, step <= 10 nm (μ_s is
//                                                    strongly peaked: the Born tables are
//                                                    computed at every wavelength, never
//                                                    interpolated across more than 10 nm)
//   [volume]   box_um                                periodic cube side, a whole number of
//                                                    voxels, 4–512 per side; default 2.0
//              voxel_um                              <= λ_min / (4 n_keratin(λ_min)); 0.025
//              keratin_fractions                     comma-separated list in [0.1, 0.9]
//              morphology                            "channel" (default) or "spheres"
//              channel:
//              shell_relative_width                  (0, 1]; 0.15
//              length_scales_um                      comma-separated list, each in
//                                                    (2 voxel_um, box_um / 4]
//              spheres (air spheres in keratin, random sequential addition):
//              sphere_radii_um                       comma-separated list, each in
//                                                    (voxel_um, box_um / 4]; "0.1"
//              min_separation_diameters              (0, 2]: centre separation / diameter;
//                                                    1 (disjoint)
//              The first value of each list is the base (f, Λ or a) of the angle dependence.
//   [medium]   route                                 "born" (default): first Born on the
//                                                    volume's power spectrum, any volume;
//                                                    "sphere": Mie × S(q) of the centres, in
//                                                    the Bruggeman medium (structcol's
//                                                    convention), sphere packings only
//              polydispersity                        0 (monodisperse); the sphere route is
//                                                    refused at read time, naming the key and
//                                                    limit, for channel volumes, overlapping
//                                                    spheres (min_separation_diameters < 1),
//                                                    φ = 1 − f beyond 0.35 or polydispersity
//                                                    other than 0 (studies/spongy_medium.h).
//              On a sphere packing both routes are computed and traced; the report sets them
//              side by side. Born stays the default: no 3D full-wave evidence decides yet.
//   [slab]     thickness_um                          (0, 100]; default 5; and at least one
//                                                    transport length 1/(μ_s (1 − g) + μ_a)
//                                                    of every case's medium at its most
//                                                    scattering wavelength (checked once
//                                                    the medium is built, before anything is
//                                                    written)
//              backing                               "melanin" (default) or "none"
//              backing_thickness_um                  (0, 10]; 1
//              paths_per_wavelength                  per slab and wavelength; 4000
//   [angles]   incidence_deg                         comma-separated list in [0, 80]; "0, 30, 60"
//              paths_per_wavelength                  per angle and wavelength; 4000
//   [baseline] paths_per_wavelength                  geometric-optics baseline; 2000
//
// Random streams (studies/study_context.h): the volume of case c from
// ctx.stream("spongy/volume", c), the paths of case c from ctx.stream("spongy/normal", c) (path
// index = wavelength index × paths + i), the other route's from
// ctx.stream("spongy/other-route", c) (its peak's bootstrap "spongy/other-bootstrap"), those of
// angle a from ctx.stream("spongy/angle", a), the bootstrap of the peak from
// ctx.stream("spongy/bootstrap", c), the baseline's paths from ctx.stream("spongy/baseline", 0).
// Results do not depend on the thread count.
#include <omp.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <limits>
#include <numbers>
#include <sstream>

#include <fmt/format.h>

#include "analysis/metrics/statistics.h"
#include "common/constants.h"
#include "common/error.h"
#include "common/interrupt.h"
#include "common/memory_limit.h"
#include "common/seed.h"
#include "common/version.h"
#include "geometry/spongy_volume.h"
#include "sim/optics/colour.h"
#include "sim/optics/material.h"
#include "sim/scatterer/random.h"
#include "sim/scattering_medium.h"
#include "sim/scattering_slab.h"
#include "sim/tracer.h"
#include "sim/wave/volume/born_medium.h"
#include "sim/wave/volume/effective_index.h"
#include "studies/plots.h"
#include "studies/sections.h"
#include "studies/spongy_medium.h"
#include "studies/staged_directory.h"
#include "studies/study.h"
#include "studies/study_context.h"
#include "studies/study_progress.h"
#include "virtual_gonio/record/hdf5_file.h"

namespace plumage::studies {
namespace {

namespace fs = std::filesystem;
constexpr int kBootstrapReplicates = 400;

struct Settings {
    std::string name;
    std::uint64_t seed = 0;
    std::vector<double> wavelengths_nm;
    double box_um = 2.0;
    double voxel_um = 0.025;
    double shell_relative_width = 0.15;
    std::vector<double> fractions;  // f
    std::vector<double> scales_um;  // Λ (channel) or the air spheres' radius a (spheres)
    geometry::SpongyMorphology morphology = geometry::SpongyMorphology::channel;
    double min_separation_diameters = 1.0;  // spheres only: disjoint
    MediumRoute route = MediumRoute::born;
    double polydispersity = 0.0;
    sim::ScatteringSlabParams slab;
    std::size_t paths = 4000;
    std::vector<double> angles_deg;
    std::size_t angle_paths = 4000;
    std::size_t baseline_paths = 2000;
    std::string thickness_where;  // file:line:col of slab.thickness_um, for later errors
    std::string text;
};

// One (f, Λ): its volume's measured numbers, its medium, and what was measured on its slab.
struct Case {
    double fraction = 0.0, scale_um = 0.0;  // requested
    double measured_fraction = 0.0, measured_scale_um = 0.0, isotropy = 1.0;
    std::vector<sim::wave::ScatteringTable> tables;  // the study's route (medium.route)
    std::shared_ptr<const sim::ScatteringMedium> medium;
    std::vector<double> r, r_se, r_single;  // per wavelength
    // The other route, side by side (sphere packings only: empty for channel volumes).
    double sphere_fraction = 0.0;  // φ of the air spheres, N (4π/3) a³ / L³
    std::vector<sim::wave::ScatteringTable> other_tables;
    std::shared_ptr<const sim::ScatteringMedium> other_medium;
    std::vector<double> other_r, other_r_se;
};

struct AngleRun {
    double incidence_deg = 0.0;
    std::vector<double> r, r_se, r_single;
};

struct Peak {
    double lambda_nm = 0.0, sigma_nm = 0.0;
    std::size_t index = 0;  // the largest sampled point
    bool at_edge = false;
};

// The colour of a reflectance spectrum under D65 (CIE 1931 2°, sRGB, CIELAB).
struct Colour {
    std::array<int, 3> srgb8{};
    double hue_deg = 0.0, chroma = 0.0, luminance_y = 0.0;
};

// The geometric-optics baseline: the base volume's explicit mesh, tiled and traced.
struct Baseline {
    double thickness_um = 0.0, half_width_um = 0.0;
    int layers = 0, cubes_per_side = 0;
    std::size_t triangles = 0;
    std::vector<double> r, r_se;
    Colour colour;
    double relative_spread = 0.0;  // (max R − min R) / mean R over the spectrum
    // Flatness test: χ² of R against its inverse-variance weighted mean, n − 1 degrees of
    // freedom, and its p-value (a small p would mean R depends on λ beyond the noise).
    double flat_chi2 = 0.0, flat_p = 0.0;
    double wall_s = 0.0;
};

struct CaseResult {
    Peak peak;
    Peak single_peak;             // of the single-scattering closed form (no Monte Carlo error)
    double bragg_nm = 0.0;        // 2 n_eff Λ (Bruggeman n_eff at that wavelength, measured Λ)
    double multiple_share = 0.0;  // 1 − R_single / R at the peak
    Colour colour;
    Peak other_peak;  // of the other route's slab, when there is one
};

// ---------------------------------------------------------------------------------- read

// A comma-separated list of numbers in `range` (ParameterTable has no list getter): errors
// name the key's file:line:col.
std::vector<double> read_list(ParameterTable& t, std::string_view key, std::string_view fallback,
                              double lo, double hi, std::string_view what) {
    const std::string text = t.string(key, fallback, {}, what);
    std::vector<double> values;
    std::stringstream in(text);
    std::string item;
    while (std::getline(in, item, ',')) {
        char* parsed_end = nullptr;
        const double v = std::strtod(item.c_str(), &parsed_end);
        const char* end = parsed_end;
        const bool blank = std::all_of(end, item.c_str() + item.size(),
                                       [](char c) { return std::isspace(c) != 0; });
        if (end == item.c_str() || !blank || !std::isfinite(v) || v < lo || v > hi) {
            throw InputError(fmt::format(
                "{}: {}.{} = \"{}\": '{}' is not a number in [{}, {}] ({}; a comma-separated list)",
                t.location(key), t.path(), key, text, item, lo, hi, what));
        }
        if (std::find(values.begin(), values.end(), v) != values.end()) {
            throw InputError(
                fmt::format("{}: {}.{} lists {} twice", t.location(key), t.path(), key, v));
        }
        values.push_back(v);
    }
    if (values.empty()) {
        throw InputError(fmt::format("{}: {}.{} is empty: expected at least one value ({})",
                                     t.location(key), t.path(), key, what));
    }
    return values;
}

void read_volume(ParameterTable v, Settings& s) {
    s.box_um = v.number("box_um", s.box_um, positive(), "side of the periodic cube, um");
    s.voxel_um = v.number("voxel_um", s.voxel_um, positive(), "voxel side, um");
    const double n = s.box_um / s.voxel_um;
    if (std::abs(n - std::round(n)) > 1e-6 * n || n < 4 || n > 512) {
        throw InputError(fmt::format(
            "{}: volume.box_um = {}: expected a whole number of voxels ({} um), 4 to 512 per side; "
            "it is {:.4f}",
            v.location("box_um"), s.box_um, s.voxel_um, n));
    }
    require_fine_voxels(v, "voxel_um", s.voxel_um, s.wavelengths_nm);
    // Peak memory measured with one volume of 64³ and 128³ voxels (maxrss 146 and 696 MB): 306
    // bytes per voxel (the volume, its level set and mesh, the FFT's arrays) over 66 MB; 512 per
    // side needs about 41 GB.
    const double voxels = std::pow(std::round(n), 3.0);
    require_memory(66e6 + 306.0 * voxels,
                   fmt::format("{}: volume.box_um / voxel_um = {} / {} = {:.0f} voxels per side",
                               v.location("box_um"), s.box_um, s.voxel_um, std::round(n)));
    s.fractions = read_list(v, "keratin_fractions", "0.5", 0.1, 0.9, "keratin filling fractions");
    const std::string morphology = v.string("morphology", "channel", {"channel", "spheres"},
                                            "channel network or packing of air spheres");
    if (morphology == "spheres") {
        s.morphology = geometry::SpongyMorphology::sphere;
        s.min_separation_diameters =
            v.number("min_separation_diameters", s.min_separation_diameters,
                     {0.0, 2.0, true, false}, "minimum centre separation / sphere diameter");
        s.scales_um =
            read_list(v, "sphere_radii_um", "0.1", s.voxel_um * (1 + 1e-9), s.box_um / 4.0,
                      "air-sphere radii in um, above one voxel and at most a quarter "
                      "of the box");
        return;
    }
    s.shell_relative_width = v.number("shell_relative_width", s.shell_relative_width,
                                      {0.0, 1.0, true, false}, "spectral shell width / k0");
    s.scales_um =
        read_list(v, "length_scales_um", "0.19", 2.0 * s.voxel_um * (1 + 1e-9), s.box_um / 4.0,
                  "channel length scales in um, above 2 voxels and at most a quarter "
                  "of the box");
}

// The volume of keratin fraction f and scale `scale`, drawn from volume_seed (a case's stream;
// the read-time checks of the sphere route do not depend on it).
SpongyMediumParams medium_params(const Settings& s, double f, double scale,
                                 std::uint64_t volume_seed) {
    SpongyMediumParams p;
    p.morphology = s.morphology;
    if (s.morphology == geometry::SpongyMorphology::sphere) {
        p.sphere_radius_um = scale;
        p.min_separation_diameters = s.min_separation_diameters;
    } else {
        p.length_scale_um = scale;
    }
    p.keratin_fraction = f;
    p.shell_relative_width = s.shell_relative_width;
    p.box_um = s.box_um;
    p.voxel_um = s.voxel_um;
    p.seed = volume_seed;
    return p;
}

// [medium] route and polydispersity. The sphere route is refused at read time, naming the key
// and the limit, for a volume it cannot describe (studies/spongy_medium.h).
void read_medium(ParameterTable m, ParameterTable& volume, Settings& s) {
    const std::string route =
        m.string("route", "born", {"born", "sphere"},
                 "the medium's route: first Born on the volume's power spectrum (any volume) or "
                 "Mie x S(q) (sphere packings)");
    s.route = route == "sphere" ? MediumRoute::sphere : MediumRoute::born;
    s.polydispersity = m.number("polydispersity", 0.0, {0.0, 1.0, false, true},
                                "relative standard deviation of the sphere radius");
    if (s.route != MediumRoute::sphere) {
        if (s.polydispersity != 0.0) {
            throw InputError(fmt::format(
                "{}: medium.polydispersity = {}: expected 0: the generated volumes are "
                "monodisperse, and the key belongs to the sphere route, which accepts 0 only",
                m.location("polydispersity"), s.polydispersity));
        }
        return;
    }
    for (const double f : s.fractions) {
        const SpongyMediumParams p = medium_params(s, f, s.scales_um.front(), 0);
        const RouteRefusal refusal = sphere_route_refusal(p, s.polydispersity);
        if (refusal.reason.empty()) continue;
        // The key to blame, in the file's own names (keratin_fractions is a list).
        const bool medium_key = refusal.key == "polydispersity";
        ParameterTable& table = medium_key ? m : volume;
        const std::string key =
            refusal.key == "keratin_fraction" ? "keratin_fractions" : refusal.key;
        const std::string where = table.has(key) ? table.location(key) : m.location("route");
        throw InputError(fmt::format("{}: medium.route = \"sphere\" refused: {}.{}{}{}", where,
                                     medium_key ? "medium" : "volume", key,
                                     key == "keratin_fractions" ? " lists " : " = ",
                                     refusal.reason));
    }
}

void read_slab(ParameterTable t, Settings& s) {
    s.slab.thickness_um =
        t.number("thickness_um", 5.0, {0.0, 100.0, true, false}, "slab thickness, um");
    s.thickness_where = t.location("thickness_um");
    s.slab.half_width_um = std::max(1000.0, 20.0 * s.slab.thickness_um);
    const std::string backing =
        t.string("backing", "melanin", {"melanin", "none"}, "what lies beneath the slab");
    const double backing_um =
        t.number("backing_thickness_um", 1.0, {0.0, 10.0, true, false}, "melanin thickness, um");
    if (backing == "melanin") s.slab.backing = sim::SlabBacking{optics::melanin(), backing_um};
    s.paths = static_cast<std::size_t>(
        t.integer("paths_per_wavelength", 4000, 100, 100000000, "paths per slab and wavelength"));
}

Settings read(StudyContext& ctx) {
    const fs::path& source = ctx.source();
    ParameterTable root = ctx.root();
    root.string("study", "spongy", {"spongy"}, "which study this file describes");
    Settings s;
    s.text = ctx.text();
    s.name = read_study_name(root, source);
    s.seed = read_seed(root);
    ParameterTable spectrum = root.table("spectrum");
    s.wavelengths_nm =
        read_wavelengths(spectrum, {.first_nm = 400.0,
                                    .last_nm = 700.0,
                                    .step_nm = 10.0,
                                    .min_nm = 380.0,
                                    .max_nm = 780.0,
                                    .range_reason = "keratin's published dispersion range"});
    const double step = s.wavelengths_nm[1] - s.wavelengths_nm[0];
    if (step > 10.0 + 1e-9) {
        throw InputError(fmt::format(
            "{}: spectrum.step_nm = {}: expected at most 10 nm (mu_s is strongly peaked in "
            "wavelength; the Born tables are computed at every wavelength of the spectrum)",
            spectrum.location("step_nm"), step));
    }
    ParameterTable volume = root.table("volume");
    read_volume(volume, s);
    read_medium(root.table("medium"), volume, s);
    read_slab(root.table("slab"), s);
    ParameterTable a = root.table("angles");
    s.angles_deg = read_list(a, "incidence_deg", "0, 30, 60", 0.0, 80.0, "incidence angles, deg");
    s.angle_paths = static_cast<std::size_t>(
        a.integer("paths_per_wavelength", 4000, 100, 100000000, "paths per angle and wavelength"));
    s.baseline_paths = static_cast<std::size_t>(
        root.table("baseline")
            .integer("paths_per_wavelength", 2000, 100, 100000000,
                     "paths per wavelength through the explicit volume (geometric optics)"));
    root.reject_unused();
    s.slab.validate();
    return s;
}

// --------------------------------------------------------------------------------- build

// The case's medium through the studies' shared route (studies/spongy_medium.h): volume →
// indicator → power spectrum → first-Born tables at every wavelength, and for a sphere packing
// the sphere route's tables as well → ScatteringMedium. The study's route (medium.route) is
// the case's medium; the other one, where there is one, goes beside it.
Case build_case(const StudyContext& ctx, const Settings& s, double f, double scale,
                std::size_t index) {
    Case c;
    c.fraction = f;
    c.scale_um = scale;
    SpongyMedium m = build_spongy_medium(
        medium_params(s, f, scale, ctx.stream("spongy/volume", index)), s.wavelengths_nm);
    c.measured_fraction = m.measured_fraction;
    c.measured_scale_um = m.measured_scale_um;
    c.isotropy = m.isotropy;
    c.sphere_fraction = m.sphere_fraction;
    c.tables = std::move(m.tables);
    c.medium = std::move(m.medium);
    c.other_tables = std::move(m.sphere_tables);
    c.other_medium = std::move(m.sphere_medium);
    if (s.route == MediumRoute::sphere) {
        PLUMAGE_CHECK(c.other_medium != nullptr, "the sphere route was checked at read time");
        std::swap(c.tables, c.other_tables);
        std::swap(c.medium, c.other_medium);
    }
    return c;
}

// A slab thinner than one transport length ℓ* = 1/(μ_s (1 − g) + μ_a) at every wavelength is
// crossed by most light before its direction is randomised: its reflectance is then set by the
// backing and by single scattering, not by the medium's transport, and the study's question
// (the colour of a spongy layer) has no answer. Checked at the most scattering wavelength
// (the shortest ℓ*), once the medium exists and before anything is written.
void require_transport_thickness(const Case& c, const Settings& s) {
    double shortest_um = std::numeric_limits<double>::infinity(), at_nm = 0.0;
    for (const auto& t : c.tables) {
        const double extinction = t.mu_s_per_um * (1.0 - t.g) + t.mu_a_per_um;
        const double transport_um = extinction > 0.0 ? 1.0 / extinction : shortest_um;
        if (transport_um < shortest_um) {
            shortest_um = transport_um;
            at_nm = t.lambda_nm;
        }
    }
    if (s.slab.thickness_um < shortest_um) {
        throw InputError(fmt::format(
            "{}: slab.thickness_um = {}: thinner than one transport length of the medium of "
            "f = {}, {} = {} um: l* = 1/(mu_s (1 - g) + mu_a) = {:.3g} um at {} nm, its "
            "shortest over the spectrum; expected a slab at least that thick (a thinner one "
            "shows the backing, not the medium)",
            s.thickness_where, s.slab.thickness_um, c.fraction,
            s.morphology == geometry::SpongyMorphology::sphere ? "a" : "Lambda", c.scale_um,
            shortest_um, at_nm));
    }
}

// The base volume's own mesh, tiled into a slab of about the medium slab's thickness (whole
// cubes, at least one) on the same backing, 0.01 µm air gaps between cubes (a twentieth of
// the box at most), laterally 10 × its thickness (at most 60 boxes) each way.
// Fills the baseline's geometry numbers.
sim::TiledVolumeSlab build_baseline(const StudyContext& ctx, const Settings& s, Baseline& b) {
    geometry::TriangleMesh mesh = geometry::level_set_to_mesh(
        *make_spongy_volume(medium_params(s, s.fractions.front(), s.scales_um.front(),
                                          ctx.stream("spongy/volume", 0)))
             .level_set);
    b.triangles = mesh.triangles.size();
    sim::TiledVolumeSlabParams p;
    p.layers = static_cast<int>(std::clamp(std::lround(s.slab.thickness_um / s.box_um), 1L, 64L));
    p.gap_um = std::min(0.01, s.box_um / 20.0);
    const double thickness = p.layers * s.box_um + (p.layers - 1) * p.gap_um;
    p.half_width_um = std::max(0.5 * s.box_um, std::min(10.0 * thickness, 60.0 * s.box_um));
    p.backing = s.slab.backing;
    sim::TiledVolumeSlab slab = sim::tiled_volume_slab_scene(std::move(mesh), s.box_um, p);
    b.layers = p.layers;
    b.thickness_um = slab.thickness_um;
    b.half_width_um = slab.half_width_um;
    b.cubes_per_side = slab.cubes_per_side;
    return slab;
}

// ------------------------------------------------------------------------------- measure

struct Reflectance {
    std::vector<double> r, r_se;
};

// R(λ) of a slab under a beam from polar angle θ (azimuth 0): the mean weight of the paths
// that leave upwards, with its standard error over paths.
Reflectance trace_reflectance(const sim::ExplicitScatterer& tracer, const Settings& s, double theta,
                              std::uint64_t seed, std::size_t paths,
                              const sim::BeamFootprint& footprint = {{-1.0, -1.0}, {1.0, 1.0}}) {
    const Vec3d wi(std::sin(theta), 0.0, std::cos(theta));
    Reflectance out;
    for (std::size_t w = 0; w < s.wavelengths_nm.size(); ++w) {
        throw_if_interrupted("spongy slab tracing");
        const auto events = sim::trace_many(tracer, wi, s.wavelengths_nm[w], footprint, seed,
                                            w * paths, paths, omp_get_max_threads());
        double sum = 0.0, sum_sq = 0.0;
        for (const auto& e : events) {
            if (!e || e->wo.z() <= 0.0) continue;
            sum += e->weight;
            sum_sq += e->weight * e->weight;
        }
        const double n = static_cast<double>(paths);
        const double mean = sum / n;
        out.r.push_back(mean);
        out.r_se.push_back(std::sqrt(std::max(0.0, sum_sq / n - mean * mean) / (n - 1.0)));
    }
    return out;
}

// The closed-form single-scattering reflectance of an index-matched slab of the same medium
// and thickness, per wavelength (sim/scattering_slab.h).
std::vector<double> single_scattering(const sim::ScatteringMedium& medium, const Settings& s,
                                      double theta) {
    const Vec3d wi(std::sin(theta), 0.0, std::cos(theta));
    std::vector<double> r;
    for (const auto& totals :
         sim::slab_single_scattering_totals(medium, s.wavelengths_nm, s.slab.thickness_um, wi)) {
        r.push_back(totals.reflectance);
    }
    return r;
}

void measure_case(const StudyContext& ctx, Case& c, const Settings& s, std::size_t index) {
    const sim::ExplicitScatterer tracer(sim::scattering_slab_scene(c.medium, s.slab));
    Reflectance r = trace_reflectance(tracer, s, 0.0, ctx.stream("spongy/normal", index), s.paths);
    c.r = std::move(r.r);
    c.r_se = std::move(r.r_se);
    c.r_single = single_scattering(*c.medium, s, 0.0);
    if (!c.other_medium) return;
    const sim::ExplicitScatterer other(sim::scattering_slab_scene(c.other_medium, s.slab));
    Reflectance o =
        trace_reflectance(other, s, 0.0, ctx.stream("spongy/other-route", index), s.paths);
    c.other_r = std::move(o.r);
    c.other_r_se = std::move(o.r_se);
}

std::vector<AngleRun> measure_angles(const StudyContext& ctx, const Case& base, const Settings& s) {
    const StudyProgress& clock = ctx.clock();
    const sim::ExplicitScatterer tracer(sim::scattering_slab_scene(base.medium, s.slab));
    std::vector<AngleRun> runs;
    for (std::size_t a = 0; a < s.angles_deg.size(); ++a) {
        clock.say(fmt::format("base slab at {} deg incidence", s.angles_deg[a]));
        Reflectance r = trace_reflectance(tracer, s, s.angles_deg[a] * kDeg,
                                          ctx.stream("spongy/angle", a), s.angle_paths);
        runs.push_back({s.angles_deg[a], std::move(r.r), std::move(r.r_se),
                        single_scattering(*base.medium, s, s.angles_deg[a] * kDeg)});
    }
    return runs;
}

// The baseline at normal incidence, the beam over the top face of the centre cube.
Baseline measure_baseline(const StudyContext& ctx, const Settings& s) {
    const StudyProgress& clock = ctx.clock();
    clock.say("geometric-optics baseline: the base volume's mesh, tiled");
    const double began = clock.elapsed_s();
    Baseline b;
    const sim::ExplicitScatterer tracer(build_baseline(ctx, s, b).scene);
    const double h = 0.5 * s.box_um;
    Reflectance r = trace_reflectance(tracer, s, 0.0, ctx.stream("spongy/baseline", 0),
                                      s.baseline_paths, {{-h, -h}, {h, h}});
    b.r = std::move(r.r);
    b.r_se = std::move(r.r_se);
    b.wall_s = clock.elapsed_s() - began;
    return b;
}

// ------------------------------------------------------------------------------- compare

Colour colour_of(const std::vector<double>& r, const Settings& s) {
    Colour out;
    const optics::ReflectanceToXyz to_xyz(optics::WavelengthGrid(s.wavelengths_nm),
                                          optics::Illuminant::d65);
    const optics::Xyz xyz = to_xyz(r);
    const optics::Rgb rgb = optics::linear_srgb_from_xyz(xyz);
    for (int k = 0; k < 3; ++k) {
        out.srgb8[static_cast<std::size_t>(k)] = static_cast<int>(
            std::lround(255.0 * optics::srgb_encode(rgb[static_cast<std::size_t>(k)])));
    }
    const optics::Lab lab = optics::lab_from_xyz(xyz, to_xyz.white());
    out.hue_deg = optics::hue_angle_deg(lab);
    out.chroma = optics::chroma(lab);
    out.luminance_y = xyz.y;
    return out;
}

void compare_baseline(Baseline& b, const Settings& s) {
    b.colour = colour_of(b.r, s);
    const auto [lo, hi] = std::minmax_element(b.r.begin(), b.r.end());
    double mean = 0.0;
    for (const double v : b.r) mean += v / static_cast<double>(b.r.size());
    b.relative_spread = mean > 0.0 ? (*hi - *lo) / mean : 0.0;
    double sum_w = 0.0, sum_wr = 0.0;
    for (std::size_t i = 0; i < b.r.size(); ++i) {
        const double w = 1.0 / std::max(b.r_se[i] * b.r_se[i], 1e-300);
        sum_w += w;
        sum_wr += w * b.r[i];
    }
    const double weighted_mean = sum_wr / sum_w;
    b.flat_chi2 = 0.0;
    for (std::size_t i = 0; i < b.r.size(); ++i) {
        const double z = (b.r[i] - weighted_mean) / std::max(b.r_se[i], 1e-150);
        b.flat_chi2 += z * z;
    }
    b.flat_p = analysis::chi_square_p_value(b.flat_chi2, static_cast<int>(b.r.size()) - 1);
}

// Vertex of the parabola through the largest value and its neighbours (uniform grid); the
// largest sampled point itself at the spectrum's edge.
Peak parabolic_peak(const std::vector<double>& wl, const std::vector<double>& r) {
    Peak p;
    p.index = static_cast<std::size_t>(std::max_element(r.begin(), r.end()) - r.begin());
    p.lambda_nm = wl[p.index];
    if (p.index == 0 || p.index + 1 == r.size()) {
        p.at_edge = true;
        return p;
    }
    const double a = r[p.index - 1], b = r[p.index], c = r[p.index + 1];
    const double curvature = a - 2.0 * b + c;
    if (curvature < 0.0) {
        const double shift = std::clamp(0.5 * (a - c) / curvature, -0.5, 0.5);
        p.lambda_nm += shift * (wl[p.index + 1] - wl[p.index]);
    }
    return p;
}

// The peak with its uncertainty: the standard deviation of the peak over parametric bootstrap
// replicates R_j + σ_j z_j (z standard normal, Box–Muller from the study's stream).
Peak peak_with_sigma(const std::vector<double>& wl, const Reflectance& r, std::uint64_t seed) {
    Peak peak = parabolic_peak(wl, r.r);
    Rng rng(seed, 0);
    double sum = 0.0, sum_sq = 0.0;
    std::vector<double> replicate(r.r.size());
    for (int b = 0; b < kBootstrapReplicates; ++b) {
        for (std::size_t j = 0; j < r.r.size(); ++j) {
            const double u1 = 1.0 - rng.uniform(), u2 = rng.uniform();
            const double z = std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * std::numbers::pi * u2);
            replicate[j] = r.r[j] + r.r_se[j] * z;
        }
        const double l = parabolic_peak(wl, replicate).lambda_nm;
        sum += l;
        sum_sq += l * l;
    }
    const double n = kBootstrapReplicates;
    peak.sigma_nm = std::sqrt(std::max(0.0, sum_sq / n - (sum / n) * (sum / n)));
    return peak;
}

// First-order Bragg estimate λ = 2 n_eff(λ) Λ, solved by fixed-point iteration (n_eff varies
// slowly with λ): a comparison, not an input.
double bragg_wavelength(double fraction, double scale_um) {
    double lambda = 2.0 * 1.25 * scale_um * 1e3;
    for (int i = 0; i < 30; ++i) {
        const auto n = sim::wave::bruggeman_index(optics::keratin()->index(lambda),
                                                  optics::air()->index(lambda), fraction);
        lambda = 2.0 * n.real() * scale_um * 1e3;
    }
    return lambda;
}

CaseResult compare_case(const StudyContext& ctx, const Case& c, const Settings& s,
                        std::size_t index) {
    CaseResult out;
    out.peak =
        peak_with_sigma(s.wavelengths_nm, {c.r, c.r_se}, ctx.stream("spongy/bootstrap", index));
    out.single_peak = parabolic_peak(s.wavelengths_nm, c.r_single);
    out.bragg_nm = bragg_wavelength(c.measured_fraction, c.measured_scale_um);
    const double r_peak = c.r[out.peak.index];
    out.multiple_share = r_peak > 0.0 ? 1.0 - c.r_single[out.peak.index] / r_peak : 0.0;
    out.colour = colour_of(c.r, s);
    if (c.other_medium) {
        out.other_peak = peak_with_sigma(s.wavelengths_nm, {c.other_r, c.other_r_se},
                                         ctx.stream("spongy/other-bootstrap", index));
    }
    return out;
}

// -------------------------------------------------------------------------------- report

std::vector<double> flatten(const std::vector<Case>& cases, std::vector<double> Case::*member) {
    std::vector<double> out;
    for (const Case& c : cases) out.insert(out.end(), (c.*member).begin(), (c.*member).end());
    return out;
}

template <typename F>
std::vector<double> per_case(std::size_t n, F&& f) {
    std::vector<double> out;
    for (std::size_t i = 0; i < n; ++i) out.push_back(f(i));
    return out;
}

record::Attributes attrs(std::string units, std::string description) {
    return {{"units", std::move(units)}, {"description", std::move(description)}};
}

void write_case_spectra(record::Hdf5Writer& h5, const std::vector<Case>& cases, const Settings& s) {
    const std::uint64_t nf = s.fractions.size(), ns = s.scales_um.size(),
                        nw = s.wavelengths_nm.size();
    const std::vector<std::uint64_t> dims{nf, ns, nw};
    h5.write("wavelength_nm", std::span<const double>(s.wavelengths_nm), {nw},
             attrs("nm", "vacuum wavelengths of every spectrum"));
    h5.write("keratin_fraction", std::span<const double>(s.fractions), {nf},
             attrs("1", "requested keratin filling fraction f (first axis of the grids)"));
    h5.write("length_scale_um", std::span<const double>(s.scales_um), {ns},
             attrs("um",
                   "requested channel length scale Lambda, or air-sphere radius a when the root "
                   "attribute morphology is spheres (second axis of the grids)"));
    h5.write("reflectance", std::span<const double>(flatten(cases, &Case::r)), dims,
             attrs("1",
                   "slab reflectance at normal incidence, Monte Carlo through the tracer "
                   "[f][Lambda][wavelength]"));
    h5.write("reflectance_standard_error", std::span<const double>(flatten(cases, &Case::r_se)),
             dims, attrs("1", "standard error of reflectance over paths"));
    h5.write("single_scattering_reflectance",
             std::span<const double>(flatten(cases, &Case::r_single)), dims,
             attrs("1",
                   "closed-form single-scattering reflectance of the same medium and "
                   "thickness, index-matched boundary (sim/scattering_slab.h)"));
    std::vector<double> mu_s, g, n_eff;
    for (const Case& c : cases) {
        for (const auto& t : c.tables) {
            mu_s.push_back(t.mu_s_per_um);
            g.push_back(t.g);
            n_eff.push_back(t.n_eff.real());
        }
    }
    h5.write("mu_s_per_um", std::span<const double>(mu_s), dims,
             attrs("1/um",
                   "scattering coefficient of the study's route (root attribute medium_route: "
                   "first Born or the sphere route, sim/wave/volume/born_medium.h)"));
    h5.write("asymmetry_g", std::span<const double>(g), dims,
             attrs("1", "mean cosine of the phase function of the study's route"));
    h5.write("n_eff", std::span<const double>(n_eff), dims,
             attrs("1", "real part of the Bruggeman effective index"));
}

void write_case_results(record::Hdf5Writer& h5, const std::vector<Case>& cases,
                        const std::vector<CaseResult>& res, const Settings& s) {
    const std::vector<std::uint64_t> dims{s.fractions.size(), s.scales_um.size()};
    const std::size_t n = cases.size();
    auto put = [&](const char* name, auto f, const char* units, const char* what) {
        h5.write(name, std::span<const double>(per_case(n, f)), dims, attrs(units, what));
    };
    put(
        "peak_wavelength_nm", [&](std::size_t i) { return res[i].peak.lambda_nm; }, "nm",
        "vertex of the parabola through the largest R and its neighbours [f][Lambda]");
    put(
        "peak_wavelength_sigma_nm", [&](std::size_t i) { return res[i].peak.sigma_nm; }, "nm",
        "standard deviation of the peak over parametric bootstrap replicates of R");
    put(
        "peak_at_spectrum_edge", [&](std::size_t i) { return res[i].peak.at_edge ? 1.0 : 0.0; },
        "1", "1: the largest R is the spectrum's first or last wavelength (no vertex)");
    put(
        "single_scattering_peak_wavelength_nm",
        [&](std::size_t i) { return res[i].single_peak.lambda_nm; }, "nm",
        "parabolic peak of the single-scattering closed form [f][Lambda]");
    put(
        "bragg_wavelength_nm", [&](std::size_t i) { return res[i].bragg_nm; }, "nm",
        "first-order Bragg estimate 2 n_eff Lambda (Bruggeman n_eff, measured Lambda)");
    put(
        "reflectance_at_peak", [&](std::size_t i) { return cases[i].r[res[i].peak.index]; }, "1",
        "R at the largest sampled point");
    put(
        "reflectance_at_peak_standard_error",
        [&](std::size_t i) { return cases[i].r_se[res[i].peak.index]; }, "1", "its standard error");
    put(
        "multiple_scattering_share", [&](std::size_t i) { return res[i].multiple_share; }, "1",
        "1 - R_single / R at the peak");
    put(
        "measured_keratin_fraction", [&](std::size_t i) { return cases[i].measured_fraction; }, "1",
        "mean of the voxel indicator of the generated volume");
    put(
        "measured_length_scale_um", [&](std::size_t i) { return cases[i].measured_scale_um; }, "um",
        "2 pi / peak wavenumber of the indicator power spectrum");
    put(
        "isotropy_eigenvalue_ratio", [&](std::size_t i) { return cases[i].isotropy; }, "1",
        "directional spread of the spectrum's peak shell (1: isotropic; power_spectrum.h)");
    put(
        "hue_deg", [&](std::size_t i) { return res[i].colour.hue_deg; }, "deg",
        "CIELAB hue angle h_ab of R under D65 (CIE 1931 2 deg)");
    put(
        "chroma", [&](std::size_t i) { return res[i].colour.chroma; }, "1", "CIELAB chroma C*_ab");
    put(
        "luminance_Y", [&](std::size_t i) { return res[i].colour.luminance_y; }, "1",
        "CIE Y of R under D65 (perfect reflector: 1)");
    std::vector<double> rgb;
    for (const CaseResult& r : res) {
        rgb.insert(rgb.end(), r.colour.srgb8.begin(), r.colour.srgb8.end());
    }
    h5.write("srgb8", std::span<const double>(rgb), {dims[0], dims[1], 3},
             attrs("0-255", "gamma-encoded sRGB (D65) of R, clipped to the gamut"));
}

// The other route beside the study's (sphere packings): its μ_s, R and peak per case.
void write_other_route(record::Hdf5Writer& h5, const std::vector<Case>& cases,
                       const std::vector<CaseResult>& res, const Settings& s) {
    const std::uint64_t nf = s.fractions.size(), ns = s.scales_um.size(),
                        nw = s.wavelengths_nm.size();
    const char* other = s.route == MediumRoute::born ? "sphere route (Mie x S(q))" : "first Born";
    // Cases the sphere route does not apply to (overlapping spheres, φ beyond its limit) are NaN.
    const double nan = std::numeric_limits<double>::quiet_NaN();
    std::vector<double> mu_s, g, peak, sigma, phi, r, r_se;
    for (std::size_t i = 0; i < cases.size(); ++i) {
        const Case& c = cases[i];
        for (std::size_t w = 0; w < nw; ++w) {
            const bool has = c.other_medium != nullptr;
            mu_s.push_back(has ? c.other_tables[w].mu_s_per_um : nan);
            g.push_back(has ? c.other_tables[w].g : nan);
            r.push_back(has ? c.other_r[w] : nan);
            r_se.push_back(has ? c.other_r_se[w] : nan);
        }
        peak.push_back(c.other_medium ? res[i].other_peak.lambda_nm : nan);
        sigma.push_back(c.other_medium ? res[i].other_peak.sigma_nm : nan);
        phi.push_back(cases[i].sphere_fraction);
    }
    const std::string route = fmt::format("the other route, {}: ", other);
    h5.write("other_route/mu_s_per_um", std::span<const double>(mu_s), {nf, ns, nw},
             attrs("1/um", route + "scattering coefficient [f][a][wavelength]"));
    h5.write("other_route/asymmetry_g", std::span<const double>(g), {nf, ns, nw},
             attrs("1", route + "mean cosine of the phase function"));
    h5.write("other_route/reflectance", std::span<const double>(r), {nf, ns, nw},
             attrs("1", route + "slab reflectance, defined as reflectance"));
    h5.write("other_route/reflectance_standard_error", std::span<const double>(r_se), {nf, ns, nw},
             attrs("1", "its standard error over paths"));
    h5.write("other_route/peak_wavelength_nm", std::span<const double>(peak), {nf, ns},
             attrs("nm", route + "parabolic peak of its R"));
    h5.write("other_route/peak_wavelength_sigma_nm", std::span<const double>(sigma), {nf, ns},
             attrs("nm", "bootstrap standard deviation of that peak"));
    h5.write("sphere_fraction", std::span<const double>(phi), {nf, ns},
             attrs("1", "air-sphere volume fraction phi = N (4 pi / 3) a^3 / L^3 [f][a]"));
    h5.set_attribute("/other_route", "route", s.route == MediumRoute::born ? "sphere" : "born");
}

void write_angles(record::Hdf5Writer& h5, const std::vector<AngleRun>& runs,
                  const std::vector<Peak>& peaks, const Settings& s) {
    const std::uint64_t na = runs.size(), nw = s.wavelengths_nm.size();
    std::vector<double> deg, r, se, single, peak, sigma, single_peak;
    for (std::size_t a = 0; a < runs.size(); ++a) {
        deg.push_back(runs[a].incidence_deg);
        single.insert(single.end(), runs[a].r_single.begin(), runs[a].r_single.end());
        single_peak.push_back(parabolic_peak(s.wavelengths_nm, runs[a].r_single).lambda_nm);
        r.insert(r.end(), runs[a].r.begin(), runs[a].r.end());
        se.insert(se.end(), runs[a].r_se.begin(), runs[a].r_se.end());
        peak.push_back(peaks[a].lambda_nm);
        sigma.push_back(peaks[a].sigma_nm);
    }
    h5.write("angles/incidence_deg", std::span<const double>(deg), {na},
             attrs("deg", "polar angle of the incident beam (azimuth 0), base (f, Lambda)"));
    h5.write("angles/reflectance", std::span<const double>(r), {na, nw},
             attrs("1", "base slab's reflectance (all upward directions) [angle][wavelength]"));
    h5.write("angles/reflectance_standard_error", std::span<const double>(se), {na, nw},
             attrs("1", "its standard error"));
    h5.write("angles/single_scattering_reflectance", std::span<const double>(single), {na, nw},
             attrs("1", "closed-form single-scattering reflectance, index-matched slab"));
    h5.write("angles/single_scattering_peak_wavelength_nm", std::span<const double>(single_peak),
             {na}, attrs("nm", "parabolic peak of the single-scattering reflectance per angle"));
    h5.write("angles/peak_wavelength_nm", std::span<const double>(peak), {na},
             attrs("nm", "parabolic peak of R per angle"));
    h5.write("angles/peak_wavelength_sigma_nm", std::span<const double>(sigma), {na},
             attrs("nm", "bootstrap standard deviation of the peak"));
    h5.set_attribute("/angles", "keratin_fraction", s.fractions.front());
    h5.set_attribute("/angles", "length_scale_um", s.scales_um.front());
}

// The figures, drawn from the record by studies/plots.py (kinds spongy_spectra, spongy_map,
// spongy_angles); a figure that cannot be drawn is a warning and the records are kept.
bool draw_figures(const fs::path& dir) {
    const fs::path h5 = dir / "spongy.h5";
    const bool drawn = run_plots({{"spongy_spectra", h5, dir / "spectra.png"},
                                  {"spongy_map", h5, dir / "peak_map.png"},
                                  {"spongy_angles", h5, dir / "angles.png"}},
                                 dir / "plots.csv");
    fs::remove(dir / "plots.csv");  // it names the staging folder
    return drawn;
}

std::string hex_colour(const std::array<int, 3>& rgb) {
    return fmt::format("#{:02x}{:02x}{:02x}", rgb[0], rgb[1], rgb[2]);
}

std::string hue_name(double hue_deg) {
    // CIELAB hue angle bands (approximate names for the reader; the angle is the result).
    if (hue_deg < 40.0 || hue_deg >= 345.0) return "red/pink";
    if (hue_deg < 75.0) return "orange";
    if (hue_deg < 105.0) return "yellow";
    if (hue_deg < 165.0) return "green";
    if (hue_deg < 225.0) return "cyan/teal";
    if (hue_deg < 290.0) return "blue";
    return "violet/purple";
}

std::string results_table(const std::vector<Case>& cases, const std::vector<CaseResult>& res,
                          const Settings& s) {
    std::string t =
        std::string(s.morphology == geometry::SpongyMorphology::sphere
                        ? "| f (measured) | a µm (measured Λ) | peak λ nm |"
                        : "| f (measured) | Λ µm (measured) | peak λ nm |") +
        " single-scattering peak λ nm | "
        "2 n_eff Λ nm | R at peak | single-scattering R at peak | multiple-scattering share | "
        "hue h_ab | sRGB |\n"
        "|---|---|---|---|---|---|---|---|---|---|\n";
    for (std::size_t i = 0; i < cases.size(); ++i) {
        const Case& c = cases[i];
        const CaseResult& r = res[i];
        t += fmt::format(
            "| {:.2f} ({:.3f}) | {:.3f} ({:.3f}) | {:.1f} ± {:.1f}{} | {:.1f}{} | {:.1f} | "
            "{:.4f} ± {:.4f} | {:.4f} | {:.0f} % | {:.0f}° ({}) | `{}` |\n",
            c.fraction, c.measured_fraction, c.scale_um, c.measured_scale_um, r.peak.lambda_nm,
            r.peak.sigma_nm, r.peak.at_edge ? " (edge)" : "", r.single_peak.lambda_nm,
            r.single_peak.at_edge ? " (edge)" : "", r.bragg_nm, c.r[r.peak.index],
            c.r_se[r.peak.index], c.r_single[r.peak.index], 100.0 * r.multiple_share,
            r.colour.hue_deg, hue_name(r.colour.hue_deg), hex_colour(r.colour.srgb8));
    }
    return t;
}

std::string angles_table(const std::vector<AngleRun>& runs, const std::vector<Peak>& peaks,
                         const std::vector<double>& wl) {
    std::string t =
        "| incidence | peak λ nm | R at peak | single-scattering peak λ nm |\n|---|---|---|---|\n";
    for (std::size_t a = 0; a < runs.size(); ++a) {
        t += fmt::format("| {:g}° | {:.1f} ± {:.1f}{} | {:.4f} ± {:.4f} | {:.1f} |\n",
                         runs[a].incidence_deg, peaks[a].lambda_nm, peaks[a].sigma_nm,
                         peaks[a].at_edge ? " (edge)" : "", runs[a].r[peaks[a].index],
                         runs[a].r_se[peaks[a].index],
                         parabolic_peak(wl, runs[a].r_single).lambda_nm);
    }
    return t;
}

// The base medium at the spectrum's ends and middle: how steeply μ_s falls with λ decides how
// far multiple scattering moves R's maximum from the single-scattering one.
std::string medium_text(const Settings& s, const Case& base) {
    std::string t =
        fmt::format("The base medium (f = {}, {} = {} µm):", base.fraction,
                    s.morphology == geometry::SpongyMorphology::sphere ? "a" : "Λ", base.scale_um);
    const std::size_t last = base.tables.size() - 1;
    for (const std::size_t i : {std::size_t{0}, last / 2, last}) {
        const auto& m = base.tables[i];
        t += fmt::format(
            " at {:.0f} nm μ_s = {:.3f} µm⁻¹, g = {:.2f}, n_eff = {:.3f}, optical "
            "thickness {:.2f}{}",
            m.lambda_nm, m.mu_s_per_um, m.g, m.n_eff.real(), m.mu_s_per_um * s.slab.thickness_um,
            i == last ? ". " : ";");
    }
    return t;
}

std::string method_text(const Settings& s, const Case& base) {
    const std::size_t n = static_cast<std::size_t>(std::lround(s.box_um / s.voxel_um));
    const bool spheres = s.morphology == geometry::SpongyMorphology::sphere;
    const std::string volumes =
        spheres ? fmt::format(
                      "Packings of air spheres in keratin (random sequential addition, "
                      "minimum centre separation {} × the diameter)",
                      s.min_separation_diameters)
                : fmt::format("Channel-type volumes (shell width {})", s.shell_relative_width);
    const std::string tables =
        s.route == MediumRoute::sphere
            ? "the sphere route's scattering tables (Mie of one air sphere in the Bruggeman "
              "medium × the measured structure factor of the centres, "
              "sim/wave/volume/born_medium.h)"
            : "first-Born scattering tables from their indicator power spectrum "
              "(sim/wave/volume/born_medium.h)";
    return fmt::format(
        "{12} ({0}³ voxels of {1} µm, box {2} µm), one per (f, {3}), give {13} "
        "at every one of the {4} wavelengths ({5:.0f}–{6:.0f} nm), "
        "transported by the tracer in a slab {7} µm thick on {8}, {9} paths per wavelength. "
        "{10}The single-scattering column is the closed form of an "
        "index-matched slab of the same medium (sim/scattering_slab.h); the Monte Carlo slab "
        "has a Fresnel boundary in n_eff, so their ratio is the multiple-scattering share only "
        "approximately. The peak is the vertex of the parabola through the largest R and its "
        "neighbours, ± the standard deviation over {11} parametric bootstrap replicates; "
        "2 n_eff Λ uses the Bruggeman index and the volume's measured length scale (2π / peak "
        "of its power spectrum): a comparison, not an input. Colours: CIE 1931 2° XYZ of R "
        "under D65 over the study's spectrum, sRGB, CIELAB hue.\n\n",
        n, s.voxel_um, s.box_um, spheres ? "sphere radius a" : "Λ", s.wavelengths_nm.size(),
        s.wavelengths_nm.front(), s.wavelengths_nm.back(), s.slab.thickness_um,
        s.slab.backing ? fmt::format("{} µm of melanin", s.slab.backing->thickness_um)
                       : std::string("nothing (air)"),
        s.paths, medium_text(s, base), kBootstrapReplicates, volumes, tables);
}

const char* route_name(MediumRoute r) {
    return r == MediumRoute::sphere ? "sphere route (Mie x S(q))" : "first Born";
}

// One row of the routes table: μ_s at the spectrum's ends and middle, the peak, R there and at
// the three wavelengths.
std::string route_row(const char* name, const std::vector<sim::wave::ScatteringTable>& t,
                      const std::vector<double>& r, const std::vector<double>& se, const Peak& p) {
    const std::size_t last = t.size() - 1;
    return fmt::format(
        "| {} | {:.3f} / {:.3f} / {:.4f} | {:.1f} ± {:.1f}{} | {:.4f} ± {:.4f} | {:.4f} / {:.4f} / "
        "{:.4f} |",
        name, t[0].mu_s_per_um, t[last / 2].mu_s_per_um, t[last].mu_s_per_um, p.lambda_nm,
        p.sigma_nm, p.at_edge ? " (edge)" : "", r[p.index], se[p.index], r[0], r[last / 2],
        r[last]);
}

// Both routes on every case of a sphere packing; where the sphere route does not apply, why.
std::string routes_text(const std::vector<Case>& cases, const std::vector<CaseResult>& res,
                        const Settings& s) {
    std::string t = fmt::format(
        "## The two routes side by side\n\nThe study's route (`medium.route`) is **{}**; it "
        "gives the results above, the angle dependence and the colours; how each route does "
        "against 3D full wave is the next section. Both use the Bruggeman index for propagation, "
        "the slab's Fresnel faces "
        "and absorption; they differ in the contrast that scatters: first Born the full "
        "two-phase contrast ε_keratin − ε_air on the volume's power spectrum, the sphere route "
        "each air sphere's contrast to the Bruggeman medium, ε_air − ε_eff (structcol's "
        "convention), on Mie × the measured S(q) of the centres. At weak contrast their μ_s "
        "ratio is 1/(1 − φ)², φ the air-sphere fraction (sim/wave/volume/born_medium.h).\n\n",
        route_name(s.route));
    if (s.morphology != geometry::SpongyMorphology::sphere) {
        return t +
               "Here only first Born applies: channel-type volumes are not sphere packings. "
               "`volume.morphology = \"spheres\"` (disjoint spheres, min_separation_diameters >= "
               "1, φ <= 0.35) computes both.\n\n";
    }
    if (std::none_of(cases.begin(), cases.end(), [](const Case& c) { return c.other_medium; })) {
        const Case& b = cases.front();
        const RouteRefusal why =
            sphere_route_refusal(medium_params(s, b.fraction, b.scale_um, 0), s.polydispersity);
        return t + fmt::format("Here only first Born applies: volume.{} = {}.\n\n", why.key,
                               why.reason);
    }
    const std::size_t last = s.wavelengths_nm.size() - 1;
    t += fmt::format(
        "| f | a µm | φ | route | μ_s µm⁻¹ at {0:.0f} / {1:.0f} / {2:.0f} nm | peak λ nm | R at "
        "peak | R at {0:.0f} / {1:.0f} / {2:.0f} nm |\n|---|---|---|---|---|---|---|---|\n",
        s.wavelengths_nm[0], s.wavelengths_nm[last / 2], s.wavelengths_nm[last]);
    const bool born_first = s.route == MediumRoute::born;
    for (std::size_t i = 0; i < cases.size(); ++i) {
        const Case& c = cases[i];
        const std::string head =
            fmt::format("| {:.2f} | {:.3f} | {} ", c.fraction, c.scale_um,
                        c.other_medium ? fmt::format("{:.3f}", c.sphere_fraction) : "—");
        t += head +
             route_row(born_first ? "first Born" : "sphere (Mie x S(q))", c.tables, c.r, c.r_se,
                       res[i].peak) +
             "\n";
        if (!c.other_medium) {
            const RouteRefusal why =
                sphere_route_refusal(medium_params(s, c.fraction, c.scale_um, 0), s.polydispersity);
            t += head + fmt::format("| sphere (Mie x S(q)) | not applicable: {} = {} | | | |\n",
                                    why.key, why.reason);
            continue;
        }
        t += head +
             route_row(born_first ? "sphere (Mie x S(q))" : "first Born", c.other_tables, c.other_r,
                       c.other_r_se, res[i].other_peak) +
             "\n";
    }
    const Case& b = cases.front();
    if (!b.other_medium) return t + "\nR here is defined as in the results table.\n\n";
    const auto& born = born_first ? b.tables : b.other_tables;
    const auto& sphere = born_first ? b.other_tables : b.tables;
    return t + fmt::format(
                   "\nFor the base case μ_s(Born) / μ_s(sphere) = {:.2f} at {:.0f} nm against "
                   "the weak-contrast limit 1/(1 − φ)² = {:.2f}. R here is defined as in the "
                   "results table.\n\n",
                   born[last / 2].mu_s_per_um / sphere[last / 2].mu_s_per_um,
                   s.wavelengths_nm[last / 2],
                   1.0 / ((1.0 - b.sphere_fraction) * (1.0 - b.sphere_fraction)));
}

// The definition of every reflectance the report prints.
std::string reflectance_definitions(const Case& base, const Settings& s) {
    const double n = base.tables[base.tables.size() / 2].n_eff.real();
    const double specular = std::pow((n - 1.0) / (n + 1.0), 2.0);
    return fmt::format(
        "## What each reflectance is\n\n"
        "- **R** (results, angle dependence, the two routes, the spectra figure): the "
        "hemispherical reflectance of a slab of the medium {:.3g} µm thick with Fresnel faces in "
        "the real Bruggeman index n_eff (air above, {} beneath, the slab's sides far away), "
        "every path that leaves upwards counted, so the specular reflection of the top face is "
        "included (((n_eff − 1)/(n_eff + 1))² = {:.2f} % at normal incidence, n_eff = {:.3f} at "
        "{:.0f} nm). Light inside the slab beyond the total-internal-reflection cone, sin θ > "
        "1/n_eff (θ > {:.1f}°), is returned into the slab by the top face.\n"
        "- **Single-scattering R**: the closed form for an index-matched slab of the same medium "
        "and thickness (no faces: no specular reflection, no refraction, no total-internal-"
        "reflection cone), light scattered once, all upward directions.\n"
        "- **Geometric-optics baseline R**: the explicit keratin/air mesh with Fresnel at every "
        "face, all upward paths over the centre cube counted, specular reflections included.\n\n",
        s.slab.thickness_um,
        s.slab.backing ? fmt::format("{} µm of melanin", s.slab.backing->thickness_um)
                       : std::string("nothing (air)"),
        100.0 * specular, n, base.tables[base.tables.size() / 2].lambda_nm,
        std::asin(1.0 / n) / kDeg);
}

// The baseline beside the base medium: geometric optics of the same volume has no length
// scale, so its R(λ) follows only keratin's weak dispersion.
std::string baseline_text(const Baseline& b, const Case& base, const CaseResult& base_result,
                          const Settings& s) {
    double noise = 0.0, mean = 0.0;
    for (std::size_t i = 0; i < b.r.size(); ++i) {
        noise = std::max(noise, b.r_se[i]);
        mean += b.r[i] / static_cast<double>(b.r.size());
    }
    const std::size_t last = b.r.size() - 1;
    return fmt::format(
        "## Geometric-optics baseline (the same volume, traced as interfaces)\n\n"
        "The base volume (f = {}, Λ = {} µm) meshed at its keratin/air surface ({} triangles "
        "per {} µm cube), tiled {} × {} × {} with 0.01 µm air gaps into a slab {:.2f} µm thick "
        "and {:.0f} µm wide on the same backing, traced by the tracer with Fresnel and "
        "refraction at every interface, {} paths per wavelength over the centre cube "
        "({:.1f} s).\n\n"
        "| | R at {:.0f} nm | R at {:.0f} nm | R at {:.0f} nm | spread (max − min) / mean | "
        "hue h_ab | chroma C*_ab | sRGB |\n|---|---|---|---|---|---|---|---|\n"
        "| geometric optics | {:.4f} ± {:.4f} | {:.4f} ± {:.4f} | {:.4f} ± {:.4f} | {:.1f} % "
        "(largest σ/mean {:.1f} %) | {:.0f}° | {:.1f} | `{}` |\n"
        "| first-Born medium | {:.4f} ± {:.4f} | {:.4f} ± {:.4f} | {:.4f} ± {:.4f} | — | {:.0f}° "
        "({}) | {:.1f} | `{}` |\n\n"
        "Ray optics has no length scale: the explicit sponge reflects all wavelengths alike. "
        "Flatness test, R(λ) against a constant: χ² = {:.1f} on {} degrees of freedom, p = "
        "{:.2g} ({}). Its colour is a white-grey of chroma {:.1f} against the medium's {:.1f}. "
        "The structural blue is a wave effect of the network's length scale; it needs the "
        "medium.\n\n",
        base.fraction, base.scale_um, b.triangles, s.box_um, b.cubes_per_side, b.cubes_per_side,
        b.layers, b.thickness_um, 2.0 * b.half_width_um, s.baseline_paths, b.wall_s,
        s.wavelengths_nm[0], s.wavelengths_nm[last / 2], s.wavelengths_nm[last], b.r[0], b.r_se[0],
        b.r[last / 2], b.r_se[last / 2], b.r[last], b.r_se[last], 100.0 * b.relative_spread,
        mean > 0.0 ? 100.0 * noise / mean : 0.0, b.colour.hue_deg, b.colour.chroma,
        hex_colour(b.colour.srgb8), base.r[0], base.r_se[0], base.r[last / 2], base.r_se[last / 2],
        base.r[last], base.r_se[last], base_result.colour.hue_deg,
        hue_name(base_result.colour.hue_deg), base_result.colour.chroma,
        hex_colour(base_result.colour.srgb8), b.flat_chi2, b.r.size() - 1, b.flat_p,
        b.flat_p < 0.01 ? "R varies with λ beyond the Monte Carlo noise: keratin's dispersion "
                          "shows"
                        : "no dependence on λ beyond the Monte Carlo noise",
        b.colour.chroma, base_result.colour.chroma);
}

// Where a case's route was not validated (spongy_medium.h, outside_validated_range), at the
// case's peak; empty when inside.
std::string case_outside_validated_range(const Case& c, const CaseResult& r, const Settings& s,
                                         const std::vector<RouteValidatedCase>& validated) {
    const double lambda = r.peak.lambda_nm;
    return outside_validated_range(
        validated, s.morphology == geometry::SpongyMorphology::sphere ? "air_spheres" : "channel",
        c.measured_fraction, c.scale_um, lambda, optics::keratin()->index(lambda).real());
}

// The report's opening: what the study found, each with its statistic, and where the route that
// computed it is trusted.
std::string verdicts_text(const std::vector<Case>& cases, const std::vector<CaseResult>& res,
                          const Baseline& b, const Settings& s) {
    const bool spheres = s.morphology == geometry::SpongyMorphology::sphere;
    const std::string length = spheres ? "a" : "Λ";
    const Case& base = cases.front();
    const CaseResult& r0 = res.front();
    double lo = r0.peak.lambda_nm, hi = r0.peak.lambda_nm;
    for (const CaseResult& r : res) {
        lo = std::min(lo, r.peak.lambda_nm);
        hi = std::max(hi, r.peak.lambda_nm);
    }
    std::string md = fmt::format(
        "## Verdicts\n\n"
        "- **Colour from the volume**: the base medium (f = {}, {} = {} µm) reflects most at "
        "{:.1f} ± {:.1f} nm (± one parametric-bootstrap standard deviation){}, hue {:.0f}° ({}); "
        "the {} cases' peaks span {:.0f}–{:.0f} nm (table below).\n",
        base.fraction, length, base.scale_um, r0.peak.lambda_nm, r0.peak.sigma_nm,
        r0.peak.at_edge ? ", at the range's edge" : "", r0.colour.hue_deg,
        hue_name(r0.colour.hue_deg), cases.size(), lo, hi);
    md += fmt::format(
        "- **Ray optics alone makes no structural colour**: the base volume's explicit mesh, "
        "traced, gives chroma {:.1f} against the medium's {:.1f}; flatness test of its R(λ), "
        "χ² = {:.1f} on {} degrees of freedom, p = {:.2g} ({}).\n",
        b.colour.chroma, r0.colour.chroma, b.flat_chi2, b.r.size() - 1, b.flat_p,
        b.flat_p < 0.01 ? "R varies with λ beyond the noise: keratin's dispersion"
                        : "flat within the noise");
    const std::string route = s.route == MediumRoute::sphere ? "sphere" : "born";
    const auto validated = route_validated_cases(route);
    std::string where;
    for (const RouteValidatedCase& v : validated)
        where += fmt::format(
            "{}{} at keratin n = {} (keratin fraction {}, {} = {} µm, size "
            "parameter k0 n_eff {} = {:.2f}–{:.2f})",
            where.empty() ? "" : "; ", spongy_structure_label(v.structure), v.keratin_index,
            v.keratin_fraction, v.length_name, v.length_um, v.length_name, v.size_parameter_lo,
            v.size_parameter_hi);
    md += fmt::format(
        "- **Where the route is trusted**: this study's route, {}, passes 3D full wave (the "
        "section \"The routes against 3D full wave\") on {}. A case is inside that range when "
        "it is the same structure, its keratin fraction within 0.02 and keratin's n at its peak "
        "within 0.05 of a validated case's, and its size parameter at its peak (with the validated "
        "case's n_eff, so that the index is judged by n alone) within that case's range.",
        spongy_route_label(route),
        where.empty() ? std::string("no structure of the reference") : where);
    std::size_t inside = 0;
    std::string list;
    for (std::size_t i = 0; i < cases.size(); ++i) {
        const std::string outside = case_outside_validated_range(cases[i], res[i], s, validated);
        if (outside.empty()) ++inside;
        list += fmt::format("  - f = {}, {} = {} µm: {}\n", cases[i].fraction, length,
                            cases[i].scale_um, outside.empty() ? "inside" : "outside: " + outside);
    }
    md += fmt::format(" {} of the {} cases are inside:\n", inside, cases.size()) + list + "\n";
    return md;
}

void write_report(const fs::path& path, const std::vector<Case>& cases,
                  const std::vector<CaseResult>& res, const std::vector<AngleRun>& runs,
                  const std::vector<Peak>& angle_peaks, const Baseline& baseline, const Settings& s,
                  double wall_s, const std::string& run_time) {
    std::ofstream md(path);
    md << "# Spongy keratin: structural colour computed from the volume\n\n"
       << verdicts_text(cases, res, baseline, s) << method_text(s, cases.front())
       << results_table(cases, res, s) << "\n![Reflectance spectra](spectra.png)\n\n"
       << "![Peak wavelength over Λ × f, and the colour of each slab](peak_map.png)\n\n"
       << fmt::format("## Angle dependence (base f = {}, Λ = {} µm)\n\n", s.fractions.front(),
                      s.scales_um.front())
       << angles_table(runs, angle_peaks, s.wavelengths_nm)
       << "\n![Angle dependence](angles.png)\n\n"
       << routes_text(cases, res, s) << routes_against_full_wave_text(s.route)
       << reflectance_definitions(cases.front(), s)
       << baseline_text(baseline, cases.front(), res.front(), s)
       << "Records: `spongy.h5` (every dataset with `units` and `description` attributes; the "
          "figures are drawn from it by plumage's plotting script, kinds `spongy_spectra`, "
          "`spongy_map` and `spongy_angles`).\n\n"
       << fmt::format("Wall time {:.1f} s on {} threads; plumage {}.\n\n", wall_s,
                      omp_get_max_threads(), kVersion)
       << run_time << "## Study file\n\n```toml\n"
       << s.text << "\n```\n";
    if (!md) throw IoError(fmt::format("cannot write {}", path.string()));
}

void write_baseline(record::Hdf5Writer& h5, const Baseline& b, const Settings& s) {
    const std::uint64_t nw = s.wavelengths_nm.size();
    h5.write("baseline/reflectance", std::span<const double>(b.r), {nw},
             attrs("1",
                   "geometric optics: reflectance at normal incidence of the base volume's "
                   "keratin/air mesh, tiled into a slab and traced as interfaces"));
    h5.write("baseline/reflectance_standard_error", std::span<const double>(b.r_se), {nw},
             attrs("1", "its standard error over paths"));
    const std::vector<double> rgb(b.colour.srgb8.begin(), b.colour.srgb8.end());
    h5.write("baseline/srgb8", std::span<const double>(rgb), {3},
             attrs("0-255", "gamma-encoded sRGB (D65) of the baseline's R"));
    h5.set_attribute("/baseline", "thickness_um", b.thickness_um);
    h5.set_attribute("/baseline", "half_width_um", b.half_width_um);
    h5.set_attribute("/baseline", "layers", static_cast<double>(b.layers));
    h5.set_attribute("/baseline", "cubes_per_side", static_cast<double>(b.cubes_per_side));
    h5.set_attribute("/baseline", "triangles_per_cube", static_cast<double>(b.triangles));
    h5.set_attribute("/baseline", "paths_per_wavelength", static_cast<double>(s.baseline_paths));
    h5.set_attribute("/baseline", "hue_deg", b.colour.hue_deg);
    h5.set_attribute("/baseline", "chroma", b.colour.chroma);
    h5.set_attribute("/baseline", "relative_spread", b.relative_spread);
    h5.set_attribute("/baseline", "flatness_chi2", b.flat_chi2);
    h5.set_attribute("/baseline", "flatness_p_value", b.flat_p);
}

void write_records(const fs::path& dir, const std::vector<Case>& cases,
                   const std::vector<CaseResult>& res, const std::vector<AngleRun>& runs,
                   const std::vector<Peak>& angle_peaks, const Baseline& baseline,
                   const Settings& s) {
    record::Hdf5Writer h5(dir / "spongy.h5");
    write_case_spectra(h5, cases, s);
    write_case_results(h5, cases, res, s);
    if (!runs.empty()) write_angles(h5, runs, angle_peaks, s);
    if (std::any_of(cases.begin(), cases.end(), [](const Case& c) { return c.other_medium; })) {
        write_other_route(h5, cases, res, s);
    }
    h5.set_attribute("/", "medium_route", s.route == MediumRoute::sphere ? "sphere" : "born");
    h5.set_attribute("/", "morphology",
                     s.morphology == geometry::SpongyMorphology::sphere ? "spheres" : "channel");
    write_baseline(h5, baseline, s);
    h5.set_attribute("/", "slab_thickness_um", s.slab.thickness_um);
    h5.set_attribute("/", "backing", s.slab.backing ? "melanin" : "none");
    h5.set_attribute("/", "paths_per_wavelength", static_cast<double>(s.paths));
    h5.set_attribute("/", "seed", static_cast<double>(s.seed));
    h5.set_attribute("/", "config_text", s.text);
    h5.set_attribute("/", "plumage_version", kVersion);
    h5.commit();
}

std::string run(const std::string& text, const fs::path& source, const fs::path& results_root,
                const RunLimits& limits) {
    refuse_limits("spongy", limits, "its Monte Carlo runs a fixed number of paths");
    StudyContext ctx(text, source, results_root, limits, true);
    const StudyProgress& clock = ctx.clock();
    const Settings s = read(ctx);  // read
    ctx.begin(s.name);
    std::vector<Case> cases;
    std::vector<CaseResult> results;
    for (const double f : s.fractions) {
        for (const double scale : s.scales_um) {
            const std::size_t i = cases.size();
            clock.say(fmt::format(
                "volume, scattering tables and slab: f = {}, {} = {} um", f,
                s.morphology == geometry::SpongyMorphology::sphere ? "a" : "Lambda", scale));
            cases.push_back(build_case(ctx, s, f, scale, i));  // build
            require_transport_thickness(cases.back(), s);
            measure_case(ctx, cases.back(), s, i);                     // measure
            results.push_back(compare_case(ctx, cases.back(), s, i));  // compare
        }
    }
    const std::vector<AngleRun> runs = measure_angles(ctx, cases.front(), s);
    Baseline baseline = measure_baseline(ctx, s);
    compare_baseline(baseline, s);
    std::vector<Peak> angle_peaks;
    for (std::size_t a = 0; a < runs.size(); ++a) {
        angle_peaks.push_back(peak_with_sigma(s.wavelengths_nm, {runs[a].r, runs[a].r_se},
                                              ctx.stream("spongy/angle-bootstrap", a)));
    }
    const fs::path out = ctx.out();  // report
    write_records(out, cases, results, runs, angle_peaks, baseline, s);
    clock.say("figures");
    draw_figures(out);
    write_report(out / "report.md", cases, results, runs, angle_peaks, baseline, s,
                 clock.elapsed_s(), ctx.run_time_by_stage());
    const fs::path final_path = ctx.commit();
    std::string summary = fmt::format("plumage: wrote {}:", final_path.string());
    for (std::size_t i = 0; i < cases.size(); ++i) {
        summary += fmt::format(
            " f={} {}={}um peak {:.0f}+-{:.0f} nm (2 n_eff L {:.0f});", cases[i].fraction,
            s.morphology == geometry::SpongyMorphology::sphere ? "a" : "L", cases[i].scale_um,
            results[i].peak.lambda_nm, results[i].peak.sigma_nm, results[i].bragg_nm);
    }
    return summary + fmt::format(" geometric-optics baseline: chroma {:.1f}, R spread {:.1f} %\n",
                                 baseline.colour.chroma, 100.0 * baseline.relative_spread);
}

void check(const std::string& text, const fs::path& source) {
    StudyContext ctx(text, source);
    read(ctx);
}

}  // namespace

StudyEntry spongy_study_entry() {
    return {"spongy",
            "structural colour of spongy keratin slabs from the volume (first Born + tracer)",
            check, run};
}

}  // namespace plumage::studies
