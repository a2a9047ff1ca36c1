#include "studies/measurement_cost.h"

#include <limits>

#include <fmt/format.h>

namespace plumage::studies {

std::string p_value_text(double p) {
    return p < 1e-15 ? std::string("p < 1e-15") : fmt::format("p = {:.2g}", p);
}

MeasurementCost scatterogram_cost(const std::string& measurement, const gonio::Scatterogram& s,
                                  double signal_fraction) {
    return {measurement,
            fmt::format("{} quanta/λ × {} pass{}, {} px", s.config.quanta_per_pass, s.passes,
                        s.passes == 1 ? "" : "es", s.config.image_size),
            fmt::format("median per-pixel σ/I (pixels above {:g} % of the peak)",
                        100.0 * signal_fraction),
            gonio::median_relative_standard_error(s, signal_fraction),
            s.wall_time_s,
            s.cpu_time_s};
}

namespace {

// How the photon estimator aimed its diffuse directions at the detectors (GoniometerConfig).
std::string guided_description(const gonio::GoniometerConfig& c) {
    std::string text;
    if (c.guided_branches > 0) {
        text += fmt::format(", {} guided branch{} at the first diffuse event", c.guided_branches,
                            c.guided_branches == 1 ? "" : "es");
    }
    if (c.guided_fraction > 0.0) {
        text += fmt::format(", {:.0f} % of first diffuse directions guided to the detectors",
                            100.0 * c.guided_fraction);
    }
    return text;
}

// The detector-side half of a connected measurement (GoniometerConfig::connect_lights).
std::string connected_description(const gonio::BrdfRecord& r) {
    return fmt::format(", lights connected to {} detector-side walks per view and pass",
                       r.config.connected_walks_per_pass());
}

}  // namespace

MeasurementCost brdf_cost(const std::string& measurement, const gonio::BrdfRecord& r) {
    const bool photon = r.estimator_used == gonio::Estimator::photon;
    const std::string samples =
        photon ? fmt::format("photon estimator, {} quanta/λ per light × {} pass{}{}{}{}{}",
                             r.config.quanta_per_pass, r.passes, r.passes == 1 ? "" : "es",
                             r.wavelength_paths_shared ? ", wavelengths sharing paths" : "",
                             r.reflections_split ? ", split at the first film and the reflected "
                                                   "branch's next"
                             : r.paths_split     ? ", split at the first film"
                                                 : "",
                             r.diffuse_guided ? guided_description(r.config) : "",
                             r.lights_connected ? connected_description(r) : "")
        : r.config.eval_tolerance > 0.0
            ? fmt::format("eval cubature, {}–{} rings per cone until within {:g} %",
                          r.config.eval_rings, r.config.eval_max_rings,
                          100.0 * r.config.eval_tolerance)
            : fmt::format("eval cubature, {} rings per cone", r.config.eval_rings);
    const double error = r.convergence.empty() ? std::numeric_limits<double>::quiet_NaN()
                                               : r.convergence.back().estimated_relative_rms_error;
    return {measurement,
            samples,
            photon ? "relative RMS standard error over the cells > 0"
                   : "relative RMS of the rule against the half-rings rule, cells > 0",
            error,
            r.wall_time_s,
            r.cpu_time_s};
}

std::string measurement_cost_section(std::span<const MeasurementCost> costs) {
    std::string md =
        "## Error and time per measurement\n\nEach measurement's own error estimate (from its "
        "record; the comparisons above set their differences beside these) and its wall and CPU "
        "time.\n\n| measurement | samples | estimated error | of what | wall (s) | CPU (s) |\n"
        "|---|---|---|---|---|---|\n";
    for (const MeasurementCost& c : costs)
        md += fmt::format("| {} | {} | {:.2f} % | {} | {:.3g} | {:.3g} |\n", c.measurement,
                          c.samples, 100.0 * c.error, c.error_kind, c.wall_s, c.cpu_s);
    return md + "\n";
}

}  // namespace plumage::studies
