// common/fast_trig.h against libm: random arguments over the documented range and every quadrant
// boundary (where the reduction's n changes and the selects switch).
#include "common/fast_trig.h"

#include <algorithm>
#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "common/constants.h"

namespace plumage {
namespace {

double worst_error(double x) {
    double s = 0.0, c = 0.0;
    sin_cos(x, s, c);
    return std::max(std::abs(s - std::sin(x)), std::abs(c - std::cos(x)));
}

TEST(FastTrig, MatchesLibmOverTheDocumentedRange) {
    std::mt19937_64 rng(7);
    for (const double range : {1.0, 100.0, 1e4, kSinCosLimit}) {
        std::uniform_real_distribution<double> x(-range, range);
        double worst = 0.0;
        for (int m = 0; m < 200000; ++m) worst = std::max(worst, worst_error(x(rng)));
        // Both are within an ulp or so of the truth; |sin|, |cos| <= 1, so 2.3e-16 absolute.
        EXPECT_LE(worst, 2.3e-16) << "range " << range;
    }
}

TEST(FastTrig, HoldsAtEveryQuadrantBoundary) {
    double worst = 0.0;
    for (int n = -20000; n <= 20000; ++n)
        for (const double offset : {-1e-13, 0.0, 1e-13})
            worst = std::max(worst, worst_error(n * kPi / 4.0 + offset));
    EXPECT_LE(worst, 2.3e-16);
    double s = 1.0, c = 0.0;
    sin_cos(0.0, s, c);
    EXPECT_EQ(s, 0.0);
    EXPECT_EQ(c, 1.0);
}

}  // namespace
}  // namespace plumage
