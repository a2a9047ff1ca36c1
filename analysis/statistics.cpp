#include "analysis/statistics.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

namespace plumage::analysis {

double regularized_gamma_q(double a, double x) {
    if (!(a > 0.0) || !(x >= 0.0)) return std::numeric_limits<double>::quiet_NaN();
    if (x == 0.0) return 1.0;
    const double log_prefactor = -x + a * std::log(x) - std::lgamma(a);
    constexpr double kEpsilon = 1e-16;
    constexpr int kMaxTerms = 100'000;
    if (x < a + 1.0) {
        // P(a, x) = x^a e^−x / Γ(a + 1) Σ_n x^n / ((a + 1) ... (a + n)).
        double term = 1.0 / a;
        double sum = term;
        for (int n = 1; n < kMaxTerms; ++n) {
            term *= x / (a + n);
            sum += term;
            if (std::abs(term) < std::abs(sum) * kEpsilon) break;
        }
        return std::clamp(1.0 - sum * std::exp(log_prefactor), 0.0, 1.0);
    }
    // Q(a, x) = x^a e^−x / Γ(a) · 1 / (x + 1 − a − 1 (1 − a) / (x + 3 − a − 2 (2 − a) / ...)).
    constexpr double kTiny = 1e-300;
    double b = x + 1.0 - a;
    double c = 1.0 / kTiny;
    double d = 1.0 / b;
    double h = d;
    for (int i = 1; i < kMaxTerms; ++i) {
        const double an = -i * (i - a);
        b += 2.0;
        d = an * d + b;
        if (std::abs(d) < kTiny) d = kTiny;
        c = b + an / c;
        if (std::abs(c) < kTiny) c = kTiny;
        d = 1.0 / d;
        const double delta = d * c;
        h *= delta;
        if (std::abs(delta - 1.0) < kEpsilon) break;
    }
    return std::clamp(std::exp(log_prefactor) * h, 0.0, 1.0);
}

double chi_square_p_value(double statistic, int dof) {
    return dof > 0 ? regularized_gamma_q(0.5 * dof, 0.5 * statistic) : 1.0;
}

double sidak_significance(double family, int tests) {
    return -std::expm1(std::log1p(-family) / std::max(tests, 1));
}

double two_sided_normal_quantile(double p) {
    double lo = 0.0, hi = 40.0;
    for (int i = 0; i < 200; ++i) {
        const double mid = 0.5 * (lo + hi);
        (std::erfc(mid / std::numbers::sqrt2) > p ? lo : hi) = mid;
    }
    return 0.5 * (lo + hi);
}

}  // namespace plumage::analysis
