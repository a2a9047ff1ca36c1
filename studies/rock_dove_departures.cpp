#include "studies/rock_dove_departures.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>

#include <fmt/format.h>

#include "analysis/metrics/compare.h"
#include "analysis/models/huang2022_trt_exit.h"
#include "common/constants.h"
#include "common/seed.h"
#include "sim/tracer.h"
#include "virtual_gonio/direction_sets.h"

namespace plumage::studies {
namespace {

constexpr double kGrazingDeg = 75.0;

// The pair's light along the barbules (patch +y): φ_i = ±90°.
bool along_barbules(const gonio::DirectionPair& p) {
    return std::abs(p.wi.x()) < 1e-9 * std::abs(p.wi.y());
}

double lobe_at(const gonio::BrdfRecord& r, const char* lobe, std::size_t cell, bool error = false) {
    const int l = analysis::lobe_index(r.lobes, lobe);
    if (l < 0) return 0.0;
    const std::size_t n = r.value.size();
    return (error ? r.lobe_standard_error : r.lobe_values)[static_cast<std::size_t>(l) * n + cell];
}

// Σ over the pairs `use` selects and every wavelength of one lobe ("" the total) and its σ.
// Pairs of different light directions have independent quanta (variances add); one quantum
// carries every wavelength (shared paths), so within a pair the σ add as if fully correlated,
// an upper bound.
struct LobeSum {
    double value = 0.0, sigma = 0.0;
};
LobeSum lobe_sum(const gonio::BrdfRecord& r, const char* lobe, const std::vector<bool>& use) {
    const std::size_t nl = r.config.wavelengths_nm.size();
    const bool total = lobe[0] == '\0';
    LobeSum s;
    double variance = 0.0;
    for (std::size_t p = 0; p < use.size(); ++p) {
        if (!use[p]) continue;
        double pair_sigma = 0.0;
        for (std::size_t k = 0; k < nl; ++k) {
            const std::size_t c = p * nl + k;
            s.value += total ? r.value[c] : lobe_at(r, lobe, c);
            pair_sigma += total ? r.standard_error[c] : lobe_at(r, lobe, c, true);
        }
        variance += pair_sigma * pair_sigma;
    }
    s.sigma = std::sqrt(variance);
    return s;
}

// Simulation − model over the pairs `use` selects (every wavelength), by lobe, in units of the
// model's total there.
LobeExcess lobe_excess(const gonio::BrdfRecord& sim, const gonio::BrdfRecord& model,
                       const std::vector<bool>& use) {
    const LobeSum s_total = lobe_sum(sim, "", use), s_r = lobe_sum(sim, "R", use),
                  s_trt = lobe_sum(sim, "TRT", use), s_multi = lobe_sum(sim, "multi", use);
    const double m_r = lobe_sum(model, "R", use).value, m_trt = lobe_sum(model, "TRT", use).value;
    LobeExcess e;
    e.model_total = m_r + m_trt;
    if (!(e.model_total > 0.0)) return e;
    const double m = e.model_total;
    e.total = (s_total.value - m) / m, e.total_sigma = s_total.sigma / m;
    e.r = (s_r.value - m_r) / m, e.r_sigma = s_r.sigma / m;
    e.trt = (s_trt.value - m_trt) / m, e.trt_sigma = s_trt.sigma / m;
    e.multi = s_multi.value / m, e.multi_sigma = s_multi.sigma / m;
    return e;
}

// Σ lobe(a) / Σ lobe(b) − 1 over the selected pairs, with a's σ.
std::pair<double, double> lobe_ratio(const gonio::BrdfRecord& a, const gonio::BrdfRecord& b,
                                     const char* lobe, const std::vector<bool>& use) {
    const LobeSum sa = lobe_sum(a, lobe, use), sb = lobe_sum(b, lobe, use);
    return {sa.value / sb.value - 1.0, sa.sigma / sb.value};
}

// The tracer on `row` with at most `max_events` events per path.
gonio::BrdfRecord measure_tracer(const geometry::BarbuleRow& row, int max_events,
                                 const gonio::GoniometerConfig& g) {
    sim::TracerOptions options;
    options.max_events = max_events;
    const sim::ExplicitScatterer tracer(sim::barbule_row_scene(row), options);
    return gonio::measure_brdf(tracer, g);
}

// The study's row with cells short enough that Eq. 7's longitudinal coupling
// r_θ(1 − cos θ_d)/(b² A) is `coupling`, as long along the barbules as the study's.
geometry::BarbuleRowParams short_cells(const geometry::BarbuleRowParams& row, double coupling) {
    geometry::BarbuleRowParams p = row;
    const double rho_min = p.cell.b * p.cell.b * p.cell.semi_major_um;
    const double r_theta = coupling * rho_min / (1.0 - std::cos(p.cell.theta_d));
    p.cell.cell_length_um = 2.0 * r_theta * std::sin(p.cell.theta_d);
    p.cell.melanin_depth_um = std::min(p.cell.melanin_depth_um, 0.5 * rho_min);
    p.cells_per_barbule = static_cast<int>(
        std::ceil(row.cells_per_barbule * row.cell.cell_length_um / p.cell.cell_length_um));
    return p;
}

}  // namespace

LobeExcess brdf_lobe_excess(const gonio::BrdfRecord& simulation, const gonio::BrdfRecord& model) {
    return lobe_excess(simulation, model, std::vector<bool>(simulation.config.pairs.size(), true));
}

std::vector<gonio::DirectionPair> grazing_specular_pairs() {
    std::vector<gonio::DirectionPair> pairs;
    for (int k = 0; k < 12; ++k) {
        const double phi = k * 30.0 * kDeg;
        pairs.push_back({gonio::direction_from_angles(kGrazingDeg * kDeg, phi),
                         gonio::direction_from_angles(kGrazingDeg * kDeg, phi + kPi)});
    }
    return pairs;
}

GrazingDepartures measure_grazing_departures(const GrazingSetup& setup,
                                             const std::function<void(const std::string&)>& say) {
    const auto start = std::chrono::steady_clock::now();
    GrazingDepartures d;
    gonio::GoniometerConfig g = setup.goniometer;
    g.direction_set = "custom: the grazing specular pairs (75°/75°)";
    g.pairs = grazing_specular_pairs();
    g.estimator = gonio::Estimator::photon;
    d.pairs = static_cast<int>(g.pairs.size());
    // The cone about the barbule axis through ω_i's mirror (half-angle 90° − θ_i for light along
    // the axis) and the arc of it within the detector: two points of the cone ψ apart in
    // azimuth are δ apart with sin(δ/2) = sin(cone) sin(ψ/2), δ = the detector's half-angle.
    d.cone_half_angle = (90.0 - kGrazingDeg) * kDeg;
    d.detector_half_angle = g.detector_half_angle_rad;
    d.cone_transversal_half_range =
        2.0 * std::asin(std::min(
                  1.0, std::sin(0.5 * g.detector_half_angle_rad) / std::sin(d.cone_half_angle)));
    std::vector<bool> along(g.pairs.size()), across(g.pairs.size()), all(g.pairs.size(), true);
    for (std::size_t p = 0; p < g.pairs.size(); ++p)
        along[p] = along_barbules(g.pairs[p]), across[p] = !along[p];

    say("departures: grazing pairs, the model");
    gonio::GoniometerConfig m = g;
    m.estimator = gonio::Estimator::eval;
    m.eval_tolerance = 0.01;
    const gonio::BrdfRecord model = gonio::measure_brdf(setup.model, m);

    say("departures: grazing pairs, every path");
    g.seed = derive_seed(setup.goniometer.seed, "rock_dove/departures/all_events");
    const gonio::BrdfRecord full = measure_tracer(setup.row, sim::TracerOptions{}.max_events, g);
    d.along = lobe_excess(full, model, along);
    d.across = lobe_excess(full, model, across);

    say("departures: grazing pairs, at most two events");
    g.seed = derive_seed(setup.goniometer.seed, "rock_dove/departures/two_events");
    const gonio::BrdfRecord two = measure_tracer(setup.row, 2, g);
    const LobeExcess two_along = lobe_excess(two, model, along);
    d.multi_two_events = two_along.multi, d.multi_two_events_sigma = two_along.multi_sigma;

    say("departures: grazing pairs, R alone on the study's cells and on short cells");
    g.seed = derive_seed(setup.goniometer.seed, "rock_dove/departures/r_default");
    const gonio::BrdfRecord r_default = measure_tracer(setup.row, 1, g);
    std::tie(d.r_default, d.r_default_sigma) = lobe_ratio(r_default, model, "R", all);
    const geometry::BarbuleRowParams short_row =
        short_cells(setup.row.params, setup.short_cell_coupling);
    d.short_cell_length_um = short_row.cell.cell_length_um;
    d.short_cell_coupling = setup.short_cell_coupling;
    g.seed = derive_seed(setup.goniometer.seed, "rock_dove/departures/r_short");
    const gonio::BrdfRecord r_short =
        measure_tracer(geometry::build_barbule_row(short_row, setup.tolerance), 1, g);
    std::tie(d.r_short, d.r_short_sigma) = lobe_ratio(r_short, model, "R", all);
    d.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return d;
}

TrtDepartures trt_exit_departures(const gonio::BrdfRecord& simulation,
                                  const gonio::BrdfRecord& model,
                                  const analysis::Huang2022Bsdf& huang) {
    const auto start = std::chrono::steady_clock::now();
    const std::vector<gonio::DirectionPair>& pairs = model.config.pairs;
    const std::vector<double>& wl = model.config.wavelengths_nm;
    const std::size_t np = pairs.size(), nl = wl.size();
    // Per cell: the model's TRT (its record, cone averaged) times each law's ratio to Huang's at
    // the cell's central directions.
    std::vector<double> fore(np * nl, 0.0), exit(np * nl, 0.0);
#pragma omp parallel for schedule(dynamic)
    for (std::size_t p = 0; p < np; ++p) {
        const analysis::TrtExitLaws laws =
            analysis::trt_exit_laws(huang, pairs[p].wi, pairs[p].wo, wl);
        for (std::size_t k = 0; k < nl; ++k) {
            if (!(laws.huang[k] > 0.0)) continue;
            const double m = lobe_at(model, "TRT", p * nl + k);
            fore[p * nl + k] = m * laws.foreshortened[k] / laws.huang[k];
            exit[p * nl + k] = m * laws.exit[k] / laws.huang[k];
        }
    }
    TrtDepartures t;
    auto row = [&](auto&& use) {
        double s = 0, m = 0, f = 0, x = 0, v = 0;
        for (std::size_t p = 0; p < np; ++p) {
            if (!use(pairs[p].wo)) continue;
            double pair_sigma = 0.0;  // wavelengths of one quantum: σ added as correlated
            for (std::size_t k = 0; k < nl; ++k) {
                const std::size_t c = p * nl + k;
                s += lobe_at(simulation, "TRT", c), m += lobe_at(model, "TRT", c);
                f += fore[c], x += exit[c];
                pair_sigma += lobe_at(simulation, "TRT", c, true);
            }
            v += pair_sigma * pair_sigma;
        }
        if (!(m > 0.0 && f > 0.0 && x > 0.0)) return TrtDepartures::Row{};  // no such cells
        return TrtDepartures::Row{s / m - 1.0, s / f - 1.0, s / x - 1.0, std::sqrt(v) / m, true};
    };
    const double cos60 = std::cos(60.0 * kDeg);
    t.all = row([](const Vec3d&) { return true; });
    t.near = row([&](const Vec3d& wo) { return wo.z() >= cos60 - 1e-9; });
    t.far = row([&](const Vec3d& wo) { return wo.z() < cos60 - 1e-9; });
    double f = 0.0, x = 0.0;
    for (std::size_t c = 0; c < fore.size(); ++c) f += fore[c], x += exit[c];
    t.blocked_share = f > 0.0 ? 1.0 - x / f : 0.0;
    t.exit_cells = std::move(exit);
    t.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return t;
}

namespace {

// Every tenth light direction of `pairs` (in their order) and all of its pairs: their indices.
std::vector<std::size_t> every_tenth_light(const std::vector<gonio::DirectionPair>& pairs) {
    std::vector<Vec3d> lights;
    std::vector<std::size_t> picked;
    for (std::size_t p = 0; p < pairs.size(); ++p) {
        auto it = std::find_if(lights.begin(), lights.end(),
                               [&](const Vec3d& w) { return (w - pairs[p].wi).norm() < 1e-12; });
        const std::size_t light = static_cast<std::size_t>(it - lights.begin());
        if (it == lights.end()) lights.push_back(pairs[p].wi);
        if (light % 10 == 0) picked.push_back(p);
    }
    return picked;
}

// Σ TRT of `sim` (its cells c·nl + k for the pairs `sim_pairs`) against Σ of `exit_cells` at the
// matching pairs of the model's record `model_pairs`: ratio − 1 and σ (wavelengths correlated).
TrtDepartures::Variant trt_against_exit(std::string what, const gonio::BrdfRecord& sim,
                                        const std::vector<std::size_t>& sim_pairs,
                                        const std::vector<double>& exit_cells,
                                        const std::vector<std::size_t>& model_pairs,
                                        std::size_t nl) {
    double s = 0.0, x = 0.0, v = 0.0;
    for (std::size_t i = 0; i < sim_pairs.size(); ++i) {
        double pair_sigma = 0.0;
        for (std::size_t k = 0; k < nl; ++k) {
            s += lobe_at(sim, "TRT", sim_pairs[i] * nl + k);
            pair_sigma += lobe_at(sim, "TRT", sim_pairs[i] * nl + k, true);
            x += exit_cells[model_pairs[i] * nl + k];
        }
        v += pair_sigma * pair_sigma;
    }
    return {std::move(what), x > 0.0 ? s / x - 1.0 : 0.0, x > 0.0 ? std::sqrt(v) / x : 0.0};
}

}  // namespace

void measure_trt_variants(const GrazingSetup& setup, const gonio::BrdfRecord& simulation,
                          const gonio::BrdfRecord& model, TrtDepartures& trt,
                          const std::function<void(const std::string&)>& say) {
    const auto start = std::chrono::steady_clock::now();
    const std::vector<std::size_t> picked = every_tenth_light(model.config.pairs);
    const std::size_t nl = model.config.wavelengths_nm.size();
    std::vector<std::size_t> own(picked.size());
    for (std::size_t i = 0; i < own.size(); ++i) own[i] = i;
    gonio::GoniometerConfig g = setup.goniometer;
    g.direction_set = "custom: every tenth light direction of the study's BRDF";
    g.pairs.clear();
    for (std::size_t p : picked) g.pairs.push_back(model.config.pairs[p]);
    trt.variant_pairs = static_cast<int>(picked.size());
    trt.variants.push_back(trt_against_exit("the study's patch (its BRDF record)", simulation,
                                            picked, trt.exit_cells, picked, nl));
    const geometry::BarbuleRowParams& p0 = setup.row.params;
    geometry::BarbuleRowParams short_row = short_cells(p0, setup.short_cell_coupling);
    geometry::BarbuleRowParams thin_gap = p0;
    thin_gap.cell.melanin_depth_um = 0.1 * p0.cell.melanin_depth_um;
    const std::array<std::pair<std::string, const geometry::BarbuleRowParams*>, 2> variants = {
        {{fmt::format("cells {:.3f} µm long (Eq. 7 exact)", short_row.cell.cell_length_um),
          &short_row},
         {fmt::format("melanin {:.2f} µm under the film (study: {:.2f} µm)",
                      thin_gap.cell.melanin_depth_um, p0.cell.melanin_depth_um),
          &thin_gap}}};
    for (std::size_t v = 0; v < variants.size(); ++v) {
        say("departures: TRT with " + variants[v].first);
        g.seed = derive_seed(setup.goniometer.seed, "rock_dove/departures/trt_variant", v);
        const gonio::BrdfRecord r =
            measure_tracer(geometry::build_barbule_row(*variants[v].second, setup.tolerance),
                           sim::TracerOptions{}.max_events, g);
        trt.variants.push_back(
            trt_against_exit(variants[v].first, r, own, trt.exit_cells, picked, nl));
    }
    trt.variant_seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

namespace {

// x ± σ in per cent, with a second decimal where σ would read 0.0 %.
std::string pm(double x, double sigma) {
    if (std::abs(sigma) < 5e-4)
        return fmt::format("{:+.2f} % ± {:.2f} %", 100.0 * x, 100.0 * sigma);
    return fmt::format("{:+.1f} % ± {:.1f} %", 100.0 * x, 100.0 * sigma);
}

std::string grazing_markdown(const GrazingDepartures& g) {
    const LobeExcess& a = g.along;
    return fmt::format(
        "- **Grazing specular pairs (75°/75°): interreflection, with light along the barbules.** "
        "Measured on the {} pairs alone (step *departures: grazing pairs*; model by its "
        "converged cubature). Light along the barbules (φ_i = ±90°, the BRDF's worst cells): "
        "simulation − model = {} of the model, of which R {}, TRT {} and the multi lobe "
        "(interreflection, which the model leaves out) {}; with interreflection left out (R + "
        "TRT) the excess is {}. The other {} pairs: {} (R {}, TRT {}, multi {}). With the tracer "
        "stopped after two events the multi lobe along the barbules keeps {} of the model "
        "({:.0f} % of it): two film reflections, off one barbule and then its neighbour. Why "
        "along the barbules: their film is straight along its axis to within θ_d, so every "
        "reflection keeps the light's component along it, and whatever the transversal angle "
        "after a second reflection, the light leaves on the {:.0f}° cone about the axis on which "
        "the specular view lies; the {:.0f}° detector takes ±{:.0f}° of that cone, so it collects "
        "the "
        "interreflection that elsewhere spreads over the hemisphere. R alone (the tracer "
        "stopped after one event) over the {} pairs: {} on the study's cells, {} on cells {:.3f} "
        "µm long (Eq. 7's coupling {:.2f}, where the model's normal distribution is exact).\n",
        g.pairs, pm(a.total, a.total_sigma), pm(a.r, a.r_sigma), pm(a.trt, a.trt_sigma),
        pm(a.multi, a.multi_sigma), pm(a.r + a.trt, std::hypot(a.r_sigma, a.trt_sigma)),
        g.pairs - 2, pm(g.across.total, g.across.total_sigma), pm(g.across.r, g.across.r_sigma),
        pm(g.across.trt, g.across.trt_sigma), pm(g.across.multi, g.across.multi_sigma),
        pm(g.multi_two_events, g.multi_two_events_sigma),
        a.multi > 0.0 ? 100.0 * g.multi_two_events / a.multi : 0.0, g.cone_half_angle / kDeg,
        g.detector_half_angle / kDeg, g.cone_transversal_half_range / kDeg, g.pairs,
        pm(g.r_default, g.r_default_sigma), pm(g.r_short, g.r_short_sigma), g.short_cell_length_um,
        g.short_cell_coupling);
}

// What is left against the exit law, one thing of the patch changed at a time.
std::string trt_variants_markdown(const TrtDepartures& t) {
    if (t.variants.empty()) return "";
    std::string md = fmt::format(
        " What is left, one thing of the simulated patch changed at a time (step *departures: "
        "TRT with …*, {} pairs: every tenth light direction of the BRDF, {:.1f} s), simulated "
        "TRT against the model under the exit law:\n\n  | simulated patch | TRT, simulation / "
        "model − 1 |\n  |---|---|\n",
        t.variant_pairs, t.variant_seconds);
    for (const TrtDepartures::Variant& v : t.variants)
        md += fmt::format("  | {} | {} |\n", v.what, pm(v.exit, v.sigma));
    if (t.variants.size() < 3) return md;
    const TrtDepartures::Variant &study = t.variants[0], &short_cells = t.variants[1],
                                 &thin_gap = t.variants[2];
    return md + fmt::format(
                    "\n  So what the exit law leaves is the explicit layer's geometry, which the "
                    "model does not describe: it puts the melanin at the film, and moving the "
                    "simulated melanin up to it changes TRT by {}; its normals are Eq. 7's, and "
                    "cells short enough for Eq. 7 change it by {}.\n",
                    pm(thin_gap.exit - study.exit, std::hypot(thin_gap.sigma, study.sigma)),
                    pm(short_cells.exit - study.exit, std::hypot(short_cells.sigma, study.sigma)));
}

std::string trt_markdown(const TrtDepartures& t) {
    auto row = [](const char* what, const TrtDepartures::Row& r) {
        if (!r.measured) return fmt::format("| {} | no cells | | |\n", what);
        return fmt::format("| {} | {} | {} | {} |\n", what, pm(r.huang, r.sigma),
                           pm(r.foreshortened, r.sigma), pm(r.exit, r.sigma));
    };
    return fmt::format(
        "- **TRT: the model's exit law.** The model lets the melanin's light out of every "
        "lit facet with the same radiance towards every view the facet faces; the "
        "simulated melanin is a Lambertian sheet under the curved film, whose facets a "
        "view sees foreshortened by ⟨ω_o, ω_m⟩/cos θ_o and hidden where a neighbouring "
        "barbule stands in front (analysis/models/huang2022_trt_exit.h). Simulated TRT against "
        "the model with each exit law, summed over the BRDF's cells (step *departures: "
        "TRT exit law*, {:.1f} s; the law's ratio to the model's at each cell's central "
        "directions):\n\n"
        "  | views | model (Huang's law) | foreshortened | foreshortened and masked |\n"
        "  |---|---|---|---|\n  {}  {}  {}\n"
        "  The neighbours block {:.1f} % of the light the foreshortened law lets out; in "
        "the simulation it meets them and goes on in the multi lobe.{}\n",
        t.seconds, row("all", t.all), row("θ_o ≤ 60°", t.near), row("θ_o > 60°", t.far),
        100.0 * t.blocked_share, trt_variants_markdown(t));
}

}  // namespace

std::string departures_markdown(const Departures& d, double multi_share) {
    std::string md = fmt::format(
        "- **Interreflection (the multi lobe).** The model keeps one film reflection (R) and one "
        "melanin bounce (TRT); light that meets a second barbule is lost in the model and kept "
        "in the simulation. Under hemispheric light {:.1f} % of the simulated reflected power "
        "took more than these paths.",
        100.0 * multi_share);
    if (!d.measured) return md + "\n";
    const LobeExcess& b = d.brdf;
    md += fmt::format(
        " In the BRDF the simulation's power is {} of the model's: the multi lobe {}, R {}, TRT "
        "{} (the two bullets below say where the multi lobe is largest and why TRT is short).\n",
        pm(b.total, b.total_sigma), pm(b.multi, b.multi_sigma), pm(b.r, b.r_sigma),
        pm(b.trt, b.trt_sigma));
    return md + grazing_markdown(d.grazing) + trt_markdown(d.trt);
}

}  // namespace plumage::studies
