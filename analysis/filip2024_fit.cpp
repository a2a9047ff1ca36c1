#include "analysis/filip2024_fit.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>
#include <Eigen/Eigenvalues>
#include <unsupported/Eigen/NonLinearOptimization>

#include "analysis/bounded_parameters.h"
#include "analysis/levenberg_marquardt.h"
#include "common/constants.h"
#include "common/error.h"
#include "common/interrupt.h"

namespace plumage::analysis {
namespace {

// Relative eigenvalue below which JᵀJ (after unit-diagonal scaling) counts as singular.
constexpr double kSingularRatio = 1e-12;

bool periodic(int index) { return index == kFilipPhiA; }

double wrap_half_turn(double phi) {
    // Into (−π/2, π/2]: φa and φa + π are the same model.
    double wrapped = std::remainder(phi, kPi);
    if (wrapped <= -kPi / 2) wrapped += kPi;
    return wrapped;
}

struct PreparedObservation {
    Filip2024Geometry geometry;
    RgbChannel channel;
    double value;
    double inverse_sigma;
};

bool is_unit_above_patch(const Vec3d& w) {
    return w.allFinite() && std::abs(w.norm() - 1.0) <= 1e-6 && w.z() > 0.0;
}

std::vector<PreparedObservation> prepare(std::span<const BrdfObservation> data) {
    std::vector<PreparedObservation> prepared;
    prepared.reserve(data.size());
    const bool weighted = !data.empty() && data.front().standard_error.has_value();
    for (std::size_t k = 0; k < data.size(); ++k) {
        const BrdfObservation& o = data[k];
        auto fail = [k](const std::string& what) {
            throw InputError(fmt::format("Filip 2024 fit: observation {}: {}", k, what));
        };
        if (!is_unit_above_patch(o.wi) || !is_unit_above_patch(o.wo)) {
            fail(
                fmt::format("wi = ({}, {}, {}), wo = ({}, {}, {}): expected unit vectors with "
                            "z > 0 (the model is a BRDF of the upper side)",
                            o.wi.x(), o.wi.y(), o.wi.z(), o.wo.x(), o.wo.y(), o.wo.z()));
        }
        if (o.channel.has_value() == o.lambda_nm.has_value()) {
            fail("expected exactly one of channel and lambda_nm");
        }
        RgbChannel channel = RgbChannel::kRed;
        if (o.channel) {
            channel = *o.channel;
            const int c = static_cast<int>(channel);
            if (c < 0 || c > 2)
                fail(fmt::format("channel = {}: expected 0 (R), 1 (G) or 2 (B)", c));
        } else {
            try {
                channel = filip2024_channel(*o.lambda_nm);
            } catch (const InputError& e) {
                fail(e.what());
            }
        }
        if (!std::isfinite(o.value))
            fail(fmt::format("value = {}: expected a finite BRDF", o.value));
        if (o.standard_error.has_value() != weighted) {
            fail("standard errors are given for some observations only: give all or none");
        }
        double inverse_sigma = 1.0;
        if (o.standard_error) {
            if (!(std::isfinite(*o.standard_error) && *o.standard_error > 0.0)) {
                fail(fmt::format("standard_error = {}: expected a finite value > 0",
                                 *o.standard_error));
            }
            inverse_sigma = 1.0 / *o.standard_error;
        }
        prepared.push_back({filip2024_geometry(o.wi, o.wo), channel, o.value, inverse_sigma});
    }
    return prepared;
}

BoundedRange range(int index) {
    const auto& info = kFilip2024ParameterTable[index];
    return {info.min, info.max};
}

// The optimiser's variables u ↔ the parameters p: logistic onto each range
// (bounded_parameters.h), identity for φa.
struct ParameterMap {
    std::array<double, kFilip2024ParameterCount> base;  // fixed parameters' values
    std::vector<int> free;

    double to_parameter(int index, double u) const {
        return periodic(index) ? u : range(index).parameter(u);
    }
    double derivative(int index, double u) const {  // dp/du
        return periodic(index) ? 1.0 : range(index).slope(u);
    }
    double to_variable(int index, double p) const {
        return periodic(index) ? p : range(index).variable(p);
    }
    std::array<double, kFilip2024ParameterCount> parameters(const Eigen::VectorXd& u) const {
        auto v = base;
        for (std::size_t j = 0; j < free.size(); ++j) v[free[j]] = to_parameter(free[j], u[j]);
        return v;
    }
};

// The functor interface of Eigen's LevenbergMarquardt: residuals and their Jacobian in u.
struct Residuals {
    const std::vector<PreparedObservation>& data;
    const ParameterMap& map;

    int values() const { return static_cast<int>(data.size()); }

    int operator()(const Eigen::VectorXd& u, Eigen::VectorXd& r) const {
        // Once per iteration: a fit of 10^4 observations takes seconds, Ctrl-C must not wait.
        if (interrupt_requested()) throw Interrupted("interrupted while fitting Filip 2024");
        const Filip2024Parameters p = from_vector(map.parameters(u));
        for (std::size_t k = 0; k < data.size(); ++k) {
            const double f = filip2024_terms(p, data[k].geometry, data[k].channel).total();
            r[static_cast<Eigen::Index>(k)] = (f - data[k].value) * data[k].inverse_sigma;
        }
        return 0;
    }

