// Levenberg–Marquardt for fits with many observations and few parameters, evaluated on every
// OpenMP thread and bit-identical for any thread count.
//
// The problem: minimise S(u) = Σ_k r_k(u)², k over the observations, u ∈ ℝⁿ (n ≲ 30).
// The observations are cut by the problem into a fixed number of chunks (the cut depends on the
// data only, never on the thread count). Each trial point needs, per chunk, the chunk's
// normal equations (JᵀJ, Jᵀr, Σ r²); the chunks run in parallel and their results are added in
// chunk order, so every sum, and so every iterate, has the same bits on 1, 2 or 64 threads.
//
// Why not MINPACK's lmder itself (Eigen's LevenbergMarquardt, which the Filip fit used before):
// it wants the whole m × n Jacobian and factorises it by Householder QR on one thread each
// iteration, which for 25 620 × 18 cost more than the model evaluations; and its functor
// interface leaves no room for a fixed-order parallel reduction. So this is lmder's algorithm
// (Moré 1978) on the normal equations instead of the QR of J: the same scaling, trust-region
// radius updates, acceptance and stopping tests. The normal equations square J's condition
// number; the steps are solved in variables scaled to a unit diagonal, and a fit whose scaled
// JᵀJ is singular is caught by the fits' covariance test. On the Filip fits the two reach the
// same optima (tests/analysis/least_squares_test.cpp; the species BRDFs: within 0.3 σ).
//
// One iteration, in scaled variables ŝ = D δ (D = the largest column norm of J seen so far,
// sqrt(diag JᵀJ), 1 for a zero column), with radius Δ (first 100 ‖D u‖, then at most the first
// step's length):
//   μ = 0 if the Gauss–Newton step has ‖ŝ‖ ≤ 1.1 Δ, else μ > 0 with ‖ŝ‖ within 10 % of Δ, where
//   (Â + μ I) ŝ = −ĝ,  Â = D⁻¹ JᵀJ D⁻¹,  ĝ = D⁻¹ Jᵀr;
//   ρ = actual / predicted reduction of S, predicted = (ŝᵀÂŝ + 2μ‖ŝ‖²) / S;
//   ρ ≤ 1/4: Δ shrinks by 0.1–0.5 (lmder's rule);  ρ ≥ 3/4 or μ = 0: Δ = 2 ‖ŝ‖;
//   ρ ≥ 1e-4: the step is taken, with the normal equations already built at its point.
// Stops (the first that holds):
//   gradient:       max_j |ĝ_j| / sqrt(S) ≤ gradient_tolerance, or S = 0
//   sum of squares: actual and predicted relative reduction ≤ relative_tolerance (ρ ≤ 2)
//   parameters:     Δ ≤ relative_tolerance ‖D u‖
//   evaluations:    function_evaluations ≥ max_function_evaluations (not converged)
//   no progress:    Δ ≤ machine epsilon × ‖D u‖ (not converged)
// Every trial point gets its normal equations, which yield S in the same pass (a step is taken
// far more often than refused, so this is cheaper than S first and JᵀJ after); a function
// evaluation is one trial point, a Jacobian evaluation one taken step (plus the start). Ctrl-C
// (common/interrupt.h) throws Interrupted between evaluations.
#pragma once

#include <cstddef>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace plumage::analysis {

// One chunk's (or a sum of chunks') contribution: JᵀJ (full, symmetric), Jᵀr and Σ r².
struct NormalEquations {
    Eigen::MatrixXd jtj;
    Eigen::VectorXd jtr;
    double sum_of_squares = 0.0;

    explicit NormalEquations(int n = 0)
        : jtj(Eigen::MatrixXd::Zero(n, n)), jtr(Eigen::VectorXd::Zero(n)) {}
    NormalEquations& operator+=(const NormalEquations& other);
};

// What a fit supplies. set_point is called on one thread before each round of chunk calls;
// the chunk calls then run concurrently, so they must only read.
class ChunkedLeastSquares {
public:
    virtual ~ChunkedLeastSquares() = default;
    virtual int variables() const = 0;
    virtual std::size_t chunks() const = 0;
    virtual void set_point(const Eigen::VectorXd& u) = 0;
    // Adds the chunk's JᵀJ (lower triangle is enough: the caller mirrors it), Jᵀr and Σ r² at the
    // current point into `sum`, which has variables() rows.
    virtual void add_chunk_normal_equations(std::size_t chunk, NormalEquations& sum) const = 0;
};

// Evaluates chunk_result(c, slot_c) for every chunk on all OpenMP threads, each into its own
// slot (initialised to `zero`), then adds the slots in chunk order: the sum has the same bits for
// any thread count. chunk_result must not throw.
template <class T, class ChunkResult>
T sum_in_chunk_order(std::size_t chunks, const T& zero, ChunkResult&& chunk_result) {
    std::vector<T> slots(chunks, zero);
#pragma omp parallel for schedule(dynamic, 1)
    for (std::size_t c = 0; c < chunks; ++c) chunk_result(c, slots[c]);
    T total = zero;
    for (const T& slot : slots) total += slot;
    return total;
}

// Σ over chunks, in chunk order, evaluated on all threads, at the problem's current point.
NormalEquations total_normal_equations(const ChunkedLeastSquares& problem);

enum class LeastSquaresStop {
    kGradient,
    kSumOfSquares,
    kParameters,
    kMaxEvaluations,
    kNoProgress,
};

struct LeastSquaresOptions {
    int max_function_evaluations = 4000;
    double relative_tolerance = 1e-10;  // on the sum of squares and on the parameters
    double gradient_tolerance = 0.0;    // 0: the gradient test only stops at an exact zero
    // Called after every evaluation with the evaluations so far, the sum of squares just
    // computed and the seconds since the minimisation started (a caller prints progress from
    // it); empty: silent.
    std::function<void(int evaluations, double sum_of_squares, double elapsed_s)> progress;
};

struct LeastSquaresResult {
    LeastSquaresStop stop = LeastSquaresStop::kMaxEvaluations;
    int function_evaluations = 0;
    int jacobian_evaluations = 0;
    int iterations = 0;           // solves of the damped system
    double sum_of_squares = 0.0;  // at the returned u
    bool converged() const;
    std::string termination() const;  // the stopping reason, in words a report can print
};

// Minimises from u (in place; on return u is the best point found). Throws Interrupted on
// Ctrl-C, InputError for bad options.
LeastSquaresResult minimise_least_squares(ChunkedLeastSquares& problem, Eigen::VectorXd& u,
                                          const LeastSquaresOptions& options);

// The fits' one covariance rule: s² (JᵀJ)⁻¹ at the optimum from the normal matrix JᵀJ (in the
// variables the caller wants the covariance in) and s² = χ²/dof, the usual linearisation.
// Inverted after scaling JᵀJ to a unit diagonal, so that the singularity test does not depend
// on the variables' units: nullopt when a diagonal entry is not > 0, an entry is not finite, or
// the scaled matrix's smallest eigenvalue is at most kSingularRatio × its largest (some
// combination of the parameters is not determined by the data).
inline constexpr double kSingularRatio = 1e-12;
std::optional<Eigen::MatrixXd> least_squares_covariance(const Eigen::MatrixXd& normal,
                                                        double reduced_chi_square);

}  // namespace plumage::analysis
