#include "studies/wave_validity_live.h"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <numeric>
#include <sstream>

#include <fmt/format.h>

#include "common/constants.h"
#include "common/error.h"
#include "common/interrupt.h"
#include "sim/fullwave/row_reference.h"
#include "sim/wave/compare/levels_against_full_wave.h"
#include "sim/wave/compare/ray_optics_validity.h"
#include "sim/wave/surface/physical_optics_hybrid_2d.h"
#include "studies/study_progress.h"
#include "studies/text_files.h"
#include "virtual_gonio/record/hdf5_file.h"

namespace plumage::studies {
namespace {

namespace fw = sim::fullwave;
namespace wave = sim::wave;

int runs_at_once() { return std::clamp(omp_get_max_threads(), 1, 4); }

fw::RowReferenceRequest request_of(const LiveFullWaveSettings& s) {
    fw::RowReferenceRequest q;
    q.resolution_px_per_um = s.resolution_px_per_um;
    q.decay = s.decay;
    q.stop = &interrupt_flag();
    q.threads = runs_at_once();
    return q;
}

// The scene's full-wave period and its cost, or why it has none.
WaveValidityLivePoint plan(const LiveScene& c, const std::vector<double>& lambdas_nm,
                           const LiveFullWaveSettings& s, fw::CrossSection2d& period) {
    WaveValidityLivePoint p;
    p.scene = c.scene;
    p.map_verdict = c.map_verdict;
    p.width_um = 2.0 * c.a_um;
    p.theta_i_deg = c.theta_i_deg;
    p.period_um = c.H * c.a_um;
    try {
        period = fw::barbule_row(c.a_um, c.b, c.d, c.g, p.period_um, c.mu, 1);
    } catch (const InputError& e) {
        p.status = "not a barbule";
        p.reason = e.what();
        return p;
    }
    try {
        const fw::RowReferenceCost cost = fw::row_reference_cost(
            period, p.period_um, c.theta_i_deg * kDeg, lambdas_nm, request_of(s));
        p.cell_runs = cost.cell_runs;
        p.fine_cells = static_cast<double>(cost.fine_cells);
    } catch (const InputError& e) {
        p.status = "refused";
        p.reason = e.what();
    }
    return p;
}

// The cheaper levels on the row: ray optics and physical optics, and the GO–PO hybrid on the
// barbule with its gap as separate curves (fullwave::barbule_row's body). The hybrid refuses
// curves closer than its sampling step (neighbours of a tilted row can come within a few tens of
// nm), so its step is halved up to twice (each halving about doubles its cost); where it still
// refuses, the reason is kept and the other levels are judged without it.
wave::RowVerdict2d judge_levels(const LiveScene& c, const wave::Row2d& row,
                                std::span<const wave::RowReflectanceFullWave> reference,
                                double threshold, double step_um, WaveValidityLivePoint& p) {
    const double theta_i = c.theta_i_deg * kDeg;
    wave::RowVerdict2d v =
        wave::judge_row_against_full_wave(row, theta_i, reference, threshold, step_um);
    // the reference's wavelengths are increasing (the judge refuses others): λ/10 at the shortest
    double hybrid_step = std::min(step_um, 1e-4 * v.lambda_nm.front());
    for (int halvings = 0; halvings <= 2; ++halvings, hybrid_step *= 0.5) {
        try {
            wave::add_hybrid(v, row, theta_i, wave::barbule_with_gap(c.a_um, c.b, c.d, c.g),
                             hybrid_step);
            p.hybrid_step_um = hybrid_step;
            p.hybrid_reason.clear();
            break;
        } catch (const InputError& e) {
            p.hybrid_reason = e.what();
        }
    }
    return v;
}

// Full wave, then the cheaper levels on the same row, errors and verdict.
void judge(const LiveScene& c, const std::vector<double>& lambdas_nm, const LiveFullWaveSettings& s,
           double threshold, const fw::CrossSection2d& period, WaveValidityLivePoint& p) {
    const fw::RowReference ref =
        fw::row_reference(period, p.period_um, c.theta_i_deg * kDeg, lambdas_nm, request_of(s));
    p.seconds = ref.seconds;
    p.max_fit_index_error = ref.max_fit_index_error;
    wave::Row2d row = wave::barbule_row_2d(c.a_um, c.b, c.phi0, c.phi1, c.d, c.g, c.H, c.mu, 1);
    const double step_um = 0.95 * wave::barbule_row_min_radius_um(c.a_um, c.b, c.phi0, c.phi1);
    const wave::RowVerdict2d v = judge_levels(c, row, ref.reflectance, threshold, step_um, p);
    p.lambda_nm = v.lambda_nm;
    p.full_wave = v.full_wave;
    p.full_wave_coarse = v.full_wave_coarse;
    p.physical_optics = v.physical_optics;
    p.ray_optics = v.ray_optics;
    p.hybrid = v.hybrid;
    p.band_full_wave = v.band_full_wave;
    p.resolution_error = v.resolution_error;
    p.po_error = v.po_error;
    p.go_error = v.go_error;
    p.hybrid_error = v.hybrid_error;
    for (std::size_t k = 0; k < v.lambda_nm.size(); ++k) {
        p.resolution_worst =
            std::max(p.resolution_worst, std::abs(v.full_wave_coarse[k] / v.full_wave[k] - 1.0));
        const double po = std::abs(v.physical_optics[k] / v.full_wave[k] - 1.0);
        const double go = std::abs(v.ray_optics[k] / v.full_wave[k] - 1.0);
        if (po >= p.po_worst) p.po_worst = po, p.po_worst_lambda_nm = v.lambda_nm[k];
        if (go >= p.go_worst) p.go_worst = go, p.go_worst_lambda_nm = v.lambda_nm[k];
        if (v.hybrid.empty()) continue;
        const double hy = std::abs(v.hybrid[k] / v.full_wave[k] - 1.0);
        if (hy >= p.hybrid_worst) p.hybrid_worst = hy, p.hybrid_worst_lambda_nm = v.lambda_nm[k];
    }
    if (std::abs(v.resolution_error) > s.tolerance) {
        p.status = "unconverged";
        p.reason = fmt::format("resolution error {:+.2f} % beyond the tolerance {:g} %",
                               100.0 * v.resolution_error, 100.0 * s.tolerance);
        return;
    }
    p.status = "judged";
    p.level = v.level;
}

}  // namespace

std::vector<WaveValidityLivePoint> judge_live(const std::vector<LiveScene>& scenes,
                                              const std::vector<double>& lambdas_nm,
                                              const LiveFullWaveSettings& settings,
                                              double threshold, const StudyProgress& clock,
                                              double& rate) {
    std::vector<WaveValidityLivePoint> out(scenes.size());
    std::vector<fw::CrossSection2d> periods(scenes.size());
    for (std::size_t i = 0; i < scenes.size(); ++i)
        out[i] = plan(scenes[i], lambdas_nm, settings, periods[i]);
    std::vector<std::size_t> order(scenes.size());
    std::iota(order.begin(), order.end(), 0);
    std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
        return out[a].cell_runs < out[b].cell_runs;
    });
    const double budget_s = 60.0 * settings.budget_minutes, threads = runs_at_once();
    double spent = 0.0;
    rate = fw::kReferenceSecondsPerCellRun;
    bool measured = false;
    for (const std::size_t i : order) {
        WaveValidityLivePoint& p = out[i];
        if (!p.status.empty()) continue;
        p.predicted_s = p.cell_runs * rate / threads;
        if (spent + p.predicted_s > budget_s) {
            p.status = "not afforded";
            p.reason = fmt::format("predicted {:.0f} s, {:.0f} s of the budget left", p.predicted_s,
                                   std::max(0.0, budget_s - spent));
            continue;
        }
        clock.say(
            fmt::format("full wave, live: {}, width {:g} µm, θ_i = {:g}° ({:.0f} s predicted)",
                        p.scene, p.width_um, p.theta_i_deg, p.predicted_s));
        judge(scenes[i], lambdas_nm, settings, threshold, periods[i], p);
        spent += p.seconds;
        const double measured_rate = p.seconds * threads / p.cell_runs;
        rate = measured ? std::max(rate, measured_rate) : measured_rate;
        measured = true;
    }
    return out;
}

