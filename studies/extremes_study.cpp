#include "studies/extremes_study.h"

#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <functional>
#include <iostream>
#include <memory>

#include <fmt/format.h>

#include "analysis/metrics/energy.h"
#include "analysis/models/filip2024.h"
#include "analysis/models/huang2022.h"
#include "analysis/models/lambertian.h"
#include "common/constants.h"
#include "common/error.h"
#include "common/seed.h"
#include "common/version.h"
#include "geometry/barbule.h"
#include "sim/optics/material.h"
#include "sim/tracer.h"
#include "studies/plots.h"
#include "studies/sections.h"
#include "studies/staged_directory.h"
#include "studies/study.h"
#include "studies/study_context.h"
#include "studies/study_file.h"
#include "studies/study_progress.h"
#include "studies/text_files.h"
#include "virtual_gonio/direction_sets.h"
#include "virtual_gonio/record/hdf5_file.h"

namespace plumage::studies {
namespace {

namespace fs = std::filesystem;
using geometry::BarbuleRowParams;

// Energy > 1 must exceed these many standard errors of the sampled mean to count.
constexpr double kEnergySigmas = 4.0;
// A quadrature energy counts when its error estimate is at most this share of max(1, value).
constexpr double kResolvedQuadrature = 0.05;

struct Settings {
    std::uint64_t seed = kDefaultSeed;
    std::uint64_t quanta = 20000;
    double polar_step = 40.0 * kDeg, max_polar = 80.0 * kDeg, azimuth_step = 90.0 * kDeg;
    std::vector<double> wavelengths;
    int grid_rings = 8;
    int albedo_polar_cells = 16;
    int barbules = 16, cells_per_barbule = 8;
    double relative_chord = 0.002;
    double max_normal_error = 2.0 * kDeg;
};

Settings read_settings(StudyFile& file, std::string& name, const fs::path& source) {
    Settings s;
    ParameterTable root = file.root();
    name = read_study_name(root, source);
    root.string("study", "extremes", {"extremes"}, "which study this file describes");
    s.seed = read_seed(root);
    ParameterTable sampling = root.table("sampling");
    s.quanta = static_cast<std::uint64_t>(
        sampling.integer("quanta", static_cast<long>(s.quanta), 100, 100000000,
                         "quanta per case, scatterer, incident direction and wavelength"));
    ParameterTable incidence = root.table("incidence");
    s.polar_step = incidence.angle_deg("polar_step_deg", s.polar_step, {0.0, 90.0, true, false},
                                       "step of the incident polar angles");
    s.max_polar =
        incidence.angle_deg("max_polar_deg", s.max_polar, {0.0, 90.0, false, true},
                            "largest regular incident polar angle (grazing cases add 89 and 89.9)");
    s.azimuth_step =
        incidence.angle_deg("azimuth_step_deg", s.azimuth_step, {0.0, 360.0, true, false},
                            "step of the incident azimuths");
    ParameterTable spectrum = root.table("spectrum");
    s.wavelengths = read_wavelengths(spectrum, kFilipWavelengths);
    ParameterTable evaluation = root.table("evaluation");
    s.grid_rings = static_cast<int>(
        evaluation.integer("grid_rings", s.grid_rings, 1, 256,
                           "polar rings of the eval()/pdf() check grid per hemisphere"));
    s.albedo_polar_cells = static_cast<int>(
        evaluation.integer("albedo_polar_cells", s.albedo_polar_cells, 2, 256,
                           "polar cells of the albedo quadrature (analysis/metrics/energy.h)"));
    ParameterTable tracer = root.table("tracer");
    s.barbules = static_cast<int>(
        tracer.integer("barbules", s.barbules, 1, 10000, "barbules in each explicit row"));
    s.cells_per_barbule = static_cast<int>(tracer.integer("cells_per_barbule", s.cells_per_barbule,
                                                          1, 10000, "cells along each barbule"));
    s.relative_chord = tracer.number("relative_chord", s.relative_chord, {0.0, 0.1, true, false},
                                     "largest facet-to-surface distance, in semi-major axes");
    s.max_normal_error = tracer.angle_deg("max_normal_error_deg", s.max_normal_error,
                                          {0.0, 28.0, true, false}, "largest facet-normal error");
    root.reject_unused();
    return s;
}

// A scatterer of one case, built on demand (building may throw InputError: rejected).
struct Built {
    std::shared_ptr<const Scatterer> scatterer;
    // Where quanta are aimed (µm): points uniform in this box; each enters the tracer's
    // top plane (at entry_z) upstream of its point, so that grazing light reaches the
    // structure instead of skimming over it. Models: a point at the origin.
    Eigen::Vector3d lo = Eigen::Vector3d::Zero(), hi = Eigen::Vector3d::Zero();
    double entry_z = 0.0;
};
struct Entry {
    std::string label;
    std::function<Built()> build;
    bool published_model = false;  // Filip's published presets: energy > 1 by construction
};
struct Case {
    std::string name;
    std::string description;
    std::vector<Vec3d> incidence;
    std::vector<Entry> entries;
};

// Per (incident direction, wavelength): what sampling found.
struct SampleTally {
    double sum = 0.0, sum_sq = 0.0;
    long nan = 0, inf = 0, negative = 0, malformed = 0, mismatches = 0, max_events = 0;
    std::string failure;
    void add(const SampleTally& o) {
        sum += o.sum, sum_sq += o.sum_sq, nan += o.nan, inf += o.inf, negative += o.negative;
        malformed += o.malformed, mismatches += o.mismatches, max_events += o.max_events;
        if (failure.empty()) failure = o.failure;
    }
};

void count_value(double v, long& nan, long& inf, long& negative) {
    if (std::isnan(v))
        ++nan;
    else if (std::isinf(v))
        ++inf;
    else if (v < 0.0)
        ++negative;
}

void count_vector(const Eigen::Ref<const Eigen::VectorXd>& v, long& nan, long& inf) {
    for (Eigen::Index i = 0; i < v.size(); ++i) {
        if (std::isnan(v[i])) return void(++nan);
        if (std::isinf(v[i])) return void(++inf);
    }
}

std::string exception_text(const std::exception& e) {
    if (dynamic_cast<const InputError*>(&e)) return std::string("InputError: ") + e.what();
    if (dynamic_cast<const InvariantError*>(&e)) return std::string("InvariantError: ") + e.what();
    return e.what();
}

// `count` quanta from wi at λ, stream (seed, first + q), aimed at points uniform in b's
// box and entering the top plane upstream of them. Fixed chunks summed in order: the
// same numbers for any thread count.
SampleTally play(const Built& b, const Vec3d& wi, double lambda, std::uint64_t seed,
                 std::uint64_t first, std::uint64_t count) {
    const Scatterer& scatterer = *b.scatterer;
    const auto* tracer = dynamic_cast<const sim::ExplicitScatterer*>(&scatterer);
    const long lobes = static_cast<long>(scatterer.lobe_names().size());
    constexpr std::uint64_t kChunk = 256;
    const long chunks = static_cast<long>((count + kChunk - 1) / kChunk);
    std::vector<SampleTally> parts(static_cast<std::size_t>(chunks));
#pragma omp parallel for schedule(dynamic)
    for (long c = 0; c < chunks; ++c) {
        SampleTally& t = parts[static_cast<std::size_t>(c)];
        try {
            const std::uint64_t end = std::min(count, (static_cast<std::uint64_t>(c) + 1) * kChunk);
            for (std::uint64_t q = static_cast<std::uint64_t>(c) * kChunk; q < end; ++q) {
                Rng rng(seed, first + q);
                Eigen::Vector3d aim;
                for (int k = 0; k < 3; ++k) aim[k] = b.lo[k] + rng.uniform() * (b.hi[k] - b.lo[k]);
                const double climb = (b.entry_z - aim.z()) / wi.z();
                const Vec2 position(aim.x() + climb * wi.x(), aim.y() + climb * wi.y());
                std::optional<ScatterEvent> event;
                if (tracer) {
                    const sim::PathResult path = tracer->trace(wi, lambda, position, rng);
                    t.mismatches += path.medium_mismatches;
                    t.max_events += path.reached_max_events ? 1 : 0;
                    event = path.event;
                } else {
                    event = scatterer.sample(wi, lambda, position, rng);
                }
                if (!event) continue;  // absorbed: weight 0
                const double w = event->weight;
                const long bad = t.nan + t.inf + t.negative;
                count_value(w, t.nan, t.inf, t.negative);
                if (t.nan + t.inf + t.negative == bad) t.sum += w, t.sum_sq += w * w;
                const long before = t.nan + t.inf;
                count_vector(event->wo, t.nan, t.inf);
                count_vector(event->exit_position_um, t.nan, t.inf);
                if (t.nan + t.inf == before && std::abs(event->wo.norm() - 1.0) > 1e-6)
                    ++t.malformed;
                if (event->lobe < 0 || event->lobe >= lobes) ++t.malformed;
            }
        } catch (const std::exception& e) {
            t.failure = exception_text(e);
        }
    }
    SampleTally total;
    for (const auto& p : parts) total.add(p);
    return total;
}

// Per (incident direction, wavelength): eval() and pdf() on the check grid, and the
// energy by quadrature (+ the discrete T lobe of the Huang model).
struct EvalTally {
    long values = 0, nan = 0, inf = 0, negative = 0;
    double energy = 0.0, energy_error = 0.0;
    std::string failure;
};

std::vector<Vec3d> check_directions(const Vec3d& wi, int rings) {
    std::vector<Vec3d> out;
    for (double sign : {1.0, -1.0}) {
        for (int r = 0; r < rings; ++r) {
            const double theta = (r + 0.5) / rings * 0.5 * kPi;
            for (int a = 0; a < 2 * rings; ++a) {
                Vec3d w = gonio::direction_from_angles(theta, (a + 0.25) * kPi / rings);
                w.z() *= sign;
                out.push_back(w);
            }
        }
    }
    // Where lobes are narrow or the formulas divide: mirror, retro, straight through,
    // the normals and the horizon.
    const double phi_i = std::atan2(wi.y(), wi.x());
    out.push_back(Vec3d(-wi.x(), -wi.y(), wi.z()));
    out.push_back(wi);
    out.push_back(-wi);
    out.push_back(Vec3d::UnitZ());
    out.push_back(-Vec3d::UnitZ());
    out.push_back(Vec3d(std::cos(phi_i + kPi), std::sin(phi_i + kPi), 1e-9).normalized());
    out.push_back(Vec3d(std::cos(phi_i), std::sin(phi_i), 1e-9).normalized());
    return out;
}

EvalTally evaluate(const Scatterer& scatterer, const Vec3d& wi, double lambda, const Settings& s) {
    EvalTally t;
    try {
        std::vector<double> per_lobe(scatterer.lobe_names().size());
        for (const Vec3d& wo : check_directions(wi, s.grid_rings)) {
            const double f = scatterer.eval(wi, wo, lambda, per_lobe);
            count_value(f, t.nan, t.inf, t.negative);
            for (double v : per_lobe) count_value(v, t.nan, t.inf, t.negative);
            count_value(scatterer.pdf(wi, wo, lambda), t.nan, t.inf, t.negative);
            t.values += 2 + static_cast<long>(per_lobe.size());
        }
        const analysis::AlbedoEstimate a =
            analysis::directional_albedo(scatterer, wi, lambda, s.albedo_polar_cells);
        double discrete = 0.0;
        if (const auto* huang = dynamic_cast<const analysis::Huang2022Bsdf*>(&scatterer))
            discrete = huang->t_lobe_mass(wi);
        t.energy = a.value + discrete;
        t.energy_error = a.error_estimate;
        count_value(t.energy, t.nan, t.inf, t.negative);
        count_value(t.energy_error, t.nan, t.inf, t.negative);
        ++t.values;
    } catch (const std::exception& e) {
        t.failure = exception_text(e);
    }
    return t;
}

double clear_spacing(const geometry::BarbuleCellParams& cell, double mu) {
    return std::max(1.25, 1.02 * geometry::minimum_spacing(cell, mu));
}

void write_h5(const fs::path& path, const std::vector<double>& energy,
              const std::vector<double>& error, const std::vector<double>& eval,
              const std::vector<double>& eval_error, const std::vector<double>& flags) {
    record::Hdf5Writer h5(path);
    const std::vector<std::uint64_t> dims = {energy.size()};
    h5.write("energy/sampled", std::span<const double>(energy), dims,
             {{"units", "1"},
              {"description",
               "largest mean quantum weight over incident directions and wavelengths, per row of "
               "extremes.csv (NaN: rejected)"}});
    h5.write("energy/sampled_standard_error", std::span<const double>(error), dims,
             {{"units", "1"}, {"description", "standard error of energy/sampled"}});
    h5.write(
        "energy/evaluated", std::span<const double>(eval), dims,
        {{"units", "1"},
         {"description",
          "largest resolved directional albedo by quadrature plus discrete lobes (NaN: no eval, "
          "none resolved, or rejected)"}});
    h5.write("energy/evaluated_error", std::span<const double>(eval_error), dims,
             {{"units", "1"}, {"description", "quadrature error estimate of energy/evaluated"}});
    h5.write("status", std::span<const double>(flags), dims,
             {{"units", "1"},
              {"description",
               "0 ok, 1 numerical failure, 2 energy > 1, 3 energy > 1 by the published model's "
               "construction, -1 rejected input"}});
    h5.set_attribute("/", "rows", "in the order of extremes.csv (case, scatterer)");
    h5.set_attribute("/", "plumage_version", kVersion);
    h5.commit();
}

std::string method_section(const Settings& s) {
    return fmt::format(
        "For every case, scatterer, incident direction and wavelength ({} wavelengths, {}–{} nm): "
        "{} quanta through sample(), each event checked (finite weight ≥ 0, unit direction, lobe "
        "in "
        "range, finite exit position); energy = mean weight (absorbed quanta count 0) ± its "
        "standard "
        "error σ. Scatterers that evaluate f: eval() per lobe and pdf() on {} × {} directions per "
        "hemisphere plus the mirror, retro, straight-through, normal and horizon directions, every "
        "value checked; energy by quadrature = directional albedo (analysis/metrics/energy.h, {} "
        "polar "
        "cells) "
        "plus the Huang model's discrete T lobe, ± the quadrature's error estimate (the change "
        "from "
        "half the cells). Energy > 1 counts when it exceeds 1 by more than {:.0f} σ (sampled) or "
        "the "
        "quadrature error (evaluated). The table shows the largest energy over the directions and "
        "wavelengths and where it occurs. The quadrature resolves smooth f (Filip, Lambertian) but "
        "not "
        "the Huang model's R lobe where it narrows to a spike (grazing light, θ_d → 0, the b = "
        "1e-3 "
        "strip): a quadrature counts only when its error estimate is at most {:.0f} % of max(1, "
        "value); "
        "the others are counted as unresolved and the sampled energy is the measure there. Per "
        "row, "
        "the table counts the resolved items whose quadrature energy agrees with the sampled one "
        "(within 4 σ + the quadrature error + 0.01): a coarse grid can miss a narrow lobe at both "
        "resolutions and look resolved while under-estimating it (the Huang R lobe at grazing "
        "light "
        "with few cells); with cells enough, the Huang model's sample() and eval() agree "
        "(tests/analysis/huang2022_test.cpp). "
        "Explicit rows: {} barbules "
        "× {} cells, facets within {} semi-major axes of the surface; quanta are aimed at points "
        "spread over the middle half of the patch and the structure's whole height, entering the "
        "tracer's top plane upstream of them, so that grazing light reaches the barbules instead "
        "of "
        "skimming over the patch.\n\n",
        s.wavelengths.size(), s.wavelengths.front(), s.wavelengths.back(), s.quanta, s.grid_rings,
        2 * s.grid_rings, s.albedo_polar_cells, kEnergySigmas, 100.0 * kResolvedQuadrature,
        s.barbules, s.cells_per_barbule, s.relative_chord);
}

// ---- Build: the cases, each a list of scatterers built on demand. ---------------------------

// Entries for the scatterers a case may hold.
struct Scatterers {
    const Settings& s;

