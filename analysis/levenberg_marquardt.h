// What Eigen's Levenberg–Marquardt stopping status means, in words a fit report can
// print, and whether it counts as converged: shared by the model fits.
#pragma once

#include <string>

#include <unsupported/Eigen/NonLinearOptimization>

namespace plumage::analysis {

inline std::string describe(Eigen::LevenbergMarquardtSpace::Status status) {
    using namespace Eigen::LevenbergMarquardtSpace;
    switch (status) {
        case ImproperInputParameters: return "improper input parameters";
        case RelativeReductionTooSmall: return "relative reduction of the sum of squares below tolerance";
        case RelativeErrorTooSmall: return "relative change of the parameters below tolerance";
        case RelativeErrorAndReductionTooSmall: return "both sum of squares and parameters converged";
        case CosinusTooSmall: return "residuals orthogonal to the Jacobian (stationary point)";
        case TooManyFunctionEvaluation: return "too many function evaluations";
        case FtolTooSmall: return "no further reduction of the sum of squares possible";
        case XtolTooSmall: return "no further improvement of the parameters possible";
        case GtolTooSmall: return "gradient orthogonal to the Jacobian columns";
        case UserAsked: return "stopped by the residual function";
        default: return "unknown status";
    }
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
        case GtolTooSmall: return true;
        default: return false;
    }
}

}  // namespace plumage::analysis
