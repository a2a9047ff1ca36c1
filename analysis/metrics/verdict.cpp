#include "analysis/metrics/verdict.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "analysis/metrics/statistics.h"
#include "common/error.h"

namespace plumage::analysis {

AgreementVerdict agreement(std::span<const double> test, std::span<const double> test_sigma,
                           std::span<const double> reference,
                           std::span<const double> reference_error,
                           std::span<const std::uint8_t> use, double max_reference_error) {
    PLUMAGE_CHECK(test_sigma.size() == test.size() && reference.size() == test.size() &&
                      (reference_error.empty() || reference_error.size() == test.size()) &&
                      (use.empty() || use.size() == test.size()),
                  "agreement: spans of different lengths");
    AgreementVerdict v;
    double sum_test = 0.0, sum_reference = 0.0, variance = 0.0;
    std::size_t beyond = 0;
    std::vector<double> relative_reference_error;
    for (std::size_t c = 0; c < test.size(); ++c) {
        const double s = test_sigma[c];
        if ((!use.empty() && use[c] == 0) || !(s > 0.0) || !std::isfinite(test[c]) ||
            !std::isfinite(reference[c]) || !std::isfinite(s))
            continue;
        const double z = (test[c] - reference[c]) / s;
        v.chi_square += z * z;
        beyond += std::abs(z) > 3.0;
        sum_test += test[c];
        sum_reference += reference[c];
        variance += s * s;
        ++v.cells;
        if (!reference_error.empty() && reference[c] != 0.0)
            relative_reference_error.push_back(std::abs(reference_error[c] / reference[c]));
    }
    if (v.cells == 0) {
        v.verdict = "no cells";
        return v;
    }
    const double n = static_cast<double>(v.cells);
    v.chi_square_p = chi_square_p_value(v.chi_square, static_cast<int>(v.cells));
    v.rms_z = std::sqrt(v.chi_square / n);
    v.beyond_3_sigma = static_cast<double>(beyond) / n;
    if (sum_reference != 0.0) {
        v.power_difference = sum_test / sum_reference - 1.0;
        v.power_difference_sigma = std::sqrt(variance) / std::abs(sum_reference);
        v.power_p =
            std::erfc(std::abs(v.power_difference) / v.power_difference_sigma / std::sqrt(2.0));
    }
    v.p_value = std::min(1.0, 2.0 * std::min(v.chi_square_p, v.power_p));
    if (!relative_reference_error.empty()) {
        auto middle = relative_reference_error.begin() +
                      static_cast<std::ptrdiff_t>(relative_reference_error.size() / 2);
        std::nth_element(relative_reference_error.begin(), middle, relative_reference_error.end());
        v.reference_error = *middle;
        v.reference_converged = v.reference_error <= max_reference_error;
    }
    v.verdict = v.p_value < 1e-3 ? "differs" : v.p_value >= 0.01 ? "agrees" : "undecided";
    return v;
}

}  // namespace plumage::analysis