    Entry huang(const BarbuleRowParams& p) const {
        return Entry{"Huang 2022", [p] {
                         return Built{std::make_shared<analysis::Huang2022Bsdf>(
                             analysis::huang_params_of(p))};
                     }};
    }
    Entry tracer(const BarbuleRowParams& p, sim::BarbuleRowMaterials materials = {},
                 std::string label = "explicit barbules") const {
        const Settings* settings = &s;
        return Entry{
            std::move(label), [p, materials, settings] {
                geometry::TessellationTolerance tolerance;
                tolerance.max_chord_um = settings->relative_chord * p.cell.semi_major_um;
                tolerance.max_normal_error_rad = settings->max_normal_error;
                const geometry::BarbuleRow row = geometry::build_barbule_row(p, tolerance);
                const Eigen::AlignedBox3d box = row.bounds();
                auto traced = std::make_shared<sim::ExplicitScatterer>(
                    sim::barbule_row_scene(row, materials));
                // Aimed at the middle half of the patch (away from its edges), at
                // every height of the structure.
                Eigen::Vector3d half = 0.25 * box.sizes();
                half.z() = 0.5 * box.sizes().z();
                return Built{traced, box.center() - half, box.center() + half, traced->top_z_um()};
            }};
    }
    static Entry filip(const std::string& preset) {
        return Entry{"Filip 2024 " + preset,
                     [preset] {
                         return Built{std::make_shared<analysis::Filip2024Brdf>(
                             analysis::filip2024_preset(preset), "filip2024 " + preset)};
                     },
                     true};
    }
    static Entry lambertian(double albedo) {
        return Entry{fmt::format("Lambertian ρ = {}", albedo), [albedo] {
                         return Built{std::make_shared<analysis::LambertianScatterer>(albedo)};
                     }};
    }
    std::vector<Entry> every(const BarbuleRowParams& p) const {
        std::vector<Entry> list = {huang(p)};
        for (std::string_view preset : analysis::filip2024_preset_names())
            list.push_back(filip(std::string(preset)));
        list.push_back(lambertian(0.8));
        list.push_back(lambertian(1.0));
        list.push_back(tracer(p));
        return list;
    }
};

// Huang's rock-dove fit (geometry/barbule.h defaults) at the study's patch size, changed.
BarbuleRowParams rock_dove_with(const Settings& s,
                                const std::function<void(BarbuleRowParams&)>& change = {}) {
    BarbuleRowParams p;
    p.barbules = s.barbules;
    p.cells_per_barbule = s.cells_per_barbule;
    if (change) change(p);
    return p;
}

// The reference, grazing light, and the film and arc-shape extremes.
void film_and_arc_cases(const Settings& s, const std::vector<Vec3d>& regular,
                        std::vector<Case>& cases) {
    const Scatterers make{s};
    auto grazing = [&](double theta_deg) {
        std::vector<Vec3d> out;
        for (double phi = 0.0; phi < 2.0 * kPi - 1e-9; phi += s.azimuth_step)
            out.push_back(gonio::direction_from_angles(theta_deg * kDeg, phi));
        return out;
    };
    const BarbuleRowParams rock_dove = rock_dove_with(s);
    cases.push_back({"reference",
                     "the rock dove (Huang's fit), the Filip presets, Lambertian reflectors",
                     regular, make.every(rock_dove)});
    cases.push_back(
        {"grazing 89°", "light at 89° from the normal", grazing(89.0), make.every(rock_dove)});
    cases.push_back(
        {"grazing 89.9°", "light at 89.9° from the normal", grazing(89.9), make.every(rock_dove)});
    for (const double d : {0.0, 50.0}) {
        const auto p =
            rock_dove_with(s, [d](BarbuleRowParams& q) { q.cell.film_thickness_um = d; });
        cases.push_back({d == 0.0 ? "film d = 0" : "film d = 50 µm",
                         d == 0.0 ? "no keratin film: the film reflects nothing"
                                  : "a thick coherent film: dense Airy fringes",
                         regular,
                         {make.huang(p), make.tracer(p)}});
    }
    // A strip: the arc's smallest radius of curvature b²A = 1e-5 µm leaves no room for a
    // longitudinal arc or a deeper melanin layer in the explicit cell.
    const auto p = rock_dove_with(s, [](BarbuleRowParams& q) { q.cell.b = 1e-3; });
    const auto strip = rock_dove_with(s, [](BarbuleRowParams& q) {
        q.cell.b = 1e-3;
        q.cell.theta_d = 0.0;
        q.cell.melanin_depth_um = 0.5e-6 * q.cell.semi_major_um;
    });
    cases.push_back(
        {"b = 1e-3",
         "a flat strip. Explicit cells straight (θ_d = 0) with the melanin 5e-6 µm "
         "under the film: the edges' radius of curvature b²A = 1e-5 µm leaves no room for "
         "more. That gap is below the tracer's spawn offset (about 1e-4 µm at 50 µm from "
         "the origin, sim/scene.h): light crosses the melanin unseen and leaves below, "
         "finite and energy-bounded but geometrically wrong, where the model keeps its TRT",
         regular,
         {make.huang(p), make.tracer(strip)}});
    auto circular = rock_dove_with(s, [](BarbuleRowParams& q) { q.cell.b = 1.0; });
    circular.H = clear_spacing(circular.cell, circular.mu);
    cases.push_back(
        {"b = 1",
         fmt::format("circular arcs (H = {:.3f}: clear of interpenetration)", circular.H),
         regular,
         {make.huang(circular), make.tracer(circular)}});
    const auto sliver =
        rock_dove_with(s, [](BarbuleRowParams& q) { q.cell.phi1 = q.cell.phi0 + 1e-4; });
    cases.push_back({"φ1 − φ0 = 1e-4 rad",
                     "a sliver of arc: almost all light passes",
                     regular,
                     {make.huang(sliver), make.tracer(sliver)}});
    for (double span : {kPi, 2.0 * kPi}) {
        auto q =
            rock_dove_with(s, [span](BarbuleRowParams& r) { r.cell.phi1 = r.cell.phi0 + span; });
        q.H = clear_spacing(q.cell, q.mu);
        cases.push_back({span < 4.0 ? "φ1 − φ0 = π" : "φ1 − φ0 = 2π",
                         fmt::format("{} (H = {:.3f})",
                                     span < 4.0 ? "half an ellipse" : "a closed ellipse", q.H),
                         regular,
                         {make.huang(q), make.tracer(q)}});
    }
}

// Spacing and orientation extremes: overlap, the interpenetration limit, gaps, θ_d → 0, μ → ±90°.
void spacing_cases(const Settings& s, const std::vector<Vec3d>& regular, std::vector<Case>& cases) {
    const Scatterers make{s};
    const auto overlap = rock_dove_with(s, [](BarbuleRowParams& q) { q.H = 0.3; });
    cases.push_back({"H = 0.3 (overlap)",
                     "barbules closer than their width: the model takes it, the geometry "
                     "refuses interpenetrating barbules",
                     regular,
                     {make.huang(overlap), make.tracer(overlap)}});
    auto limit = rock_dove_with(s);
    limit.H = 1.001 * geometry::minimum_spacing(limit.cell, limit.mu);
    cases.push_back({"H at the interpenetration limit",
                     fmt::format("H = {:.4f}, 1.001 × the smallest spacing", limit.H),
                     regular,
                     {make.huang(limit), make.tracer(limit)}});
    const auto gaps = rock_dove_with(s, [](BarbuleRowParams& q) { q.H = 20.0; });
    cases.push_back({"H = 20 (gaps)",
                     "barbules far apart: most light passes between them",
                     regular,
                     {make.huang(gaps), make.tracer(gaps)}});
    const auto flat = rock_dove_with(s, [](BarbuleRowParams& q) { q.cell.theta_d = 1e-4; });
    cases.push_back({"θ_d = 1e-4 rad",
                     "an almost flat longitudinal profile: a needle-thin lobe in θ",
                     regular,
                     {make.huang(flat), make.tracer(flat)}});
    for (double mu_deg : {80.0, -80.0}) {
        const auto p = rock_dove_with(s, [mu_deg](BarbuleRowParams& q) { q.mu = mu_deg * kDeg; });
        cases.push_back({fmt::format("μ = {:+.0f}°", mu_deg),
                         "the barb plane tilted almost on edge",
                         regular,
                         {make.huang(p), make.tracer(p)}});
    }
}

// Material and scale extremes: strong absorption, tiny and huge barbules, Filip at its range edges.
void material_and_scale_cases(const Settings& s, const std::vector<Vec3d>& regular,
                              std::vector<Case>& cases) {
    const Scatterers make{s};
    sim::BarbuleRowMaterials dark;
    dark.film = std::make_shared<optics::ConstantMaterial>("n = 1.55 + 10i",
                                                           std::complex<double>(1.55, 10.0));
    dark.melanin = sim::constant_albedo(0.0);
    cases.push_back({"strong absorption",
                     "a k = 10 film over black melanin (the Huang model has no absorption "
                     "parameter); a black Lambertian reflector",
                     regular,
                     {make.tracer(rock_dove_with(s), dark, "explicit barbules, k = 10 film"),
                      Scatterers::lambertian(0.0)}});
    for (double a : {0.5, 500.0}) {
        auto p = rock_dove_with(s);
        p.cell.semi_major_um = a;
        p.cell.cell_length_um = 2.0 * a;
        p.cell.melanin_depth_um = 0.03 * a;
        cases.push_back({fmt::format("semi-major axis {} µm", a),
                         "every length scaled but the film's 0.59 µm (the Huang model is "
                         "scale-free: not applicable)",
                         regular,
                         {make.tracer(p)}});
    }
    analysis::Filip2024Parameters edge = analysis::filip2024_preset("parrot");
    edge.d_w = 0.001;
    edge.gamma = 50.0;
    edge.theta_max_rad = 1.0 * kDeg;
    cases.push_back({"Filip at its range edges",
                     "the parrot preset with a hard mask (d_w = 0.001), γ = 50, θmax = 1°",
                     regular,
                     {Entry{"Filip 2024 parrot, edges", [edge] {
                                return Built{std::make_shared<analysis::Filip2024Brdf>(
                                    edge, "filip2024 edges")};
                            }}}});
}

std::vector<Case> make_cases(const Settings& s) {
    // Incident directions: the regular grid (grazing cases add their own at its azimuths).
    const std::vector<Vec3d> regular =
        analysis::hemisphere_grid(s.polar_step, s.max_polar, s.azimuth_step);
    std::vector<Case> cases;
    film_and_arc_cases(s, regular, cases);
    spacing_cases(s, regular, cases);
    material_and_scale_cases(s, regular, cases);
    return cases;
}

// ---- Measure and compare. --------------------------------------------------------------------

// Sampling, parallel over quanta inside play(): per item (direction, wavelength) the mean
// weight and its standard error; the row keeps the largest and flags energy > 1.
void sample_energy(const StudyContext& ctx, const Built& built, const Case& c, const Settings& s,
                   std::uint64_t& stream, ExtremesRow& row, std::vector<double>& item_mean,
                   std::vector<double>& item_se) {
    const std::size_t items = c.incidence.size() * s.wavelengths.size();
    bool first_energy = true;
    item_mean.assign(items, 0.0);
    item_se.assign(items, 0.0);
    for (std::size_t it = 0; it < items; ++it) {
        const Vec3d& wi = c.incidence[it / s.wavelengths.size()];
        const double lambda = s.wavelengths[it % s.wavelengths.size()];
        // Each item its own root (common/seed.h), numbered across the study's entries.
        const SampleTally t =
            play(built, wi, lambda, ctx.stream("extremes/energy", ++stream), 0, s.quanta);
        row.samples += s.quanta;
        row.nan += t.nan, row.inf += t.inf, row.negative += t.negative,
            row.malformed += t.malformed;
        row.medium_mismatches += t.mismatches, row.reached_max_events += t.max_events;
        if (row.failure.empty() && !t.failure.empty()) row.failure = t.failure;
        const double n = static_cast<double>(s.quanta);
        const double mean = t.sum / n;
        const double se = std::sqrt(std::max(0.0, t.sum_sq / n - mean * mean) / (n - 1.0));
        item_mean[it] = mean, item_se[it] = se;
        if (mean - kEnergySigmas * se - 1e-9 > 1.0) row.energy_excess = true;
        if (first_energy || mean > row.energy) {
            first_energy = false;
            row.energy = mean, row.energy_error = se, row.energy_lambda_nm = lambda;
            row.energy_theta_deg = std::acos(std::clamp(wi.z(), -1.0, 1.0)) / kDeg;
            row.energy_phi_deg = std::atan2(wi.y(), wi.x()) / kDeg;
        }
    }
}

// Evaluation, parallel over (direction, wavelength): eval()/pdf() checked, the energy by
// quadrature where it resolves, compared with the sampled one.
void evaluate_energy(const Scatterer& sc, const Case& c, const Settings& s,
                     const std::vector<double>& item_mean, const std::vector<double>& item_se,
                     ExtremesRow& row) {
    const std::size_t items = item_mean.size();
    row.evaluated = true;
    std::vector<EvalTally> evals(items);
#pragma omp parallel for schedule(dynamic)
    for (long it = 0; it < static_cast<long>(items); ++it) {
        const std::size_t i = static_cast<std::size_t>(it);
        evals[i] = evaluate(sc, c.incidence[i / s.wavelengths.size()],
                            s.wavelengths[i % s.wavelengths.size()], s);
    }
    bool first = true;
    for (std::size_t it = 0; it < items; ++it) {
        const EvalTally& t = evals[it];
        row.evaluations += static_cast<std::uint64_t>(t.values);
        row.nan += t.nan, row.inf += t.inf, row.negative += t.negative;
        if (row.failure.empty() && !t.failure.empty()) row.failure = t.failure;
        if (!t.failure.empty() || !std::isfinite(t.energy)) continue;
        ++row.eval_items;
        if (t.energy_error > kResolvedQuadrature * std::max(1.0, t.energy)) {
            ++row.eval_unresolved;
            continue;
        }
        if (t.energy - t.energy_error - 1e-6 > 1.0) row.energy_excess = true;
        if (std::abs(t.energy - item_mean[it]) <=
            kEnergySigmas * item_se[it] + t.energy_error + 0.01)
            ++row.eval_agreeing;
        if (first || t.energy > row.eval_energy) {
            first = false;
            const Vec3d& wi = c.incidence[it / s.wavelengths.size()];
            row.eval_energy = t.energy, row.eval_energy_error = t.energy_error;
            row.eval_lambda_nm = s.wavelengths[it % s.wavelengths.size()];
            row.eval_theta_deg = std::acos(std::clamp(wi.z(), -1.0, 1.0)) / kDeg;
            row.eval_phi_deg = std::atan2(wi.y(), wi.x()) / kDeg;
        }
    }
}

// One (case, scatterer): built (or rejected by name), sampled, evaluated.
ExtremesRow check_entry(const StudyContext& ctx, const Case& c, const Entry& e, const Settings& s,
                        std::uint64_t& stream) {
    const StudyProgress& clock = ctx.clock();
    ExtremesRow row;
    row.case_name = c.name;
    row.scatterer = e.label;
    clock.say(fmt::format("{}: {}", c.name, e.label));
    Built built;
    try {
        built = e.build();
    } catch (const InputError& err) {
        row.rejected = true;
        row.rejection = err.what();
        return row;
    }
    std::vector<double> item_mean, item_se;
    sample_energy(ctx, built, c, s, stream, row, item_mean, item_se);
    if (built.scatterer->can_evaluate())
        evaluate_energy(*built.scatterer, c, s, item_mean, item_se, row);
    row.by_construction = row.energy_excess && e.published_model;
    return row;
}

// ---- Report. ---------------------------------------------------------------------------------

std::string status_of(const ExtremesRow& r) {
    if (r.rejected) return "rejected (input)";
    if (r.numerical_violation()) return "**NUMERICAL FAILURE**";
    if (r.energy_violation()) return "**ENERGY > 1**";
    if (r.by_construction) return "energy > 1 by construction";
    return "ok";
}
bool resolved(const ExtremesRow& r) {
    return !r.rejected && r.evaluated && r.eval_items > r.eval_unresolved;
}
std::string where(double theta, double phi, double lambda) {
    return fmt::format("θ {:.1f}°, φ {:.0f}°, {:.0f} nm", theta, phi, lambda);
}
std::string quote(const std::string& t) {
    std::string q = "\"";
    for (char ch : t) q += ch == '"' ? std::string("\"\"") : std::string(1, ch);
    return q + "\"";
}

// The results table's row (and a failure line below it).
std::string table_row(const ExtremesRow& r) {
    const std::string st = status_of(r);
    if (r.rejected) {
        return fmt::format("| {} | {} | {} | — | — | — | — | — | — | {} | | |\n", r.case_name,
                           r.scatterer, st, r.rejection);
    }
    const std::string eval =
        !r.evaluated ? std::string("— (no eval)")
        : r.eval_unresolved == r.eval_items
            ? fmt::format("unresolved ({} of {})", r.eval_unresolved, r.eval_items)
            : fmt::format("{:.4f} ± {:.4f} ({}); agrees with sampling in {} of {}{}", r.eval_energy,
                          r.eval_energy_error,
                          where(r.eval_theta_deg, r.eval_phi_deg, r.eval_lambda_nm),
                          r.eval_agreeing, r.eval_items - r.eval_unresolved,
                          r.eval_unresolved > 0 ? fmt::format(", {} unresolved", r.eval_unresolved)
                                                : std::string());
    std::string row = fmt::format(
        "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {:.4f} ± {:.4f} ({}) | {} | {} |\n",
        r.case_name, r.scatterer, st, r.samples, r.evaluations, r.nan, r.inf, r.negative,
        r.malformed, r.energy, r.energy_error,
        where(r.energy_theta_deg, r.energy_phi_deg, r.energy_lambda_nm), eval,
        r.scatterer.rfind("explicit", 0) == 0
            ? fmt::format("{}, {}", r.medium_mismatches, r.reached_max_events)
            : std::string("—"));
    if (!r.failure.empty())
        row += fmt::format("| | ↳ failure: {} | | | | | | | | | | |\n", r.failure);
    return row;
}

// extremes.csv (every row), energy.csv (the plot's bars) and extremes.h5.
void write_records(const fs::path& dir, const ExtremesResult& result) {
    std::ofstream csv(dir / "extremes.csv");
    csv << "case,scatterer,status,quanta,values_checked,nan,inf,negative,malformed,energy,energy_"
           "error,theta_deg,phi_deg,"
           "lambda_nm,eval_energy,eval_energy_error,medium_mismatches,max_event_paths,failure_or_"
           "rejection\n";  // -1: n/a
    std::ofstream bars(dir / "energy.csv");
    bars << "label,energy,error,status\n";
    std::vector<double> energy, error, eval, eval_error, flags;
    for (const auto& r : result.rows) {
        if (!r.rejected) {
            const double quadrature = resolved(r) ? r.eval_energy : 0.0;
            bars << fmt::format(
                "{},{:.6g},{:.6g},{}\n", quote(r.case_name + " · " + r.scatterer),
                std::max(r.energy, quadrature),
                r.energy >= quadrature ? kEnergySigmas * r.energy_error : r.eval_energy_error,
                r.energy_violation() ? "violation"
                : r.by_construction  ? "by construction"
                                     : "ok");
        }
        csv << fmt::format(
            "{},{},{},{},{},{},{},{},{},{:.9g},{:.3g},{:.3f},{:.3f},{:.1f},{:.9g},{:.3g},{},{},{}"
            "\n",
            quote(r.case_name), quote(r.scatterer), quote(status_of(r)), r.samples, r.evaluations,
            r.nan, r.inf, r.negative, r.malformed, r.energy, r.energy_error, r.energy_theta_deg,
            r.energy_phi_deg, r.energy_lambda_nm, resolved(r) ? r.eval_energy : -1.0,
            resolved(r) ? r.eval_energy_error : -1.0, r.medium_mismatches, r.reached_max_events,
            quote(r.rejected ? r.rejection : r.failure));
        energy.push_back(r.rejected ? std::nan("") : r.energy);
        error.push_back(r.rejected ? std::nan("") : r.energy_error);
        eval.push_back(resolved(r) ? r.eval_energy : std::nan(""));
        eval_error.push_back(resolved(r) ? r.eval_energy_error : std::nan(""));
        flags.push_back(r.rejected                ? -1.0
                        : r.numerical_violation() ? 1.0
                        : r.energy_violation()    ? 2.0
                        : r.by_construction       ? 3.0
                                                  : 0.0);
    }
    close_written(csv, dir / "extremes.csv");
    close_written(bars, dir / "energy.csv");
    write_h5(dir / "extremes.h5", energy, error, eval, eval_error, flags);
}

// The summary at the top of the report: violations, by-construction excesses, rejected inputs.
std::string summary_section(const ExtremesResult& result) {
    std::string numerical = "none", energy = "none", construction, rejected;
    if (result.numerical_violations > 0) {
        numerical =
            fmt::format("{} (see the rows marked NUMERICAL FAILURE)", result.numerical_violations);
    }
    if (result.energy_violations > 0)
        energy = fmt::format("{} (see the rows marked ENERGY > 1)", result.energy_violations);
    for (const auto& r : result.rows) {
        if (r.by_construction) {
            construction += fmt::format(
                "- {}, {}: sampled {:.3f} ± {:.3f} ({}){}\n", r.scatterer, r.case_name, r.energy,
                r.energy_error, where(r.energy_theta_deg, r.energy_phi_deg, r.energy_lambda_nm),
                resolved(r) ? fmt::format("; by quadrature {:.3f} ± {:.3f} ({})", r.eval_energy,
                                          r.eval_energy_error,
                                          where(r.eval_theta_deg, r.eval_phi_deg, r.eval_lambda_nm))
                            : std::string());
        }
        if (r.rejected)
            rejected += fmt::format("- {}, {}: {}\n", r.scatterer, r.case_name, r.rejection);
    }
    return fmt::format(
               "**Numerical violations** (NaN, Inf, negative values, malformed events, unexpected "
               "exceptions): {}.\n\n**Energy > 1** beyond its error, other than by a published "
               "model's "
               "construction: {}.\n\n",
               numerical, energy) +
           "**Energy > 1 by construction of the published parameters** (the model's, not a "
           "numerical failure; "
           "analysis/models/filip2024.h explains why: the Filip 2024 BRDF has no energy "
           "normalisation, "
           "and the "
           "flamingo and stork presets add a retro-reflective term the size of the background, the "
           "rooster's "
           "specular highlight grows as E^12 at grazing light):\n\n" +
           (construction.empty() ? std::string("none\n") : construction) + "\n" +
           "**Rejected inputs** (InputError naming the parameter, as designed; not failures):\n\n" +
           (rejected.empty() ? std::string("none\n") : rejected) + "\n";
}

void write_report(const fs::path& path, const Settings& s, const std::vector<Case>& cases,
                  const ExtremesResult& result, const std::string& run_time) {
    std::string case_list, table =
                               "| case | scatterer | status | quanta | values checked | NaN | Inf "
                               "| negative | malformed | energy, sampled ± σ "
                               "(where) | energy, eval ± quadrature error (where) | tracer: medium "
                               "mismatches, max-event paths |\n"
                               "|---|---|---|---|---|---|---|---|---|---|---|---|\n";
    for (const auto& r : result.rows) table += table_row(r);
    for (const Case& c : cases) {
        std::string who;
        for (const Entry& e : c.entries) who += (who.empty() ? "" : ", ") + e.label;
        case_list += fmt::format("- **{}** — {}; {} incident directions. Scatterers: {}.\n", c.name,
                                 c.description, c.incidence.size(), who);
    }
    std::ofstream report(path);
    report << "# Extremes: stiff and extreme parameters through every scatterer\n\n"
           << summary_section(result) << "## Method\n\n"
           << method_section(s) << "## Cases\n\n"
           << case_list << "\n"
           << "## Results\n\n![largest energy per case and scatterer](energy.png)\n\n"
           << table << "\n"
           << "Medium mismatches (explicit rows) count rays that arrived on a side of a surface "
              "they did not leave "
              "into: where features are thinner than the tracer's single-precision spawn offset "
              "(the 5e-6 µm "
              "melanin gap of the b = 1e-3 strip, the 500 µm barbules far from the origin), paths "
              "are geometrically "
              "approximate but stay finite and energy-bounded (sim/scene.h); they are reported, "
              "not failures.\n\n"
           << run_time
           << fmt::format(
                  "---\nRun time {:.0f} s (plumage {}). Every number: extremes.csv, extremes.h5.\n",
                  result.wall_seconds, kVersion);
    close_written(report, path);
}

}  // namespace

ExtremesResult run_extremes_study(const std::string& study_text, const fs::path& source_name,
                                  const fs::path& results_root, bool progress) {
    StudyContext ctx(study_text, source_name, results_root, {}, progress);
    const StudyProgress& clock = ctx.clock();
    std::string name;
    const Settings s = read_settings(ctx.file(), name, source_name);  // read
    ctx.begin(name);
    const std::vector<Case> cases = make_cases(s);  // build (each scatterer on demand)
    ExtremesResult result;
    std::uint64_t stream = 0;
    for (const Case& c : cases) {  // measure and compare
        for (const Entry& e : c.entries) result.rows.push_back(check_entry(ctx, c, e, s, stream));
    }
    for (const auto& r : result.rows) {
        result.numerical_violations += r.numerical_violation() ? 1 : 0;
        result.energy_violations += r.energy_violation() ? 1 : 0;
        result.by_construction += r.energy_excess && r.by_construction ? 1 : 0;
        result.rejected += r.rejected ? 1 : 0;
    }
    const fs::path out = ctx.out();  // report
    write_records(out, result);
    run_plot("energy_bars", out / "energy.csv", out / "energy.png");
    result.wall_seconds = clock.elapsed_s();
    write_report(out / "report.md", s, cases, result, ctx.run_time_by_stage());
    result.output_dir = ctx.commit();
    return result;
}

void check_extremes_study(const std::string& study_text, const fs::path& source_name) {
    StudyContext ctx(study_text, source_name);
    std::string name;
    read_settings(ctx.file(), name, source_name);
}

namespace {

// `plumage run`: the run, and the summary printed on stdout.
std::string run_from_command_line(const std::string& text, const fs::path& source,
                                  const fs::path& root, const RunLimits& limits) {
    refuse_limits("extremes", limits,
                  "its checks are exact sweeps over fixed grids, not progressive measurements");
    const auto r = run_extremes_study(text, source, root, true);
    return fmt::format(
        "plumage: wrote {} in {:.0f} s: numerical violations {}, energy > 1 {}, energy > 1 by "
        "the published model's construction {} (open report.md)\n",
        r.output_dir.string(), r.wall_seconds, r.numerical_violations, r.energy_violations,
        r.by_construction);
}

}  // namespace

StudyEntry extremes_study_entry() {
    return {"extremes", "stiff and extreme cases through every scatterer", check_extremes_study,
            run_from_command_line};
}

}  // namespace plumage::studies
