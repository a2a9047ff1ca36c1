#include "analysis/metrics/statistics.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string_view>

#include <fmt/format.h>
#include <boost/math/distributions/chi_squared.hpp>
#include <boost/math/distributions/normal.hpp>
#include <boost/math/policies/policy.hpp>
#include <boost/math/special_functions/erf.hpp>
#include <boost/math/special_functions/gamma.hpp>

#include "common/error.h"
#include "common/require.h"

namespace plumage::analysis {
namespace {

// Domain and evaluation errors throw (we check the domain first, so any left are bugs, caught
// below); overflow returns ±∞ and underflow 0, without touching errno's meaning for callers.
namespace bmp = boost::math::policies;
using Policy =
    bmp::policy<bmp::domain_error<bmp::throw_on_error>, bmp::pole_error<bmp::throw_on_error>,
                bmp::overflow_error<bmp::ignore_error>, bmp::underflow_error<bmp::ignore_error>,
                bmp::denorm_error<bmp::ignore_error>, bmp::evaluation_error<bmp::throw_on_error>>;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Runs a Boost.Math call; its exceptions become InvariantError naming our function and the
// arguments (which passed our own checks, so a throw is a bug here, not a user error). The
// arguments are formatted only then: normal_quantile runs once per sampled lobe direction.
template <class Compute, class Describe>
double guarded(std::string_view function, Compute&& compute, Describe&& arguments) {
    try {
        return compute();
    } catch (const std::exception& e) {
        throw InvariantError(fmt::format("analysis::{}({}): Boost.Math failed: {}", function,
                                         arguments(), e.what()));
    }
}

}  // namespace

double regularized_gamma_q(double a, double x) {
    if (!(a > 0.0) || !std::isfinite(a) || !(x >= 0.0)) return kNaN;
    if (std::isinf(x)) return 0.0;
    return guarded(
        "regularized_gamma_q", [&] { return boost::math::gamma_q(a, x, Policy()); },
        [&] { return fmt::format("a = {}, x = {}", a, x); });
}

double chi_square_p_value(double statistic, int dof) {
    if (dof <= 0) return 1.0;
    if (!(statistic >= 0.0)) return kNaN;
    if (std::isinf(statistic)) return 0.0;
    return guarded(
        "chi_square_p_value",
        [&] {
            const boost::math::chi_squared_distribution<double, Policy> chi2(dof);
            return boost::math::cdf(boost::math::complement(chi2, statistic));
        },
        [&] { return fmt::format("statistic = {}, dof = {}", statistic, dof); });
}

double sidak_significance(double family, int tests) {
    require(family > 0.0 && family < 1.0, "sidak_significance", "family", family,
            "a family-wise significance in (0, 1)");
    return -std::expm1(std::log1p(-family) / std::max(tests, 1));
}

double two_sided_normal_quantile(double p) {
    require(p > 0.0 && p <= 1.0, "two_sided_normal_quantile", "p", p,
            "a two-sided tail probability in (0, 1]");
    return guarded(
        "two_sided_normal_quantile",
        [&] { return std::numbers::sqrt2 * boost::math::erfc_inv(p, Policy()); },
        [&] { return fmt::format("p = {}", p); });
}

double normal_quantile(double p) {
    if (!(p > 0.0)) return -std::numeric_limits<double>::infinity();
    if (!(p < 1.0)) return std::numeric_limits<double>::infinity();
    return guarded(
        "normal_quantile",
        [&] {
            return boost::math::quantile(boost::math::normal_distribution<double, Policy>(), p);
        },
        [&] { return fmt::format("p = {}", p); });
}

double reciprocity_z(const ReciprocityCell& a, const ReciprocityCell& b, std::uint64_t quanta) {
    const double n = static_cast<double>(quanta), n1 = std::max(1.0, n - 1.0);
    // Each cell's mean of x and of x² (x = w / (P cos θ_view) on a hit), from the record.
    auto second_moment = [n1](const ReciprocityCell& c) {
        return c.standard_error * c.standard_error * n1 + c.value * c.value;
    };
    const double first = a.cos_view * a.value + b.cos_view * b.value;
    if (!(first > 0.0)) return std::numeric_limits<double>::quiet_NaN();
    const double kappa =
        (a.cos_view * a.cos_view * second_moment(a) + b.cos_view * b.cos_view * second_moment(b)) /
        first;  // κ / P
    const double mu = first / (a.cos_view + b.cos_view);
    const double var =
        (mu * kappa / a.cos_view - mu * mu) / n1 + (mu * kappa / b.cos_view - mu * mu) / n1;
    if (!(var > 0.0)) return std::numeric_limits<double>::quiet_NaN();
    return (a.value - b.value) / std::sqrt(var);
}

}  // namespace plumage::analysis
