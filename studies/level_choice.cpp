#include "studies/level_choice.h"

#include <omp.h>

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "common/constants.h"
#include "common/error.h"
#include "common/interrupt.h"
#include "sim/fullwave/full_wave_2d.h"
#include "sim/fullwave/row_reference.h"
#include "studies/study_common.h"
#include "studies/study_file.h"

namespace plumage::studies {

LevelSettings read_level(ParameterTable t) {
    LevelSettings s;
    s.measure = t.string("measure", s.measure, {"auto", "ray optics"},
                         "the level of physics the instruments measure with: \"auto\" (the "
                         "cheapest full wave certifies) or \"ray optics\" (ray optics + thin film "
                         "whatever full wave says; physical optics and full wave have no "
                         "instrument: the wave_validity study compares them)");
    s.tolerance = t.number("tolerance", s.tolerance, {0.0, 1.0, true, true},
                           "the largest error against full wave a level may have (a fraction "
                           "of the band-mean reflectance)");
    s.full_wave_budget_minutes =
        t.number("full_wave_budget_minutes", s.full_wave_budget_minutes, non_negative(),
                 "minutes the row's full-wave certificate may take when no committed reference "
                 "covers it");
    return s;
}

LiveRowReference live_row_reference(const RowScene& c, const std::vector<double>& lambdas_nm,
                                    const LevelSettings& settings, const StudyProgress& clock) {
    namespace fw = sim::fullwave;
    LiveRowReference out;
    const double period_um = c.H * c.a_um;
    fw::CrossSection2d period;
    try {
        period = fw::barbule_row(c.a_um, c.b, c.film_um, c.gap_um, period_um, c.mu, 1);
    } catch (const InputError& e) {
        out.why_none = fmt::format("full wave cannot build this row's barbule: {}", e.what());
        return out;
    }
    fw::RowReferenceRequest request;
    request.resolution_px_per_um =
        std::max(45.0, std::ceil(fw::minimum_resolution_px_per_um(period, lambdas_nm)));
    request.stop = &interrupt_flag();
    const int threads = std::clamp(omp_get_max_threads(), 1, 4);
    request.threads = threads;
    fw::RowReferenceCost cost;
    try {
        cost = fw::row_reference_cost(period, period_um, c.theta_i, lambdas_nm, request);
    } catch (const InputError& e) {
        out.why_none = fmt::format("full wave refuses this row: {}", e.what());
        return out;
    }
    const double predicted_s = cost.cell_runs * fw::kReferenceSecondsPerCellRun / threads;
    if (predicted_s > 60.0 * settings.full_wave_budget_minutes) {
        out.why_none = fmt::format(
            "no committed full-wave reference covers this row, and computing one (a {:g} µm "
            "period at {:g} and {:g} px/µm, {:.3g} M cell-runs) is predicted to take {:.0f} "
            "min, beyond [level] full_wave_budget_minutes = {:g}",
            period_um, request.resolution_px_per_um, 1.5 * request.resolution_px_per_um,
            1e-6 * cost.cell_runs, predicted_s / 60.0, settings.full_wave_budget_minutes);
        return out;
    }
    clock.say(
        fmt::format("level of physics: full wave on the row ({:.0f} s predicted)", predicted_s));
    const fw::RowReference ref =
        fw::row_reference(period, period_um, c.theta_i, lambdas_nm, request);
    out.reflectance = ref.reflectance;
    out.source = fmt::format(
        "computed in this run: {} wavelengths {:g}–{:g} nm, TE and TM, at {:.4g} and {:.4g} "
        "px/µm, decay {:g}, {:.0f} s",
        lambdas_nm.size(), lambdas_nm.front(), lambdas_nm.back(), ref.coarse_px_per_um,
        ref.fine_px_per_um, request.decay, ref.seconds);
    return out;
}

namespace {

std::string certificate_text(const LevelCertificate& c) {
    const sim::wave::RowVerdict2d& v = c.verdict;
    return fmt::format(
        "full wave on the endless row ({}): band-mean R {:.4f}, ray optics {:+.1f} %, physical "
        "optics {:+.1f} %, full wave's own resolution error {:+.2f} %",
        c.source, v.band_full_wave, 100.0 * v.go_error, 100.0 * v.po_error,
        100.0 * v.resolution_error);
}

}  // namespace

LevelDecision decide_level(const LevelSettings& s, const LevelCertificate& c) {
    LevelDecision d;
    const bool converged = c.present && std::abs(c.verdict.resolution_error) <= s.convergence;
    if (!converged) {
        const std::string why =
            c.present ? fmt::format("the full-wave reference is not converged ({}: over {:g} %)",
                                    certificate_text(c), 100.0 * s.convergence)
                      : c.source;
        d.summary = fmt::format(
            "**Level of physics: {}** (asked: {}), **not certified**: {}. Its error against "
            "full wave is unknown.",
            d.measured_with, s.measure, why);
        if (s.measure == "auto")
            d.warning = fmt::format(
                "[level] measure = \"auto\" found no full-wave certificate for this row ({}); "
                "measuring "
                "with {}, whose error is unknown",
                why, d.measured_with);
        return d;
    }
    const sim::wave::RowVerdict2d& v = c.verdict;
    d.needed = std::abs(v.go_error) <= s.tolerance   ? kRayOptics
               : std::abs(v.po_error) <= s.tolerance ? "physical optics"
                                                     : "full wave";
    if (d.needed == kRayOptics) {
        d.summary =
            fmt::format("**Level of physics: {}** (asked: {}), **certified** within {:g} % by {}.",
                        d.measured_with, s.measure, 100.0 * s.tolerance, certificate_text(c));
        return d;
    }
    d.warning = fmt::format(
        "this row needs {} (ray optics + thin film is off by {:+.1f} % against full wave, "
        "beyond the tolerance {:g} %); the instruments measure with ray optics + thin film only, "
        "so every measurement carries that error",
        d.needed, 100.0 * v.go_error, 100.0 * s.tolerance);
    d.summary = fmt::format(
        "**Level of physics: {}** (asked: {}), **below what this row needs: {}**. By {}, ray "
        "optics misses by more than the tolerance {:g} %; no instrument measures at a higher "
        "level, so the measurements below carry that error.",
        d.measured_with, s.measure, d.needed, certificate_text(c), 100.0 * s.tolerance);
    return d;
}

}  // namespace plumage::studies
