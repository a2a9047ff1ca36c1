#include "analysis/filip2024_fit.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>
#include <Eigen/Eigenvalues>

#include "analysis/bounded_parameters.h"
#include "analysis/least_squares.h"
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

// The observations grouped by direction pair: the geometry, and everything of f that does not
// depend on the colour channel, is computed once per pair (a spectral record has several
// wavelengths per pair).
struct PreparedObservation {
    RgbChannel channel;
    double value;
    double inverse_sigma;
};

// A direction pair with the logarithms of E and D(π), so that the powers E^β and D(π)^γ of each
// evaluation are one exp each (and the gradient's ln E, ln D(π) come free).
struct PairGeometry {
    Filip2024Geometry geometry;
    double log_elevation;  // ln E (E ≥ 0.1 > 0)
    double log_d_retro;    // ln D(π); −∞ where D(π) = 0
};

PairGeometry pair_geometry(const Filip2024Geometry& g) {
    return {g, std::log(g.elevation),
            g.d_retro > 0.0 ? std::log(g.d_retro) : -std::numeric_limits<double>::infinity()};
}

struct PreparedPair {
    PairGeometry geometry;
    std::size_t first, last;  // its observations: [first, last)
};

struct PreparedData {
    std::vector<PreparedPair> pairs;
    std::vector<PreparedObservation> observations;
};

bool is_unit_above_patch(const Vec3d& w) {
    return w.allFinite() && std::abs(w.norm() - 1.0) <= 1e-6 && w.z() > 0.0;
}