int worst_physical_optics_scene(const WaveValidityResult& r) {
    int worst = -1;
    for (std::size_t i = 0; i < r.live.size(); ++i)
        if (r.live[i].status == "judged" &&
            (worst < 0 || std::abs(r.live[i].po_error) > std::abs(r.live[worst].po_error)))
            worst = static_cast<int>(i);
    return worst;
}

namespace {

std::string percent(double x) { return fmt::format("{:+.1f} %", 100.0 * x); }

// Why the worst scene's physical optics misses, from the numbers: when PO and GO miss alike, the
// cause is what both lack, not the diffraction PO adds.
std::string failure_text(const WaveValidityLivePoint& p, double threshold) {
    if (std::abs(p.po_error) <= threshold)
        return fmt::format(
            "Physical optics is within {:g} % at every judged scene; its largest band error is "
            "{} ({}, width {:g} µm, θ_i = {:g}°).",
            100.0 * threshold, percent(p.po_error), p.scene, p.width_um, p.theta_i_deg);
    const bool alike = std::abs(p.po_error - p.go_error) < 0.5 * std::abs(p.po_error);
    return fmt::format(
        "**Where physical optics fails**: {}, width {:g} µm, θ_i = {:g}° (live_spectra.png): "
        "band error {} (worst {:.1f} % at {:g} nm), ray optics {} (worst {:.1f} % at {:g} nm), "
        "full wave's resolution error {}. {}",
        p.scene, p.width_um, p.theta_i_deg, percent(p.po_error), 100.0 * p.po_worst,
        p.po_worst_lambda_nm, percent(p.go_error), 100.0 * p.go_worst, p.go_worst_lambda_nm,
        percent(p.resolution_error),
        alike ? "Physical and ray optics miss alike (PO − GO is under half of PO's error), so the "
                "cause is what both leave out, not diffraction: light that crosses the film "
                "into the gap and returns (both take the planar stack's r under each point of "
                "the arc), the body's closed underside and the melanin's own curvature (they "
                "sample only the arc φ0…φ1), and light passed between neighbours (single "
                "bounce)."
              : "Physical optics moves away from ray optics by more than half its error: the "
                "diffraction it adds is itself wrong here (a Kirchhoff field of the lit arc, "
                "no edge or creeping waves, no light between neighbours).");
}

}  // namespace

