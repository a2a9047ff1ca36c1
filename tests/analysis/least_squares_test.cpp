// The chunked Levenberg–Marquardt (analysis/fits/least_squares.h) against closed forms, against
// MINPACK's lmder (Eigen's LevenbergMarquardt, which the Filip fit used before) on the same
// Filip 2024 problem, and for the same bits on 1, 2 and 3 threads.
#include "analysis/fits/least_squares.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <optional>
#include <vector>

#include <gtest/gtest.h>
#include <omp.h>
#include <unsupported/Eigen/NonLinearOptimization>

#include "analysis/fits/bounded_parameters.h"
#include "analysis/fits/filip2024_fit.h"
#include "analysis/models/filip2024.h"
#include "common/constants.h"
#include "sim/scatterer/random.h"
#include "virtual_gonio/direction_sets.h"

namespace plumage::analysis {
namespace {

// r_k = a e^{−b x_k} + c − y_k on noiseless data: the minimum is the generating (a, b, c), S = 0.
class ExponentialDecay final : public ChunkedLeastSquares {
public:
    ExponentialDecay() {
        for (int k = 0; k < 500; ++k) {
            const double x = 0.01 * k;
            x_.push_back(x);
            y_.push_back(2.5 * std::exp(-1.3 * x) + 0.4);
        }
    }
    int variables() const override { return 3; }
    std::size_t chunks() const override { return x_.size() / 50; }
    void set_point(const Eigen::VectorXd& u) override { u_ = u; }
    void add_chunk_normal_equations(std::size_t chunk, NormalEquations& sum) const override {
        for (std::size_t k = chunk * 50; k < (chunk + 1) * 50; ++k) {
            const double e = std::exp(-u_[1] * x_[k]);
            const double r = u_[0] * e + u_[2] - y_[k];
            const Eigen::Vector3d j(e, -u_[0] * x_[k] * e, 1.0);
            sum.jtj += j * j.transpose();
            sum.jtr += j * r;
            sum.sum_of_squares += r * r;
        }
    }

private:
    std::vector<double> x_, y_;
    Eigen::VectorXd u_;
};

TEST(LeastSquares, RecoversAnExponentialDecayFromAFarStart) {
    ExponentialDecay problem;
    Eigen::VectorXd u(3);
    u << 0.5, 5.0, -1.0;
    const LeastSquaresResult r = minimise_least_squares(problem, u, {});
    ASSERT_TRUE(r.converged()) << r.termination();
    EXPECT_NEAR(u[0], 2.5, 1e-8);
    EXPECT_NEAR(u[1], 1.3, 1e-8);
    EXPECT_NEAR(u[2], 0.4, 1e-8);
    EXPECT_LT(r.sum_of_squares, 1e-20);
}

TEST(LeastSquares, StopsAtTheEvaluationLimitAndSaysSo) {
    ExponentialDecay problem;
    Eigen::VectorXd u(3);
    u << 0.5, 5.0, -1.0;
    LeastSquaresOptions options;
    options.max_function_evaluations = 3;
    const LeastSquaresResult r = minimise_least_squares(problem, u, options);
    EXPECT_FALSE(r.converged());
    EXPECT_EQ(r.stop, LeastSquaresStop::kMaxEvaluations);
    EXPECT_EQ(r.function_evaluations, 3);
    EXPECT_EQ(r.termination(), "too many function evaluations");
}

// The covariance rule against the closed form of a straight-line fit y = a + b x with known
// scatter: Var b = s² / Σ(x − x̄)², Var a = s² Σx² / (n Σ(x − x̄)²), Cov = −s² x̄ / Σ(x − x̄)²;
// units of a column do not change the answer (the unit-diagonal scaling); a rank-deficient
// normal matrix has none.
TEST(LeastSquares, CovarianceIsTheLinearisedOneAndRefusesASingularFit) {
    const int n = 40;
    Eigen::MatrixXd jacobian(n, 2);
    double mean = 0.0;
    for (int k = 0; k < n; ++k) {
        jacobian(k, 0) = 1.0;
        jacobian(k, 1) = 1e4 * (0.1 * k);  // x in a unit 10⁴ times too small
        mean += jacobian(k, 1) / n;
    }
    double sxx = 0.0, sum_sq = 0.0;
    for (int k = 0; k < n; ++k) {
        sxx += (jacobian(k, 1) - mean) * (jacobian(k, 1) - mean);
        sum_sq += jacobian(k, 1) * jacobian(k, 1);
    }
    const double s2 = 0.37;
    const std::optional<Eigen::MatrixXd> c =
        least_squares_covariance(jacobian.transpose() * jacobian, s2);
    ASSERT_TRUE(c.has_value());
    EXPECT_NEAR((*c)(1, 1), s2 / sxx, 1e-12 * s2 / sxx);
    EXPECT_NEAR((*c)(0, 0), s2 * sum_sq / (n * sxx), 1e-10 * s2 * sum_sq / (n * sxx));
    EXPECT_NEAR((*c)(0, 1), -s2 * mean / sxx, 1e-10 * s2 * mean / sxx);
    EXPECT_DOUBLE_EQ((*c)(0, 1), (*c)(1, 0));

    Eigen::MatrixXd twice(n, 2);
    twice << jacobian.col(1), 2.0 * jacobian.col(1);  // one parameter in two columns
    EXPECT_FALSE(least_squares_covariance(twice.transpose() * twice, s2).has_value());
    Eigen::MatrixXd unseen = jacobian;
    unseen.col(1).setZero();  // a parameter the data never see
    EXPECT_FALSE(least_squares_covariance(unseen.transpose() * unseen, s2).has_value());
}

// ---- The Filip 2024 fit against MINPACK on the same problem. --------------------------------

// Parrot data on the 3660 pairs at 7 wavelengths (the default study's), 2 % noise, σ given.
std::vector<BrdfObservation> noisy_parrot() {
    const Filip2024Brdf brdf(filip2024_preset("parrot"));
    std::vector<BrdfObservation> data;
    Rng rng(kDefaultSeed, 401);
    for (const auto& pair : gonio::filip2024_btf_pairs()) {
        for (double lambda : {400.0, 450.0, 500.0, 550.0, 600.0, 650.0, 700.0}) {
            const double f = brdf.eval(pair.wi, pair.wo, lambda);
            const double u1 = 1.0 - rng.uniform(), u2 = rng.uniform();
            const double z = std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * kPi * u2);
            data.push_back(
                {pair.wi, pair.wo, std::nullopt, lambda, f * (1.0 + 0.02 * z), 0.02 * f + 1e-6});
        }
    }
    return data;
}

Filip2024Parameters moved_start() {
    auto v = to_vector(filip2024_preset("parrot"));
    for (int i = 0; i < kFilipThetaMax; ++i) v[i] *= (i % 2 == 0) ? 1.15 : 0.85;
    v[kFilipPhiA] -= 8.0 * kDeg;
    return from_vector(v);
}

// The previous implementation of fit_filip2024's optimisation, kept here as the reference: the
// same residuals, the same logistic maps, MINPACK's lmder (QR of the whole Jacobian).
struct MinpackFilip {
    const std::vector<BrdfObservation>& data;
    std::vector<int> free;
    std::array<double, kFilip2024ParameterCount> base;

