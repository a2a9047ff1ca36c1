#include "analysis/fits/filip2024_fit.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <Eigen/Eigenvalues>

#include "analysis/fits/bounded_parameters.h"
#include "analysis/fits/least_squares.h"
#include "common/constants.h"
#include "common/error.h"
#include "common/interrupt.h"

namespace plumage::analysis {
namespace {

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

namespace {

using Values = std::array<double, kFilip2024ParameterCount>;
using Mask = std::array<bool, kFilip2024ParameterCount>;

// covariance = s² (JᵀJ)⁻¹ over the free parameters (least_squares_covariance).
void set_covariance(Filip2024FitResult& result, const Eigen::MatrixXd& normal) {
    const int n_free = static_cast<int>(result.free_parameters.size());
    const std::optional<Eigen::MatrixXd> covariance =
        least_squares_covariance(normal, result.reduced_chi_square);
    result.covariance_available = covariance.has_value();
    result.covariance = covariance.value_or(
        Eigen::MatrixXd::Constant(n_free, n_free, std::numeric_limits<double>::quiet_NaN()));
    if (!covariance) return;
    for (int j = 0; j < n_free; ++j)
        result.standard_errors[result.free_parameters[j]] = std::sqrt(result.covariance(j, j));
}

// One Levenberg–Marquardt run from `start`, the parameters of `fixed` held at their start.
Filip2024FitResult local_fit(const PreparedData& prepared, const Values& start, const Mask& fixed,
                             const Filip2024FitOptions& options) {
    ParameterMap map;
    map.base = start;
    for (int i = 0; i < kFilip2024ParameterCount; ++i) {
        if (!fixed[i]) map.free.push_back(i);
    }
    const int n_free = static_cast<int>(map.free.size());
    const int n_obs = static_cast<int>(prepared.observations.size());
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
    result.chi_square = at_optimum.sum_of_squares;
    result.reduced_chi_square = at_optimum.sum_of_squares / result.degrees_of_freedom;
    result.standard_errors.fill(std::numeric_limits<double>::quiet_NaN());
    set_covariance(result, at_optimum.jtj);
    result.local_fits = 1;
    return result;
}

// The parameters f is linear in: the four colours and α.
bool linear(int index) {
    return (index >= kFilipCbR && index <= kFilipCrB) || index == kFilipAlpha;
}

// The free linear parameters that minimise χ² with the others at `v`, clamped to their ranges:
// f is linear in them, so one Gauss–Newton step from any point is their least-squares solution.
// A column the data never see (e.g. C_a where M = 0 everywhere) keeps its value (ridge 1e-12).
// Returns χ² at the result.
double solve_linear_parameters(const PreparedData& prepared, Values& v, const Mask& fixed) {
    ParameterMap map;
    map.base = v;
    for (int i = 0; i < kFilip2024ParameterCount; ++i) {
        if (linear(i) && !fixed[i]) map.free.push_back(i);
    }
    FilipLeastSquares problem(prepared, map);
    problem.set_parameters(from_vector(v));
    if (!map.free.empty()) {
        const NormalEquations at_v = total_normal_equations(problem);
        Eigen::MatrixXd a = at_v.jtj;
        const double ridge = 1e-12 * std::max(a.diagonal().maxCoeff(), 1e-300);
        a.diagonal().array() += ridge;
        const Eigen::VectorXd step = a.ldlt().solve(-at_v.jtr);
        for (std::size_t j = 0; j < map.free.size(); ++j) {
            const int i = map.free[j];
            const auto& info = kFilip2024ParameterTable[i];
            v[i] = std::clamp(v[i] + step[static_cast<Eigen::Index>(j)], info.min, info.max);
        }
        problem.set_parameters(from_vector(v));
    }
    return total_normal_equations(problem).sum_of_squares;
}

// The global stage's grid of the nonlinear shape parameters (header): each free one takes its
// grid values, a fixed one its starting value.
std::vector<Values> shape_grid(const Values& start, const Mask& fixed) {
    struct Mask2 {
        double w, d_w;
    };
    constexpr std::array<double, 6> kPhiDeg = {-75.0, -45.0, -15.0, 15.0, 45.0, 75.0};
    constexpr std::array<Mask2, 4> kMasks = {
        {{0.95, 0.40}, {0.85, 0.20}, {0.80, 0.40}, {0.80, 0.60}}};
    constexpr std::array<double, 2> kBeta = {5.0, 12.0};
    constexpr std::array<double, 4> kGamma = {0.25, 0.75, 1.5, 4.0};
    std::vector<Values> grid;
    for (double phi : kPhiDeg) {
        for (const Mask2& m : kMasks) {
            for (double beta : kBeta) {
                for (double gamma : kGamma) {
                    Values v = start;
                    if (!fixed[kFilipPhiA]) v[kFilipPhiA] = phi * kDeg;
                    if (!fixed[kFilipW]) v[kFilipW] = m.w;
                    if (!fixed[kFilipDw]) v[kFilipDw] = m.d_w;
                    if (!fixed[kFilipBeta]) v[kFilipBeta] = beta;
                    if (!fixed[kFilipGamma]) v[kFilipGamma] = gamma;
                    if (std::find(grid.begin(), grid.end(), v) == grid.end()) grid.push_back(v);
                }
            }
        }
    }
    return grid;
}

// The starts of the local stage: the user's start, then the grid points with the lowest χ²
// after their linear parameters are solved (ties: grid order).
std::vector<Values> global_starts(const PreparedData& prepared, const Values& start,
                                  const Mask& fixed, int count) {
    std::vector<std::pair<double, Values>> ranked;
    for (Values v : shape_grid(start, fixed)) {
        throw_if_interrupted("the Filip 2024 fit's global stage");
        const double chi_square = solve_linear_parameters(prepared, v, fixed);
        ranked.emplace_back(chi_square, v);
    }
    std::stable_sort(ranked.begin(), ranked.end(),
                     [](const auto& a, const auto& b) { return a.first < b.first; });
    std::vector<Values> starts = {start};
    for (std::size_t k = 0; k < ranked.size() && static_cast<int>(starts.size()) <= count; ++k)
        starts.push_back(ranked[k].second);
    return starts;
}

// Active set: a parameter the logistic map has driven close to a bound (it reaches the bound
// only at infinity) is held exactly on it and the rest refitted; kept when χ² does not rise,
// i.e. when the optimum lies on the bound. Repeated while it helps.
Filip2024FitResult pin_to_bounds(const PreparedData& prepared, Filip2024FitResult best, Mask& fixed,
                                 const Filip2024FitOptions& options) {
    constexpr double kNearBound = 1e-2;  // fraction of the range
    for (int i = 0; i < kFilip2024ParameterCount; ++i) {
        if (fixed[i] || periodic(i)) continue;
        const auto& info = kFilip2024ParameterTable[i];
        const double margin = kNearBound * (info.max - info.min);
        const double value = best.values[i];
        if (value - info.min >= margin && info.max - value >= margin) continue;
        Values start = best.values;
        start[i] = value - info.min < margin ? info.min : info.max;
        Mask pinned = fixed;
        pinned[i] = true;
        Filip2024FitResult trial = local_fit(prepared, start, pinned, options);
        const int runs = best.local_fits + 1;
        if (trial.chi_square <= best.chi_square * (1.0 + 1e-12)) {
            best = std::move(trial);
            fixed = pinned;
        }
        best.local_fits = runs;
    }
    return best;
}

// The parameters that another run's optimum, as good within Δχ² ≤ 1 (statistically the same
// fit), puts more than 3σ (the best run's σ) from the best: the data do not decide them.
std::vector<int> undetermined_parameters(const std::vector<Filip2024FitResult>& runs,
                                         std::size_t best) {
    const Filip2024FitResult& b = runs[best];
    std::vector<int> undetermined;
    for (const Filip2024FitResult& other : runs) {
        if (!(other.chi_square <= b.chi_square + 1.0)) continue;
        for (int i = 0; i < kFilip2024ParameterCount; ++i) {
            double difference = other.values[i] - b.values[i];
            if (periodic(i)) difference = std::remainder(difference, kPi);
            const double sigma = b.standard_errors[i];
            const bool apart = std::isnan(sigma)
                                   ? std::abs(difference) > 1e-6 * (1.0 + std::abs(b.values[i]))
                                   : std::abs(difference) > 3.0 * sigma;
            if (apart &&
                std::find(undetermined.begin(), undetermined.end(), i) == undetermined.end())
                undetermined.push_back(i);
        }
    }
    std::sort(undetermined.begin(), undetermined.end());
    return undetermined;
}

}  // namespace

Filip2024FitResult fit_filip2024(std::span<const BrdfObservation> data,
                                 const Filip2024Parameters& start,
                                 const Filip2024FitOptions& options) {
    validate(start);
    const PreparedData prepared = prepare(data);
    const int n_free =
        static_cast<int>(std::count(options.fixed.begin(), options.fixed.end(), false));
    const int n_obs = static_cast<int>(prepared.observations.size());
    if (n_free == 0) throw InputError("Filip 2024 fit: every parameter is fixed: nothing to fit");
    if (n_obs <= n_free) {
        throw InputError(fmt::format(
            "Filip 2024 fit: {} observations for {} free parameters: expected more observations "
            "than free parameters",
            n_obs, n_free));
    }
    if (options.max_function_evaluations < 1 || !(options.relative_tolerance > 0.0) ||
        options.global_starts < 0 || options.global_starts > 192) {
        throw InputError(fmt::format(
            "Filip 2024 fit: max_function_evaluations = {}, relative_tolerance = {}, "
            "global_starts = {}: expected >= 1, > 0 and 0..192",
            options.max_function_evaluations, options.relative_tolerance, options.global_starts));
    }

    const Values start_values = to_vector(start);
    const std::vector<Values> starts =
        options.global_starts > 0
            ? global_starts(prepared, start_values, options.fixed, options.global_starts)
            : std::vector<Values>{start_values};
    // Each run's optimum, with parameters on bounds held there (active set), then the best.
    std::vector<Filip2024FitResult> runs;
    std::vector<Mask> run_fixed;
    for (const Values& s : starts) {
        Mask fixed = options.fixed;
        runs.push_back(
            pin_to_bounds(prepared, local_fit(prepared, s, fixed, options), fixed, options));
        run_fixed.push_back(fixed);
    }
    std::size_t best = 0;
    for (std::size_t k = 1; k < runs.size(); ++k) {
        if (runs[k].chi_square < runs[best].chi_square) best = k;
    }
    Filip2024FitResult result = runs[best];
    result.local_fits = 0;
    for (std::size_t k = 0; k < runs.size(); ++k) {
        result.local_fits += runs[k].local_fits;
        result.start_chi_squares.push_back(runs[k].chi_square);
    }
    for (int i = 0; i < kFilip2024ParameterCount; ++i) {
        const bool pinned = run_fixed[best][i] && !options.fixed[i];
        result.at_bound[i] =
            pinned || (!periodic(i) && !options.fixed[i] && range(i).near_bound(result.values[i]));
    }
    result.undetermined = undetermined_parameters(runs, best);
    return result;
}

}  // namespace plumage::analysis
