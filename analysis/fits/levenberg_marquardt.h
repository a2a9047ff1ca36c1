// What Eigen's Levenberg–Marquardt stopping status means, in words a fit report can
// print, and whether it counts as converged; the normal matrix of a fit's covariance. Shared
// by the model fits.
#pragma once

#include <string>

#include <unsupported/Eigen/NonLinearOptimization>

namespace plumage::analysis {

inline std::string describe(Eigen::LevenbergMarquardtSpace::Status status) {
    using namespace Eigen::LevenbergMarquardtSpace;
    switch (status) {
        case ImproperInputParameters:
            return "improper input parameters";
        case RelativeReductionTooSmall:
            return "relative reduction of the sum of squares below tolerance";
        case RelativeErrorTooSmall:
            return "relative change of the parameters below tolerance";
        case RelativeErrorAndReductionTooSmall:
            return "both sum of squares and parameters converged";
        case CosinusTooSmall:
            return "residuals orthogonal to the Jacobian (stationary point)";
        case TooManyFunctionEvaluation:
            return "too many function evaluations";
        case FtolTooSmall:
            return "no further reduction of the sum of squares possible";
        case XtolTooSmall:
            return "no further improvement of the parameters possible";
        case GtolTooSmall:
            return "gradient orthogonal to the Jacobian columns";
        case UserAsked:
            return "stopped by the residual function";
        default:
            return "unknown status";
    }
}

// JᵀJ summed row by row in a fixed order. Eigen's product would be parallelised by OpenMP for a
// Jacobian of 10^4 rows, and its sum order (so its last bits, and a near-singular covariance's
// leading ones) would follow the thread count; fits must give the same bits on any machine.
inline Eigen::MatrixXd normal_matrix(const Eigen::MatrixXd& jacobian) {
    const Eigen::Index n = jacobian.cols();
    Eigen::MatrixXd normal = Eigen::MatrixXd::Zero(n, n);
    for (Eigen::Index k = 0; k < jacobian.rows(); ++k) {
        for (Eigen::Index i = 0; i < n; ++i) {
            for (Eigen::Index j = 0; j <= i; ++j) normal(i, j) += jacobian(k, i) * jacobian(k, j);
        }
    }
    for (Eigen::Index i = 0; i < n; ++i) {
        for (Eigen::Index j = i + 1; j < n; ++j) normal(i, j) = normal(j, i);
    }
    return normal;
}

inline bool converged(Eigen::LevenbergMarquardtSpace::Status status) {
    using namespace Eigen::LevenbergMarquardtSpace;
    switch (status) {
        case RelativeReductionTooSmall:
        case RelativeErrorTooSmall:
        case RelativeErrorAndReductionTooSmall:
        case CosinusTooSmall:
        case FtolTooSmall:
        case XtolTooSmall:
        case GtolTooSmall:
            return true;
        default:
            return false;
    }
}

}  // namespace plumage::analysis