PreparedData prepare(std::span<const BrdfObservation> data) {
    PreparedData prepared;
    prepared.observations.reserve(data.size());
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
        // Consecutive observations of the same pair (bit for bit) share its geometry.
        if (k == 0 || o.wi != data[k - 1].wi || o.wo != data[k - 1].wo)
            prepared.pairs.push_back({pair_geometry(filip2024_geometry(o.wi, o.wo)), k, k});
        prepared.pairs.back().last = k + 1;
        prepared.observations.push_back({channel, o.value, inverse_sigma});
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

// The parts of f and of its gradient that do not depend on the colour channel, at one set of
// parameters and one direction pair.
struct PairTerms {
    double m, dm_dy;             // the mask M of Eq. 2 and dM/dy
    double x;                    // 1 − |H·U|
    double dx_dphi;              // ∂x/∂φa
    double dfalloff;             // ∂F/∂θmax (0 where F is clamped)
    double near_specular_shape;  // E D(0) F
    double retro_power;          // D(π)^γ
    double retro_shape;          // E D(π)^γ F
    double specular_shape;       // E^β D(0)
};

PairTerms pair_terms(const Filip2024Parameters& p, double sin_a, double cos_a,
                     const PairGeometry& pair) {
    const Filip2024Geometry& g = pair.geometry;
    PairTerms t;
    const double h_dot_u = g.half_vector.x() * sin_a + g.half_vector.y() * cos_a;
    t.x = 1.0 - std::abs(h_dot_u);
    const double y_raw = (t.x - p.w + p.d_w) / (2.0 * p.d_w);
    const double y = std::clamp(y_raw, 0.0, 1.0);
    t.m = y * y * (3.0 - 2.0 * y);
    t.dm_dy = (y_raw > 0.0 && y_raw < 1.0) ? 6.0 * y * (1.0 - y) : 0.0;
    t.dx_dphi = -(h_dot_u > 0.0 ? 1.0 : (h_dot_u < 0.0 ? -1.0 : 0.0)) *
                (g.half_vector.x() * cos_a - g.half_vector.y() * sin_a);

    const double falloff_raw = 1.0 - g.polar_difference_rad / p.theta_max_rad;
    const double falloff = std::max(0.0, falloff_raw);
    // ∂F/∂θmax = |θi − θo| / θmax².
    t.dfalloff =
        falloff_raw > 0.0 ? g.polar_difference_rad / (p.theta_max_rad * p.theta_max_rad) : 0.0;
    const double e = g.elevation;
    // D^γ with D^0 = 1 also at D = 0 (as std::pow), where γ ln D would be 0 × −∞.
    t.retro_power = p.gamma == 0.0 ? 1.0 : std::exp(p.gamma * pair.log_d_retro);
    t.near_specular_shape = e * g.d_specular * falloff;
    t.retro_shape = e * t.retro_power * falloff;
    t.specular_shape = std::exp(p.beta * pair.log_elevation) * g.d_specular;
    return t;
}

// f (1/sr) for one channel and, with kGradient, its gradient in every parameter of the table.
template <bool kGradient>
double channel_value(const Filip2024Parameters& p, const PairTerms& t, const PairGeometry& pair,
                     int c, std::span<double, kFilip2024ParameterCount> gradient) {
    const double s = p.brdf_scale_per_sr;
    const double m = t.m;
    const double bracket = (1.0 - m) * p.c_b[c] + m * p.c_a[c] +
                           (1.0 - m) * p.c_s[c] * t.near_specular_shape +
                           (1.0 - m) * p.c_r[c] * t.retro_shape + m * p.alpha * t.specular_shape;
    if constexpr (kGradient) {
        const Filip2024Geometry& g = pair.geometry;
        std::fill(gradient.begin(), gradient.end(), 0.0);
        gradient[kFilipCbR + c] = s * (1.0 - m);
        gradient[kFilipCaR + c] = s * m;
        gradient[kFilipCsR + c] = s * (1.0 - m) * t.near_specular_shape;
        gradient[kFilipCrR + c] = s * (1.0 - m) * t.retro_shape;
        gradient[kFilipAlpha] = s * m * t.specular_shape;
        gradient[kFilipBeta] = s * m * p.alpha * t.specular_shape * pair.log_elevation;
        // ∂(D^γ)/∂γ = D^γ ln D, 0 at D = 0 (the limit for γ > 0; D^0 = 1 has no γ dependence).
        gradient[kFilipGamma] =
            g.d_retro > 0.0 ? s * (1.0 - m) * p.c_r[c] * t.retro_shape * pair.log_d_retro : 0.0;
        gradient[kFilipThetaMax] = s * (1.0 - m) * g.elevation *
                                   (p.c_s[c] * g.d_specular + p.c_r[c] * t.retro_power) *
                                   t.dfalloff;
        gradient[kFilipBrdfScale] = bracket;

        // Through the mask: ∂f/∂M (∂M/∂y) ∂y/∂(φa, w, d_w), y = (x − w)/(2 d_w) + 1/2.
        const double df_dm = s * (-p.c_b[c] + p.c_a[c] - p.c_s[c] * t.near_specular_shape -
                                  p.c_r[c] * t.retro_shape + p.alpha * t.specular_shape);
        const double df_dy = df_dm * t.dm_dy;
        gradient[kFilipPhiA] = df_dy * t.dx_dphi / (2.0 * p.d_w);
        gradient[kFilipW] = -df_dy / (2.0 * p.d_w);
        gradient[kFilipDw] = -df_dy * (t.x - p.w) / (2.0 * p.d_w * p.d_w);
    }
    return s * bracket;
}

// Pairs per chunk of the parallel sums: fixed, so the sums' order is the data's, not the
// thread count's; ~100 chunks for the 3660 pairs of the Filip set.
constexpr std::size_t kPairsPerChunk = 32;

// The weighted residuals r_k = (f_k − value_k) / σ_k and their Jacobian, in the optimiser's
// variables u (or, for the covariance, in the free parameters' own units).
class FilipLeastSquares final : public ChunkedLeastSquares {
public:
    FilipLeastSquares(const PreparedData& data, const ParameterMap& map)
        : data_(data), map_(map), chain_(map.free.size(), 1.0) {
        // Per channel, the free columns its observations can touch: every column but the other
        // channels' colours (their derivatives are exactly zero).
        for (int c = 0; c < 3; ++c) {
            for (std::size_t j = 0; j < map.free.size(); ++j) {
                const int i = map.free[j];
                const bool colour = i >= kFilipCbR && i <= kFilipCrB;
                if (!colour || (i - kFilipCbR) % 3 == c) active_[c].push_back(static_cast<int>(j));
            }
        }
    }

    int variables() const override { return static_cast<int>(map_.free.size()); }
    std::size_t chunks() const override {
        return (data_.pairs.size() + kPairsPerChunk - 1) / kPairsPerChunk;
    }

    void set_point(const Eigen::VectorXd& u) override {
        p_ = from_vector(map_.parameters(u));
        sin_a_ = std::sin(p_.phi_a_rad);
        cos_a_ = std::cos(p_.phi_a_rad);
        for (std::size_t j = 0; j < map_.free.size(); ++j)
            chain_[j] = map_.derivative(map_.free[j], u[static_cast<Eigen::Index>(j)]);
    }

    // The point given by parameter values, with the Jacobian in their own units (dp/du = 1).
    void set_parameters(const Filip2024Parameters& p) {
        p_ = p;
        sin_a_ = std::sin(p_.phi_a_rad);
        cos_a_ = std::cos(p_.phi_a_rad);
        std::fill(chain_.begin(), chain_.end(), 1.0);
    }

    // Σ (f − value)², unweighted.
    double chunk_plain_sum_of_squares(std::size_t chunk) const {
        double sum = 0.0;
        for_each_observation<false>(chunk,
                                    [&](const PreparedObservation& o, double f, const auto&) {
                                        sum += (f - o.value) * (f - o.value);
                                    });
        return sum;
    }

    void add_chunk_normal_equations(std::size_t chunk, NormalEquations& sum) const override {
        // Accumulated on this thread's stack and stored once: the chunks' slots are separate
        // heap blocks that may share cache lines, and adding into them observation by observation
        // made two threads barely faster than one.
        constexpr int kMax = kFilip2024ParameterCount;
        std::array<double, kMax * kMax> jtj{};
        std::array<double, kMax> jtr{}, row{};
        double sum_of_squares = 0.0;
        for_each_observation<true>(
            chunk, [&](const PreparedObservation& o, double f, const std::array<double, kMax>& g) {
                const double r = (f - o.value) * o.inverse_sigma;
                sum_of_squares += r * r;
                const auto& active = active_[static_cast<int>(o.channel)];
                for (int j : active) row[j] = g[map_.free[j]] * chain_[j] * o.inverse_sigma;
                for (std::size_t a = 0; a < active.size(); ++a) {
                    const int i = active[a];
                    jtr[i] += row[i] * r;
                    for (std::size_t b = 0; b <= a; ++b)
                        jtj[i * kMax + active[b]] += row[i] * row[active[b]];
                }
            });
        const int n = variables();
        for (int i = 0; i < n; ++i) {
            sum.jtr[i] += jtr[i];
            for (int j = 0; j <= i; ++j) sum.jtj(i, j) += jtj[i * kMax + j];
        }
        sum.sum_of_squares += sum_of_squares;
    }

private:
    // visit(observation, f, gradient) for each observation of the chunk, in order; the gradient
    // is computed only when asked for.
    template <bool kGradient, class Visit>
    void for_each_observation(std::size_t chunk, Visit&& visit) const {
        std::array<double, kFilip2024ParameterCount> gradient{};
        const std::size_t first = chunk * kPairsPerChunk;
        const std::size_t last = std::min(first + kPairsPerChunk, data_.pairs.size());
        for (std::size_t q = first; q < last; ++q) {
            const PreparedPair& pair = data_.pairs[q];
            const PairTerms t = pair_terms(p_, sin_a_, cos_a_, pair.geometry);
            for (std::size_t k = pair.first; k < pair.last; ++k) {
                const PreparedObservation& o = data_.observations[k];
                const double f = channel_value<kGradient>(p_, t, pair.geometry,
                                                          static_cast<int>(o.channel), gradient);
                visit(o, f, gradient);
            }
        }
    }

    const PreparedData& data_;
    const ParameterMap& map_;
    std::array<std::vector<int>, 3> active_;
    Filip2024Parameters p_;
    double sin_a_ = 0.0, cos_a_ = 1.0;
    std::vector<double> chain_;  // dp/du per free parameter
};

}  // namespace