std::string live_verdict(const WaveValidityResult& r) {
    std::map<std::string, int> status, level;
    int map_right = 0, map_wrong = 0;
    for (const WaveValidityLivePoint& p : r.live) {
        ++status[p.status];
        if (p.status != "judged") continue;
        ++level[p.level];
        const bool go_ok = p.level == "ray optics + thin film";
        if (p.map_verdict == "undecided") continue;
        ((p.map_verdict == "GO suffices") == go_ok ? map_right : map_wrong) += 1;
    }
    std::ostringstream out;
    out << fmt::format(
        "Of {} scenes, full wave judged {} (cheapest level within {:g} %: ray optics + thin "
        "film at {}, physical optics at {}, full wave alone at {}); {} unconverged, {} not "
        "afforded within the budget, {} not a barbule at this stack, {} refused by full wave's "
        "limits. ",
        r.live.size(), status["judged"], 100.0 * r.threshold, level["ray optics + thin film"],
        level["physical optics"], level["full wave"], status["unconverged"], status["not afforded"],
        status["not a barbule"], status["refused"]);
    if (map_right + map_wrong > 0)
        out << fmt::format(
            "The map's PO − GO verdict agrees with full wave's on whether ray optics suffices at "
            "{} of the {} judged scenes it decides. ",
            map_right, map_right + map_wrong);
    const int worst = worst_physical_optics_scene(r);
    if (worst >= 0) out << failure_text(r.live[worst], r.threshold);
    return out.str();
}

