#include "analysis/fits/least_squares.h"

#include <chrono>

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include "common/error.h"
#include "common/interrupt.h"

namespace plumage::analysis {
namespace {

// A step is taken when it achieves this fraction of the reduction the linear model predicts.
constexpr double kAcceptRatio = 1e-4;
// The first trust radius, in units of ‖D u‖ (MINPACK's `factor`).
constexpr double kInitialRadiusFactor = 100.0;

void check_interrupt() {
    if (interrupt_requested()) throw Interrupted("interrupted while fitting");
}

}  // namespace

NormalEquations& NormalEquations::operator+=(const NormalEquations& other) {
    jtj += other.jtj;
    jtr += other.jtr;
    sum_of_squares += other.sum_of_squares;
    return *this;
}

NormalEquations total_normal_equations(const ChunkedLeastSquares& problem) {
    const int n = problem.variables();
    NormalEquations total = sum_in_chunk_order(
        problem.chunks(), NormalEquations(n),
        [&](std::size_t c, NormalEquations& slot) { problem.add_chunk_normal_equations(c, slot); });
    for (int i = 0; i < n; ++i) {
        for (int j = i + 1; j < n; ++j) total.jtj(i, j) = total.jtj(j, i);
    }
    return total;
}

bool LeastSquaresResult::converged() const {
    return stop == LeastSquaresStop::kGradient || stop == LeastSquaresStop::kSumOfSquares ||
           stop == LeastSquaresStop::kParameters;
}

std::string LeastSquaresResult::termination() const {
    switch (stop) {
        case LeastSquaresStop::kGradient:
            return "gradient orthogonal to the residuals (stationary point)";
        case LeastSquaresStop::kSumOfSquares:
            return "relative reduction of the sum of squares below tolerance";
        case LeastSquaresStop::kParameters:
            return "relative change of the parameters below tolerance";
        case LeastSquaresStop::kMaxEvaluations:
            return "too many function evaluations";
        case LeastSquaresStop::kNoProgress:
            return "no downhill step at machine precision";
    }
    return "unknown";
}

namespace {

// The damped step of the trust-region subproblem in scaled variables ŝ = D δ:
// (Â + μ I) ŝ = −ĝ with Â = D⁻¹ JᵀJ D⁻¹, ĝ = D⁻¹ Jᵀr, and μ ≥ 0 chosen so that ‖ŝ‖ is within
// 10 % of the radius Δ, or μ = 0 when the Gauss–Newton step is already inside it (Moré 1978,
// Sect. 5: Newton's method on 1/‖ŝ(μ)‖ − 1/Δ, safeguarded by bounds on μ, at most 10 steps).
struct DampedStep {
    Eigen::VectorXd scaled;  // ŝ
    double damping = 0.0;    // μ
};

DampedStep damped_step(const Eigen::MatrixXd& a_hat, const Eigen::VectorXd& g_hat, double radius,
                       double previous_damping) {
    auto solve = [&](double mu, Eigen::VectorXd& step, double& curvature) {
        Eigen::MatrixXd m = a_hat;
        m.diagonal().array() += mu;
        const Eigen::LDLT<Eigen::MatrixXd> ldlt(m);
        step = ldlt.solve(-g_hat);
        if (!step.allFinite() || ldlt.info() != Eigen::Success || !ldlt.isPositive()) return false;
        curvature = step.dot(ldlt.solve(step));  // ŝᵀ (Â + μ I)⁻¹ ŝ
        return std::isfinite(curvature) && curvature > 0.0;
    };
    DampedStep result;
    double curvature = 0.0;
    // Gauss–Newton first, where Â is positive definite.
    if (solve(0.0, result.scaled, curvature) && result.scaled.norm() <= 1.1 * radius) return result;

    const double g_norm = g_hat.norm();
    double upper = g_norm / radius;  // ‖ŝ(μ)‖ ≤ ‖ĝ‖ / μ
    double lower = 0.0;
    double mu = std::clamp(previous_damping, 1e-3 * upper, upper);
    for (int it = 0; it < 10; ++it) {
        if (!solve(mu, result.scaled, curvature)) {
            lower = mu;  // not yet positive definite: more damping
            mu = std::max(0.001 * upper, std::sqrt(lower * upper));
            continue;
        }
        const double norm = result.scaled.norm();
        const double excess = norm - radius;
        if (std::abs(excess) <= 0.1 * radius) break;
        (excess > 0.0 ? lower : upper) = mu;
        // Newton on 1/‖ŝ‖ − 1/Δ: μ += (‖ŝ‖ − Δ)/Δ · ‖ŝ‖² / (ŝᵀ (Â + μI)⁻¹ ŝ).
        const double next = mu + excess / radius * norm * norm / curvature;
        mu = (next > lower && next < upper) ? next
                                            : std::max(0.001 * upper, std::sqrt(lower * upper));
    }
    result.damping = mu;
    return result;
}

// Reductions relative to S, as MINPACK's lmder: actual, predicted by the linear model
// (‖Jδ‖² + 2μ‖Dδ‖²), the directional derivative along δ, and actual/predicted.
struct StepReduction {
    double actual, predicted, directional, ratio;
};

StepReduction step_reduction(const Eigen::VectorXd& scaled_step, const Eigen::MatrixXd& a_hat,
                             double damping, double s, double s_trial) {
    const double step_norm = scaled_step.norm();
    StepReduction r;
    r.actual = std::isfinite(s_trial) && s_trial < 100.0 * s ? 1.0 - s_trial / s : -1.0;
    const double model = scaled_step.dot(a_hat * scaled_step) / s;
    const double damping_term = damping * step_norm * step_norm / s;
    r.predicted = model + 2.0 * damping_term;
    r.directional = -(model + damping_term);
    r.ratio = r.predicted > 0.0 ? r.actual / r.predicted : 0.0;
    return r;
}

// MINPACK's update of the radius Δ and the damping μ from a step's reductions: shrink after a
// poor step (by the quadratic's estimate, at least 10×), double after a good one.
void update_trust_region(const StepReduction& r, double s, double s_trial, double step_norm,
                         double& radius, double& damping) {
    if (r.ratio <= 0.25) {
        double shrink =
            r.actual >= 0.0 ? 0.5 : 0.5 * r.directional / (r.directional + 0.5 * r.actual);
        if (!(s_trial < 100.0 * s) || !std::isfinite(s_trial) || !(shrink >= 0.1)) shrink = 0.1;
        radius = shrink * std::min(radius, 10.0 * step_norm);
        damping /= shrink;
    } else if (damping == 0.0 || r.ratio >= 0.75) {
        radius = 2.0 * step_norm;
        damping *= 0.5;
    }
}

// Whether to stop after a step: MINPACK's tests on S and on the parameters (‖D u‖ =
// scaled_norm after the step), the evaluation budget, or a radius too small to move u.
std::optional<LeastSquaresStop> stop_after_step(const StepReduction& r, double radius,
                                                double scaled_norm, double tol,
                                                bool out_of_evaluations) {
    const bool sum_converged =
        std::abs(r.actual) <= tol && r.predicted <= tol && 0.5 * r.ratio <= 1.0;
    const bool parameters_converged = radius <= tol * scaled_norm;
    if (sum_converged || parameters_converged)
        return sum_converged ? LeastSquaresStop::kSumOfSquares : LeastSquaresStop::kParameters;
    if (out_of_evaluations) return LeastSquaresStop::kMaxEvaluations;
    if (radius <= std::numeric_limits<double>::epsilon() * scaled_norm)
        return LeastSquaresStop::kNoProgress;
    return std::nullopt;
}

// The caller's progress callback (LeastSquaresOptions::progress), with the seconds since the
// minimisation started; nothing without one.
class ProgressReport {
public:
    explicit ProgressReport(const LeastSquaresOptions& options)
        : options_(options), started_(std::chrono::steady_clock::now()) {}
    void operator()(int evaluations, double sum_of_squares) const {
        if (!options_.progress) return;
        options_.progress(
            evaluations, sum_of_squares,
            std::chrono::duration<double>(std::chrono::steady_clock::now() - started_).count());
    }

private:
    const LeastSquaresOptions& options_;
    std::chrono::steady_clock::time_point started_;
};

void validate(const ChunkedLeastSquares& problem, const Eigen::VectorXd& u,
              const LeastSquaresOptions& options) {
    const int n = problem.variables();
    if (u.size() != n || options.max_function_evaluations < 1 ||
        !(options.relative_tolerance > 0.0) || !(options.gradient_tolerance >= 0.0)) {
        throw InputError(fmt::format(
            "least squares: {} variables for a problem of {}, max_function_evaluations = {}, "
            "relative_tolerance = {}, gradient_tolerance = {}: expected matching sizes, >= 1, > 0 "
            "and >= 0",
            u.size(), n, options.max_function_evaluations, options.relative_tolerance,
            options.gradient_tolerance));
    }
}

}  // namespace

LeastSquaresResult minimise_least_squares(ChunkedLeastSquares& problem, Eigen::VectorXd& u,
                                          const LeastSquaresOptions& options) {
    validate(problem, u, options);
    LeastSquaresResult result;
    const ProgressReport report(options);

    check_interrupt();
    problem.set_point(u);
    NormalEquations at_u = total_normal_equations(problem);
    ++result.function_evaluations;
    ++result.jacobian_evaluations;
    result.sum_of_squares = at_u.sum_of_squares;
    report(result.function_evaluations, at_u.sum_of_squares);

    // D: each column's norm, never decreasing (Moré's scaling); 1 for a column that is zero.
    Eigen::VectorXd scale = at_u.jtj.diagonal().cwiseSqrt().unaryExpr(
        [](double column) { return column > 0.0 ? column : 1.0; });
    double radius = kInitialRadiusFactor * scale.cwiseProduct(u).norm();  // Δ
    if (!(radius > 0.0)) radius = kInitialRadiusFactor;
    double damping = 0.0;  // μ of the last step
    for (;;) {
        scale = scale.cwiseMax(at_u.jtj.diagonal().cwiseSqrt());
        const double s = at_u.sum_of_squares;
        const Eigen::VectorXd inverse_scale = scale.cwiseInverse();
        const Eigen::VectorXd g_hat = inverse_scale.cwiseProduct(at_u.jtr);
        // An exact fit leaves nothing to reduce; otherwise the scaled gradient's test.
        if (!(s > 0.0) ||
            (g_hat.array().abs() / std::sqrt(s)).maxCoeff() <= options.gradient_tolerance) {
            result.stop = LeastSquaresStop::kGradient;
            return result;
        }
        const Eigen::MatrixXd a_hat =
            inverse_scale.asDiagonal() * at_u.jtj * inverse_scale.asDiagonal();

        // Steps from this point until one is taken; each costs one evaluation of S.
        for (;;) {
            const DampedStep step = damped_step(a_hat, g_hat, radius, damping);
            damping = step.damping;
            ++result.iterations;
            const double step_norm = step.scaled.norm();  // ‖D δ‖
            if (result.iterations == 1) radius = std::min(radius, step_norm);

            check_interrupt();
            const Eigen::VectorXd trial = u + inverse_scale.cwiseProduct(step.scaled);
            problem.set_point(trial);
            // With S in the same pass: a taken step needs no second pass (header).
            NormalEquations at_trial = total_normal_equations(problem);
            const double s_trial = at_trial.sum_of_squares;
            ++result.function_evaluations;
            report(result.function_evaluations, s_trial);

            const StepReduction reduction = step_reduction(step.scaled, a_hat, damping, s, s_trial);
            update_trust_region(reduction, s, s_trial, step_norm, radius, damping);
            const bool accept = reduction.ratio >= kAcceptRatio;
            if (accept) {
                u = trial;
                result.sum_of_squares = s_trial;
            }
            const std::optional<LeastSquaresStop> stop = stop_after_step(
                reduction, radius, scale.cwiseProduct(u).norm(), options.relative_tolerance,
                result.function_evaluations >= options.max_function_evaluations);
            if (stop) {
                problem.set_point(u);
                result.stop = *stop;
                return result;
            }
            if (accept) {
                at_u = std::move(at_trial);
                ++result.jacobian_evaluations;
                break;
            }
        }
    }
}

std::optional<Eigen::MatrixXd> least_squares_covariance(const Eigen::MatrixXd& normal,
                                                        double reduced_chi_square) {
    const Eigen::VectorXd diagonal = normal.diagonal();
    if (!(diagonal.array() > 0.0).all() || !normal.allFinite()) return std::nullopt;
    const Eigen::VectorXd scale = diagonal.array().rsqrt();
    const Eigen::MatrixXd scaled = scale.asDiagonal() * normal * scale.asDiagonal();
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(scaled);
    const Eigen::VectorXd lambda = eigen.eigenvalues();
    if (eigen.info() != Eigen::Success || !(lambda.minCoeff() > kSingularRatio * lambda.maxCoeff()))
        return std::nullopt;
    const Eigen::MatrixXd inverse = eigen.eigenvectors() * lambda.cwiseInverse().asDiagonal() *
                                    eigen.eigenvectors().transpose();
    return Eigen::MatrixXd(reduced_chi_square * scale.asDiagonal() * inverse * scale.asDiagonal());
}

}  // namespace plumage::analysis