double filip2024_value_and_gradient(const Filip2024Parameters& p, const Filip2024Geometry& g,
                                    RgbChannel channel,
                                    std::span<double, kFilip2024ParameterCount> gradient) {
    const PairGeometry pair = pair_geometry(g);
    const PairTerms t = pair_terms(p, std::sin(p.phi_a_rad), std::cos(p.phi_a_rad), pair);
    return channel_value<true>(p, t, pair, static_cast<int>(channel), gradient);
}

Filip2024FitResult fit_filip2024(std::span<const BrdfObservation> data,
                                 const Filip2024Parameters& start,
                                 const Filip2024FitOptions& options) {
    validate(start);
    const PreparedData prepared = prepare(data);

    ParameterMap map;
    map.base = to_vector(start);
    for (int i = 0; i < kFilip2024ParameterCount; ++i) {
        if (!options.fixed[i]) map.free.push_back(i);
    }
    const int n_free = static_cast<int>(map.free.size());
    const int n_obs = static_cast<int>(prepared.observations.size());
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

    FilipLeastSquares problem(prepared, map);
    LeastSquaresOptions lm;
    lm.max_function_evaluations = options.max_function_evaluations;
    lm.relative_tolerance = options.relative_tolerance;
    lm.progress = options.progress;
    const LeastSquaresResult minimised = minimise_least_squares(problem, u, lm);

    Filip2024FitResult result;
    auto values = map.parameters(u);
    values[kFilipPhiA] = wrap_half_turn(values[kFilipPhiA]);
    result.values = values;
    result.parameters = from_vector(values);
    result.free_parameters = map.free;
    result.observations = n_obs;
    result.degrees_of_freedom = n_obs - n_free;
    result.function_evaluations = minimised.function_evaluations;
    result.jacobian_evaluations = minimised.jacobian_evaluations;
    result.converged = minimised.converged();
    result.termination = minimised.termination();

    // Residuals and JᵀJ in the parameters' own units at the optimum.
    problem.set_parameters(result.parameters);
    const NormalEquations at_optimum = total_normal_equations(problem);
    const double plain_sum = sum_in_chunk_order(
        problem.chunks(), 0.0,
        [&](std::size_t c, double& slot) { slot = problem.chunk_plain_sum_of_squares(c); });
    result.residual_rms = std::sqrt(plain_sum / n_obs);
    result.reduced_chi_square = at_optimum.sum_of_squares / result.degrees_of_freedom;

    for (int i = 0; i < kFilip2024ParameterCount; ++i) {
        result.standard_errors[i] = std::numeric_limits<double>::quiet_NaN();
        result.at_bound[i] = !periodic(i) && !options.fixed[i] && range(i).near_bound(values[i]);
    }

    // covariance = s² (JᵀJ)⁻¹, inverted after scaling JᵀJ to a unit diagonal so that the
    // singularity test does not depend on the parameters' units.
    const Eigen::MatrixXd& normal = at_optimum.jtj;
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