std::string live_section(const WaveValidityResult& r, const LiveFullWaveSettings& s) {
    std::ostringstream md;
    md << "## Judged by full wave, live\n\n"
       << fmt::format(
              "Each scene of the maps (a barbule, a width, an incidence) as an **endless periodic "
              "row** of its barbule (spacing H·A, tilt μ, no jitter): its reflectance R(λ) into "
              "the upper half-space, all diffraction orders, unpolarised (TE + TM)/2, by full "
              "wave (Meep, sim/fullwave/row_reference.h: the closed barbule, a melanin core under "
              "a uniform air shell g and a keratin shell d; {:g} and {:g} px/µm, fitted "
              "dispersion at normal incidence and one run per wavelength otherwise, stop at "
              "decay {:g}), by physical optics and by ray optics + thin film (rows of 12 and 4 "
              "barbules, their ends cancelled). A level's **error** is its band-mean R over full "
              "wave's, minus 1 (worst: the largest |R_level(λ)/R_FW(λ) − 1|); full wave's "
              "**resolution error** is its coarse band mean over the fine one's, minus 1 (worst: "
              "the "
              "largest per wavelength, the floor of a level's worst error), and a "
              "scene whose |resolution error| exceeds {:g} % is *unconverged* and judges "
              "nothing. The cheapest level within {:g} % is the verdict. Scenes ran cheapest "
              "first within a budget of {:g} min; the cost rate at the end was {:.3g} ms per "
              "cell-run on one thread (the prior, before any run: {:.3g} ms, the committed "
              "rock-dove row reference's). *Map*: the map's own PO − GO verdict at that point "
              "(jittered finite rows; GO suffices / PO needed / undecided).\n\n",
              s.resolution_px_per_um, 1.5 * s.resolution_px_per_um, s.decay, 100.0 * s.tolerance,
              100.0 * r.threshold, s.budget_minutes, 1e3 * r.live_seconds_per_cell_run,
              1e3 * fw::kReferenceSecondsPerCellRun);
    md << "**Verdict.** " << r.live_verdict << "\n\n";
    md << "| scene | width (µm) | θ_i (°) | status | R full wave (band) | resolution error (worst) "
          "| ray "
          "optics error (worst) | physical optics error (worst) | GO–PO hybrid error (worst) | "
          "cheapest level | map | time "
          "(s; predicted) |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n";
    for (const WaveValidityLivePoint& p : r.live) {
        const bool ran = p.status == "judged" || p.status == "unconverged";
        md << fmt::format("| {} | {:g} | {:g} | {} |", p.scene, p.width_um, p.theta_i_deg,
                          p.status);
        if (ran)
            md << fmt::format(
                " {:.4f} | {} ({:.1f} %) | {} ({:.1f} % at {:g} nm) | {} ({:.1f} % at {:g} nm) | "
                "{} | {} | {} | {:.0f} ({:.0f}) |\n",
                p.band_full_wave, percent(p.resolution_error), 100.0 * p.resolution_worst,
                percent(p.go_error), 100.0 * p.go_worst, p.go_worst_lambda_nm, percent(p.po_error),
                100.0 * p.po_worst, p.po_worst_lambda_nm,
                p.hybrid.empty() ? std::string("refused")
                                 : fmt::format("{} ({:.1f} % at {:g} nm)", percent(p.hybrid_error),
                                               100.0 * p.hybrid_worst, p.hybrid_worst_lambda_nm),
                p.status == "judged" ? p.level : "—", p.map_verdict, p.seconds, p.predicted_s);
        else
            md << fmt::format(" — | — | — | — | — | — | {} | {} |\n", p.map_verdict,
                              p.status == "not afforded" ? fmt::format("({:.0f})", p.predicted_s)
                                                         : std::string("—"));
    }
    std::ostringstream why;
    for (const WaveValidityLivePoint& p : r.live)
        if (!p.reason.empty() && p.status != "not afforded")
            why << fmt::format("- {}, width {:g} µm, θ_i = {:g}°: {}\n", p.scene, p.width_um,
                               p.theta_i_deg, p.reason);
    if (!why.str().empty()) md << "\nWhy some scenes have no full wave:\n\n" << why.str();
    std::ostringstream hybrid_why;
    for (const WaveValidityLivePoint& p : r.live)
        if (!p.hybrid_reason.empty())
            hybrid_why << fmt::format("- {}, width {:g} µm, θ_i = {:g}°: {}\n", p.scene, p.width_um,
                                      p.theta_i_deg, p.hybrid_reason);
    if (!hybrid_why.str().empty())
        md << "\nWhere the GO–PO hybrid refused the row:\n\n" << hybrid_why.str();
    md << "\n*Scope:* the endless row without jitter; the map's rows are finite and jittered, so "
          "the map's and full wave's verdicts answer neighbouring questions. Spongy volumes "
          "are judged in their own section below.\n\n";
    if (worst_physical_optics_scene(r) >= 0)
        md << "![R(λ) where physical optics misses most](live_spectra.png)\n\n";
    return md.str();
}

