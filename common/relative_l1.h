// Relative L1, the one rule every comparison in the suite uses (studies' reports, the validity
// map, the full-wave judge, the .bsdf interpolation check, analysis/metrics/compare.h):
//     Σ w |a − b| / Σ w |b|      (b the reference, w >= 0 a weight: solid angle, cos θ, or 1)
// accumulated term by term in the caller's order (so a sum is the same for any thread count when
// the caller's order is). When the reference sums to zero: 0 if a equals it everywhere, else +∞
// (a miss of an empty reference is not small).
#pragma once

#include <cmath>
#include <limits>

namespace plumage {

class RelativeL1 final {
public:
    void add(double value, double reference, double weight = 1.0) {
        difference_ += std::abs(value - reference) * weight;
        reference_ += std::abs(reference) * weight;
    }
    double difference() const { return difference_; }  // Σ w |a − b|
    double reference() const { return reference_; }    // Σ w |b|
    double value() const { return of(difference_, reference_); }

    // The rule on sums accumulated elsewhere.
    static double of(double difference, double reference) {
        if (reference > 0.0) return difference / reference;
        return difference > 0.0 ? std::numeric_limits<double>::infinity() : 0.0;
    }

private:
    double difference_ = 0.0, reference_ = 0.0;
};

}  // namespace plumage
