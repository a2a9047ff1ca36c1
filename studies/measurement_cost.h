// What the reports print about a measurement's accuracy: its error and what it cost (the "Error
// and time per measurement" table) and p-values as text.
#pragma once

#include <span>
#include <string>

#include "virtual_gonio/goniometer.h"
#include "virtual_gonio/scatterometer.h"

namespace plumage::studies {

// "p = 0.011", or "p < 1e-15" where the χ² tail underflows the double's resolution near 1.
std::string p_value_text(double p);

// One measurement's accuracy and what it cost, for a report's "Error and time per
// measurement" table: every measurement says how accurate it is and what that took.
struct MeasurementCost {
    std::string measurement;  // "scatterogram (beam): simulation"
    std::string samples;      // "photon estimator, 6000 quanta/λ × 1 pass"
    std::string error_kind;   // what `error` is (its definition, briefly)
    double error;             // relative, 1 = 100 %
    double wall_s, cpu_s;
};
// A scatterogram: its median per-pixel relative standard error over the cells above
// signal_fraction of their wavelength's brightest pixel (gonio::median_relative_standard_error).
MeasurementCost scatterogram_cost(const std::string& measurement, const gonio::Scatterogram& s,
                                  double signal_fraction);
// A BRDF record: the estimated relative RMS error of its last pass (its convergence table), the
// photon estimator's standard errors or the eval cubature's against half its rings.
MeasurementCost brdf_cost(const std::string& measurement, const gonio::BrdfRecord& r);
// "## Error and time per measurement": the table, one row each, in measuring order.
std::string measurement_cost_section(std::span<const MeasurementCost> costs);

}  // namespace plumage::studies