    int df(const Eigen::VectorXd& u, Eigen::MatrixXd& jacobian) const {
        if (interrupt_requested()) throw Interrupted("interrupted while fitting Filip 2024");
        const Filip2024Parameters p = from_vector(map.parameters(u));
        std::vector<double> chain(map.free.size());
        for (std::size_t j = 0; j < map.free.size(); ++j)
            chain[j] = map.derivative(map.free[j], u[j]);
        std::array<double, kFilip2024ParameterCount> gradient{};
        for (std::size_t k = 0; k < data.size(); ++k) {
            filip2024_value_and_gradient(p, data[k].geometry, data[k].channel, gradient);
            for (std::size_t j = 0; j < map.free.size(); ++j) {
                jacobian(static_cast<Eigen::Index>(k), static_cast<Eigen::Index>(j)) =
                    gradient[map.free[j]] * chain[j] * data[k].inverse_sigma;
            }
        }
        return 0;
    }
};

}  // namespace

double filip2024_value_and_gradient(const Filip2024Parameters& p, const Filip2024Geometry& g,
                                    RgbChannel channel,
                                    std::span<double, kFilip2024ParameterCount> gradient) {
    const int c = static_cast<int>(channel);
    const double s = p.brdf_scale_per_sr;
    const double sin_a = std::sin(p.phi_a_rad);
    const double cos_a = std::cos(p.phi_a_rad);
    const double h_dot_u = g.half_vector.x() * sin_a + g.half_vector.y() * cos_a;
    const double x = 1.0 - std::abs(h_dot_u);
    const double y_raw = (x - p.w + p.d_w) / (2.0 * p.d_w);
    const double y = std::clamp(y_raw, 0.0, 1.0);
    const double m = y * y * (3.0 - 2.0 * y);
    const double dm_dy = (y_raw > 0.0 && y_raw < 1.0) ? 6.0 * y * (1.0 - y) : 0.0;

    const double falloff_raw = 1.0 - g.polar_difference_rad / p.theta_max_rad;
    const double falloff = std::max(0.0, falloff_raw);
    const double e = g.elevation;
    const double retro_power = std::pow(g.d_retro, p.gamma);
    const double e_beta = std::pow(e, p.beta);

    const double near_specular_shape = e * g.d_specular * falloff;  // E D(0) F
    const double retro_shape = e * retro_power * falloff;           // E D(π)^γ F
    const double specular_shape = e_beta * g.d_specular;            // E^β D(0)

    const double bracket = (1.0 - m) * p.c_b[c] + m * p.c_a[c] +
                           (1.0 - m) * p.c_s[c] * near_specular_shape +
                           (1.0 - m) * p.c_r[c] * retro_shape + m * p.alpha * specular_shape;

    std::fill(gradient.begin(), gradient.end(), 0.0);
    gradient[kFilipCbR + c] = s * (1.0 - m);
    gradient[kFilipCaR + c] = s * m;
    gradient[kFilipCsR + c] = s * (1.0 - m) * near_specular_shape;
    gradient[kFilipCrR + c] = s * (1.0 - m) * retro_shape;
    gradient[kFilipAlpha] = s * m * specular_shape;
    gradient[kFilipBeta] = s * m * p.alpha * specular_shape * std::log(e);
    gradient[kFilipGamma] =
        g.d_retro > 0.0 ? s * (1.0 - m) * p.c_r[c] * retro_shape * std::log(g.d_retro) : 0.0;
    if (falloff_raw > 0.0) {
        // ∂F/∂θmax = |θi − θo| / θmax².
        const double dfalloff = g.polar_difference_rad / (p.theta_max_rad * p.theta_max_rad);
        gradient[kFilipThetaMax] =
            s * (1.0 - m) * e * (p.c_s[c] * g.d_specular + p.c_r[c] * retro_power) * dfalloff;
    }
    gradient[kFilipBrdfScale] = bracket;

    // Through the mask: ∂f/∂M (∂M/∂y) ∂y/∂(φa, w, d_w), y = (x − w)/(2 d_w) + 1/2.
    const double df_dm = s * (-p.c_b[c] + p.c_a[c] - p.c_s[c] * near_specular_shape -
                              p.c_r[c] * retro_shape + p.alpha * specular_shape);
    const double df_dy = df_dm * dm_dy;
    const double dx_dphi = -(h_dot_u > 0.0 ? 1.0 : (h_dot_u < 0.0 ? -1.0 : 0.0)) *
                           (g.half_vector.x() * cos_a - g.half_vector.y() * sin_a);
    gradient[kFilipPhiA] = df_dy * dx_dphi / (2.0 * p.d_w);
    gradient[kFilipW] = -df_dy / (2.0 * p.d_w);
    gradient[kFilipDw] = -df_dy * (x - p.w) / (2.0 * p.d_w * p.d_w);
    return s * bracket;
}

Filip2024FitResult fit_filip2024(std::span<const BrdfObservation> data,
                                 const Filip2024Parameters& start,
                                 const Filip2024FitOptions& options) {
    validate(start);
    const std::vector<PreparedObservation> prepared = prepare(data);

    ParameterMap map;
    map.base = to_vector(start);
    for (int i = 0; i < kFilip2024ParameterCount; ++i) {
        if (!options.fixed[i]) map.free.push_back(i);
    }
    const int n_free = static_cast<int>(map.free.size());
    const int n_obs = static_cast<int>(prepared.size());
    if (n_free == 0) throw InputError("Filip 2024 fit: every parameter is fixed: nothing to fit");
    if (n_obs <= n_free) {
        throw InputError(fmt::format(
            "Filip 2024 fit: {} observations for {} free parameters: expected more observations "
            "than free parameters",
            n_obs, n_free));
    }
    if (options.max_function_evaluations < 1 || !(options.relative_tolerance > 0.0)) {
        throw InputError(fmt::format(
            "Filip 2024 fit: max_function_evaluations = {}, relative_tolerance = {}: expected "
            ">= 1 and > 0",
            options.max_function_evaluations, options.relative_tolerance));
    }

    Eigen::VectorXd u(n_free);
    for (int j = 0; j < n_free; ++j) u[j] = map.to_variable(map.free[j], map.base[map.free[j]]);

    Residuals residuals{prepared, map};
    Eigen::LevenbergMarquardt<Residuals> lm(residuals);
    lm.parameters.maxfev = options.max_function_evaluations;
    lm.parameters.ftol = options.relative_tolerance;
    lm.parameters.xtol = options.relative_tolerance;
    const auto status = lm.minimize(u);

    Filip2024FitResult result;
    auto values = map.parameters(u);
    values[kFilipPhiA] = wrap_half_turn(values[kFilipPhiA]);
    result.values = values;
    result.parameters = from_vector(values);
    result.free_parameters = map.free;
    result.observations = n_obs;
    result.degrees_of_freedom = n_obs - n_free;
    result.function_evaluations = static_cast<int>(lm.nfev);
    result.jacobian_evaluations = static_cast<int>(lm.njev);
    result.converged = converged(status);
    result.termination = describe(status);

    // Residuals and the Jacobian in the parameters' own units at the optimum.
    Eigen::MatrixXd jacobian(n_obs, n_free);
    double weighted_sum = 0.0;
    double plain_sum = 0.0;
    std::array<double, kFilip2024ParameterCount> gradient{};
    for (int k = 0; k < n_obs; ++k) {
        const auto& o = prepared[k];
        const double f =
            filip2024_value_and_gradient(result.parameters, o.geometry, o.channel, gradient);
        const double r = f - o.value;
        plain_sum += r * r;
        weighted_sum += r * r * o.inverse_sigma * o.inverse_sigma;
        for (int j = 0; j < n_free; ++j) jacobian(k, j) = gradient[map.free[j]] * o.inverse_sigma;
    }
    result.residual_rms = std::sqrt(plain_sum / n_obs);
    result.reduced_chi_square = weighted_sum / result.degrees_of_freedom;

    for (int i = 0; i < kFilip2024ParameterCount; ++i) {
        result.standard_errors[i] = std::numeric_limits<double>::quiet_NaN();
        result.at_bound[i] = !periodic(i) && !options.fixed[i] && range(i).near_bound(values[i]);
    }

    // covariance = s² (JᵀJ)⁻¹, inverted after scaling JᵀJ to a unit diagonal so that the
    // singularity test does not depend on the parameters' units.
    const Eigen::MatrixXd normal = normal_matrix(jacobian);
    const Eigen::VectorXd diagonal = normal.diagonal();
    result.covariance =
        Eigen::MatrixXd::Constant(n_free, n_free, std::numeric_limits<double>::quiet_NaN());
    if ((diagonal.array() > 0.0).all()) {
        const Eigen::VectorXd scale = diagonal.array().rsqrt();
        const Eigen::MatrixXd scaled = scale.asDiagonal() * normal * scale.asDiagonal();
        const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(scaled);
        const Eigen::VectorXd lambda = eigen.eigenvalues();
        if (eigen.info() == Eigen::Success &&
            lambda.minCoeff() > kSingularRatio * lambda.maxCoeff()) {
            const Eigen::MatrixXd inverse = eigen.eigenvectors() *
                                            lambda.cwiseInverse().asDiagonal() *
                                            eigen.eigenvectors().transpose();
            result.covariance =
                result.reduced_chi_square * scale.asDiagonal() * inverse * scale.asDiagonal();
            result.covariance_available = true;
            for (int j = 0; j < n_free; ++j) {
                result.standard_errors[map.free[j]] = std::sqrt(result.covariance(j, j));
            }
        }
    }
    return result;
}

}  // namespace plumage::analysis
