#include "analysis/metrics/convergence.h"

#include <cmath>
#include <limits>

#include "analysis/metrics/statistics.h"
#include "common/error.h"

namespace plumage::analysis {

ErrorAgainstReference error_against_reference(std::span<const double> value,
                                              std::span<const double> standard_error,
                                              std::span<const double> reference,
                                              std::span<const double> reference_error) {
    PLUMAGE_CHECK(value.size() == standard_error.size() && value.size() == reference.size() &&
                      value.size() == reference_error.size(),
                  "error_against_reference: spans of different lengths");
    ErrorAgainstReference e;
    double est = 0.0, tru = 0.0, floor = 0.0;
    for (std::size_t k = 0; k < value.size(); ++k) {
        const double ref = reference[k], s = standard_error[k], r = reference_error[k];
        if (!(ref > 0.0) || !(s * s + r * r > 0.0)) continue;
        const double d = value[k] - ref;
        est += (s / ref) * (s / ref);
        tru += (d / ref) * (d / ref);
        floor += (r / ref) * (r / ref);
        e.chi_square += d * d / (s * s + r * r);
        ++e.cells;
    }
    if (e.cells == 0) return e;
    const double n = e.cells;
    e.estimated = std::sqrt(est / n);
    e.true_error = std::sqrt(tru / n);
    e.reference_floor = std::sqrt(floor / n);
    e.p_value = chi_square_p_value(e.chi_square, e.cells);
    return e;
}

PowerLawFit fit_power_law(std::span<const double> t, std::span<const double> e) {
    PLUMAGE_CHECK(t.size() == e.size(), "fit_power_law: spans of different lengths");
    double sx = 0.0, sy = 0.0, sxx = 0.0, sxy = 0.0;
    PowerLawFit fit;
    for (std::size_t i = 0; i < t.size(); ++i) {
        if (!(t[i] > 0.0) || !(e[i] > 0.0)) continue;
        const double x = std::log(t[i]), y = std::log(e[i]);
        sx += x;
        sy += y;
        sxx += x * x;
        sxy += x * y;
        ++fit.points;
    }
    const double n = fit.points;
    const double spread = sxx - sx * sx / n;
    if (fit.points < 2 || !(spread > 0.0)) {
        fit.exponent = std::numeric_limits<double>::quiet_NaN();
        return fit;
    }
    fit.exponent = (sxy - sx * sy / n) / spread;
    const double intercept = (sy - fit.exponent * sx) / n;
    fit.prefactor = std::exp(intercept);
    if (fit.points > 2) {
        double residual = 0.0;
        for (std::size_t i = 0; i < t.size(); ++i) {
            if (!(t[i] > 0.0) || !(e[i] > 0.0)) continue;
            const double r = std::log(e[i]) - intercept - fit.exponent * std::log(t[i]);
            residual += r * r;
        }
        fit.exponent_standard_error = std::sqrt(residual / (n - 2.0) / spread);
    }
    return fit;
}

}  // namespace plumage::analysis