    static bool periodic(int i) { return i == kFilipPhiA; }
    static BoundedRange range(int i) {
        return {kFilip2024ParameterTable[i].min, kFilip2024ParameterTable[i].max};
    }
    Filip2024Parameters parameters(const Eigen::VectorXd& u) const {
        auto v = base;
        for (std::size_t j = 0; j < free.size(); ++j) {
            const int i = free[j];
            v[i] = periodic(i) ? u[j] : range(i).parameter(u[j]);
        }
        return from_vector(v);
    }
    int values() const { return static_cast<int>(data.size()); }
    int operator()(const Eigen::VectorXd& u, Eigen::VectorXd& r) const {
        const Filip2024Parameters p = parameters(u);
        std::array<double, kFilip2024ParameterCount> g{};
        for (std::size_t k = 0; k < data.size(); ++k) {
            const auto geometry = filip2024_geometry(data[k].wi, data[k].wo);
            const double f =
                filip2024_value_and_gradient(p, geometry, filip2024_channel(*data[k].lambda_nm), g);
            r[static_cast<Eigen::Index>(k)] = (f - data[k].value) / *data[k].standard_error;
        }
        return 0;
    }
    int df(const Eigen::VectorXd& u, Eigen::MatrixXd& jacobian) const {
        const Filip2024Parameters p = parameters(u);
        std::array<double, kFilip2024ParameterCount> g{};
        for (std::size_t k = 0; k < data.size(); ++k) {
            const auto geometry = filip2024_geometry(data[k].wi, data[k].wo);
            filip2024_value_and_gradient(p, geometry, filip2024_channel(*data[k].lambda_nm), g);
            for (std::size_t j = 0; j < free.size(); ++j) {
                const int i = free[j];
                const double chain = periodic(i) ? 1.0 : range(i).slope(u[j]);
                jacobian(static_cast<Eigen::Index>(k), static_cast<Eigen::Index>(j)) =
                    g[i] * chain / *data[k].standard_error;
            }
        }
        return 0;
    }
};

double seconds_since(std::chrono::steady_clock::time_point start) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

TEST(Filip2024Fit, FindsTheSameOptimumAsMinpack) {
    const std::vector<BrdfObservation> data = noisy_parrot();
    ASSERT_EQ(data.size(), 25620u);
    const Filip2024Parameters start = moved_start();

    auto t0 = std::chrono::steady_clock::now();
    const Filip2024FitResult fit = fit_filip2024(data, start);
    const double ours_s = seconds_since(t0);
    ASSERT_TRUE(fit.converged) << fit.termination;
    ASSERT_TRUE(fit.covariance_available);

    MinpackFilip reference{data, fit.free_parameters, to_vector(start)};
    Eigen::VectorXd u(static_cast<Eigen::Index>(reference.free.size()));
    for (std::size_t j = 0; j < reference.free.size(); ++j) {
        const int i = reference.free[j];
        u[j] = MinpackFilip::periodic(i) ? reference.base[i]
                                         : MinpackFilip::range(i).variable(reference.base[i]);
    }
    t0 = std::chrono::steady_clock::now();
    Eigen::LevenbergMarquardt<MinpackFilip> lm(reference);
    lm.parameters.maxfev = 4000;
    lm.parameters.ftol = 1e-10;
    lm.parameters.xtol = 1e-10;
    lm.minimize(u);
    const double minpack_s = seconds_since(t0);
    const auto minpack = to_vector(reference.parameters(u));

    std::printf(
        "[ info ] %zu observations: ours %.2f s (%d evaluations, %d Jacobians, %d "
        "threads), MINPACK %.2f s (%ld evaluations, %ld Jacobians, serial reference)\n",
        data.size(), ours_s, fit.function_evaluations, fit.jacobian_evaluations,
        omp_get_max_threads(), minpack_s, static_cast<long>(lm.nfev), static_cast<long>(lm.njev));
    // The same minimum: every parameter within 1 % of its standard error (both optimisers stop
    // at a relative change of 1e-10; the rest is where the flat valleys end).
    for (int i : fit.free_parameters) {
        double difference = fit.values[i] - minpack[i];
        if (i == kFilipPhiA) difference = std::remainder(difference, kPi);
        EXPECT_LE(std::abs(difference), 0.01 * fit.standard_errors[i])
            << kFilip2024ParameterTable[i].name << ": ours " << fit.values[i] << ", MINPACK "
            << minpack[i] << ", sigma " << fit.standard_errors[i];
    }
}

TEST(Filip2024Fit, SameBitsOnOneTwoAndThreeThreads) {
    const std::vector<BrdfObservation> data = noisy_parrot();
    const int threads_before = omp_get_max_threads();
    std::vector<Filip2024FitResult> fits;
    for (int threads : {1, 2, 3}) {
        omp_set_num_threads(threads);
        fits.push_back(fit_filip2024(data, moved_start()));
    }
    omp_set_num_threads(threads_before);
    for (std::size_t t = 1; t < fits.size(); ++t) {
        EXPECT_EQ(std::memcmp(fits[t].values.data(), fits[0].values.data(), sizeof(fits[0].values)),
                  0)
            << t + 1 << " threads";
        EXPECT_EQ(std::memcmp(fits[t].standard_errors.data(), fits[0].standard_errors.data(),
                              sizeof(fits[0].standard_errors)),
                  0)
            << t + 1 << " threads";
        ASSERT_EQ(fits[t].covariance.size(), fits[0].covariance.size());
        EXPECT_EQ(std::memcmp(fits[t].covariance.data(), fits[0].covariance.data(),
                              sizeof(double) * fits[0].covariance.size()),
                  0);
        EXPECT_EQ(fits[t].function_evaluations, fits[0].function_evaluations);
        EXPECT_EQ(
            std::memcmp(&fits[t].reduced_chi_square, &fits[0].reduced_chi_square, sizeof(double)),
            0);
    }
}

}  // namespace
}  // namespace plumage::analysis
