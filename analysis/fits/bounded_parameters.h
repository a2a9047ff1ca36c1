// Bounded fit parameters carried by unbounded optimiser variables: the scaffolding that the
// Filip 2024 and Huang 2022 fits share (analysis/fits/filip2024_fit.cpp, huang2022_fit.cpp).
//
// A parameter p in [min, max] is the logistic image of a variable u ∈ ℝ,
//     p = min + (max − min) / (1 + e^−u),        dp/du = (max − min) s (1 − s),  s = 1 / (1 +
//     e^−u),
// which reaches a bound only at u = ±∞; so a starting value on a bound is first moved
// kStartInset of the range inside it,
//     u = log(t / (1 − t)),  t = clamp((p − min) / (max − min), kStartInset, 1 − kStartInset),
// and a fitted value within kAtBoundFraction of the range from a bound is reported as at the
// bound (its standard error then means little).
#pragma once

#include <algorithm>
#include <cmath>

namespace plumage::analysis {

// How far inside its range a starting value on a bound is moved (fraction of the range).
inline constexpr double kStartInset = 1e-9;
// A fitted value this close to a bound (fraction of the range) is reported at_bound.
inline constexpr double kAtBoundFraction = 1e-6;

struct BoundedRange {
    double min, max;  // in the parameter's units, min < max

    // p(u), the logistic onto [min, max].
    double parameter(double u) const { return min + (max - min) / (1.0 + std::exp(-u)); }
    // dp/du at u.
    double slope(double u) const {
        const double s = 1.0 / (1.0 + std::exp(-u));
        return (max - min) * s * (1.0 - s);
    }
    // u(p), the logit, with p first moved at least kStartInset of the range inside it.
    double variable(double p) const {
        const double t = std::clamp((p - min) / (max - min), kStartInset, 1.0 - kStartInset);
        return std::log(t / (1.0 - t));
    }
    // p lies within kAtBoundFraction of the range from min or max.
    bool near_bound(double p) const {
        const double margin = kAtBoundFraction * (max - min);
        return p - min < margin || max - p < margin;
    }
};

}  // namespace plumage::analysis
