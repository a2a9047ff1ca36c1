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
#include "studies/study_file.h"
#include "studies/study_progress.h"

namespace plumage::studies {

LevelSettings read_level(ParameterTable t) {
    LevelSettings s;
    s.measure =
        t.string("measure", s.measure, {"auto", "ray optics", kPhysicalOptics},
                 "the level of physics the instruments measure with: \"auto\" (the cheapest full "
                 "wave certifies), \"ray optics\" (ray optics + thin film whatever full wave "
                 "says) or \"physical optics\" (the 2.5D physical-optics level as well, whatever "
                 "full wave says); full wave has no instrument: the wave_validity study compares "
                 "it with the others");
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

// Without a converged certificate: the level asked (ray optics under "auto"), its error unknown;
// a warning under "auto" only (otherwise the user chose the level).
LevelDecision uncertified(const LevelSettings& s, const LevelCertificate& c) {
    LevelDecision d;
    if (s.measure == kPhysicalOptics) {
        d.measured_with = kPhysicalOptics;
        d.physical_optics = true;
    }
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

// What the measurements left at ray optics carry when physical optics measures the BRDF too.
std::string rest_at_ray_optics(const LevelDecision& d) {
    return d.needed == kRayOptics
               ? "The other measurements are ray optics + thin film's, certified too."
               : "The study's other measurements are ray optics + thin film's and carry its "
                 "error.";
}

// Physical optics measures as well (asked, or "auto" on a row that needs it).
void physical_optics_decision(const LevelSettings& s, const LevelCertificate& c, LevelDecision& d) {
    const sim::wave::RowVerdict2d& v = c.verdict;
    d.measured_with = kPhysicalOptics;
    d.physical_optics = true;
    const bool within = std::abs(v.po_error) <= s.tolerance;
    d.summary = fmt::format(
        "**Level of physics: {}** (asked: {}) for the goniometer's BRDF, beside ray optics + "
        "thin film; physical optics {} the tolerance {:g} % by {}. {}",
        d.measured_with, s.measure, within ? "**certified** within" : "**not within**",
        100.0 * s.tolerance, certificate_text(c), rest_at_ray_optics(d));
    if (!within)
        d.warning = fmt::format(
            "physical optics is off by {:+.2f} % against full wave on this row, beyond the "
            "tolerance {:g} % (ray optics + thin film {:+.1f} %; the row needs {}): the BRDF "
            "measured at physical optics carries that error",
            100.0 * v.po_error, 100.0 * s.tolerance, 100.0 * v.go_error, d.needed);
    else if (d.needed != kRayOptics)
        d.warning = fmt::format(
            "this row needs {} (ray optics + thin film is off by {:+.1f} % against full wave, "
            "beyond the tolerance {:g} %); the BRDF is measured at physical optics as well, "
            "the study's other measurements are ray optics' and carry that error",
            d.needed, 100.0 * v.go_error, 100.0 * s.tolerance);
}

}  // namespace

LevelDecision decide_level(const LevelSettings& s, const LevelCertificate& c) {
    const bool converged = c.present && std::abs(c.verdict.resolution_error) <= s.convergence;
    if (!converged) return uncertified(s, c);
    LevelDecision d;
    const sim::wave::RowVerdict2d& v = c.verdict;
    d.needed = std::abs(v.go_error) <= s.tolerance   ? kRayOptics
               : std::abs(v.po_error) <= s.tolerance ? kPhysicalOptics
                                                     : "full wave";
    if (s.measure == kPhysicalOptics || (s.measure == "auto" && d.needed == kPhysicalOptics)) {
        physical_optics_decision(s, c, d);
        return d;
    }
    if (d.needed == kRayOptics) {
        d.summary =
            fmt::format("**Level of physics: {}** (asked: {}), **certified** within {:g} % by {}.",
                        d.measured_with, s.measure, 100.0 * s.tolerance, certificate_text(c));
        return d;
    }
    d.warning = fmt::format(
        "this row needs {} (ray optics + thin film is off by {:+.1f} % against full wave, "
        "beyond the tolerance {:g} %); {}, so every measurement carries that error",
        d.needed, 100.0 * v.go_error, 100.0 * s.tolerance,
        s.measure == "ray optics"
            ? "[level] measure = \"ray optics\" measures with ray optics + thin film"
            : fmt::format("no instrument measures at full wave and physical optics is off by "
                          "{:+.1f} %: the measurements are ray optics + thin film's",
                          100.0 * v.po_error));
    d.summary = fmt::format(
        "**Level of physics: {}** (asked: {}), **below what this row needs: {}**. By {}, ray "
        "optics misses by more than the tolerance {:g} %; {}, so the measurements below carry "
        "that error.",
        d.measured_with, s.measure, d.needed, certificate_text(c), 100.0 * s.tolerance,
        s.measure == "ray optics" ? "ray optics + thin film was asked"
                                  : "no instrument measures at a higher level");
    return d;
}

}  // namespace plumage::studies