void write_live(record::Hdf5Writer& h5, const WaveValidityResult& r,
                const LiveFullWaveSettings& s) {
    const std::uint64_t n = r.live.size();
    using P = WaveValidityLivePoint;
    auto column = [&](const std::string& name, double P::*member, const std::string& units,
                      const std::string& description) {
        std::vector<double> v;
        for (const P& p : r.live) v.push_back(p.*member);
        h5.write("full_wave_live/" + name, std::span<const double>(v), {n},
                 {{"units", units}, {"description", description + ", [scene]; 0 where not run"}});
    };
    column("width_um", &P::width_um, "µm", "barbule width 2A");
    column("theta_i_deg", &P::theta_i_deg, "deg", "incidence");
    column("period_um", &P::period_um, "µm", "the row's period H·A");
    column("band_full_wave", &P::band_full_wave, "1",
           "full wave's band-mean reflectance (fine grid), unpolarised, all orders");
    column("resolution_error", &P::resolution_error, "1",
           "full wave's coarse band mean over the fine one's, minus 1");
    column("resolution_worst", &P::resolution_worst, "1",
           "full wave's largest |R_coarse(λ)/R_fine(λ) − 1|");
    column("ray_optics_error", &P::go_error, "1",
           "ray optics' band mean over full wave's, minus 1");
    column("physical_optics_error", &P::po_error, "1",
           "physical optics' band mean over full wave's, minus 1");
    column("hybrid_error", &P::hybrid_error, "1",
           "the GO–PO hybrid's band mean over full wave's, minus 1 (0 where it refused the row)");
    column("hybrid_worst", &P::hybrid_worst, "1", "largest |R_hybrid(λ)/R_FW(λ) − 1|");
    column("hybrid_step_um", &P::hybrid_step_um, "µm",
           "the hybrid's sampling step (λ/10 or the row's, halved where it refused a coarser)");
    column("ray_optics_worst", &P::go_worst, "1", "largest |R_GO(λ)/R_FW(λ) − 1|");
    column("physical_optics_worst", &P::po_worst, "1", "largest |R_PO(λ)/R_FW(λ) − 1|");
    column("seconds", &P::seconds, "s", "wall time of the full-wave runs");
    column("predicted_s", &P::predicted_s, "s", "the time predicted before the run");
    column("cell_runs", &P::cell_runs, "1", "Σ over the full-wave runs of their grid cells");
    column("max_fit_index_error", &P::max_fit_index_error, "1",
           "the fitted dispersion's largest |Δ(n + ik)| (0: exact per wavelength)");
    std::string scenes, statuses, levels, maps;
    for (const P& p : r.live) {
        scenes += (scenes.empty() ? "" : "|") + p.scene;
        statuses += (statuses.empty() ? "" : "|") + p.status;
        levels += (levels.empty() ? "" : "|") + p.level;
        maps += (maps.empty() ? "" : "|") + p.map_verdict;
    }
    h5.set_attribute("full_wave_live", "scenes", scenes);
    h5.set_attribute("full_wave_live", "statuses", statuses);
    h5.set_attribute("full_wave_live", "levels", levels);
    h5.set_attribute("full_wave_live", "map_verdicts", maps);
    h5.set_attribute("full_wave_live", "verdict", r.live_verdict);
    h5.set_attribute("full_wave_live", "resolution_px_per_um", s.resolution_px_per_um);
    h5.set_attribute("full_wave_live", "decay", s.decay);
    h5.set_attribute("full_wave_live", "budget_minutes", s.budget_minutes);
    h5.set_attribute("full_wave_live", "tolerance", s.tolerance);
    h5.set_attribute("full_wave_live", "seconds_per_cell_run", r.live_seconds_per_cell_run);
}

void write_live_csv(const std::filesystem::path& path, const WaveValidityResult& r) {
    std::ofstream csv(path);
    csv << "scene,width_um,theta_i_deg,status,lambda_nm,full_wave,full_wave_coarse,"
           "physical_optics,ray_optics,hybrid,level,map_verdict,seconds,predicted_s\n";
    for (const WaveValidityLivePoint& p : r.live) {
        const std::string head =
            fmt::format("\"{}\",{:g},{:g},{}", p.scene, p.width_um, p.theta_i_deg, p.status);
        const std::string tail = fmt::format(",\"{}\",{},{:.4g},{:.4g}\n", p.level, p.map_verdict,
                                             p.seconds, p.predicted_s);
        if (p.lambda_nm.empty()) csv << head << ",,,,,,," << tail.substr(1);
        for (std::size_t k = 0; k < p.lambda_nm.size(); ++k)
            csv << head
                << fmt::format(
                       ",{:g},{:.6g},{:.6g},{:.6g},{:.6g},{}", p.lambda_nm[k], p.full_wave[k],
                       p.full_wave_coarse[k], p.physical_optics[k], p.ray_optics[k],
                       p.hybrid.empty() ? std::string() : fmt::format("{:.6g}", p.hybrid[k]))
                << tail;
    }
    close_written(csv, path);
}

void write_live_figure(const std::filesystem::path& path, const WaveValidityLivePoint& p,
                       double threshold) {
    record::Hdf5Writer h5(path);
    const std::uint64_t n = p.lambda_nm.size();
    auto curve = [&](const std::string& name, const std::vector<double>& v,
                     const std::string& description) {
        h5.write(name, std::span<const double>(v), {n},
                 {{"units", "1"}, {"description", description}});
    };
    h5.write("lambda_nm", std::span<const double>(p.lambda_nm), {n},
             {{"units", "nm"}, {"description", "wavelength (vacuum)"}});
    curve("full_wave", p.full_wave, "full wave's R, fine grid, unpolarised, all orders");
    curve("full_wave_coarse", p.full_wave_coarse, "full wave's R, coarse grid");
    curve("physical_optics", p.physical_optics, "physical optics' R of the endless row");
    curve("ray_optics", p.ray_optics, "ray optics + thin film's R of the endless row");
    if (!p.hybrid.empty())
        curve("hybrid", p.hybrid,
              "the GO–PO hybrid's R of the endless row (gap as separate curves)");
    h5.set_attribute("/", "title",
                     fmt::format("{}, width {:g} µm, θ_i = {:g}°: physical optics {} (band), ray "
                                 "optics {}; threshold {:g} %",
                                 p.scene, p.width_um, p.theta_i_deg, percent(p.po_error),
                                 percent(p.go_error), 100.0 * threshold));
    h5.commit();
}

}  // namespace plumage::studies
