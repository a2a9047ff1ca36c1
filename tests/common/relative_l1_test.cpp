// common/relative_l1.h: the one relative-L1 rule, its weights and its empty reference.
#include "common/relative_l1.h"

#include <cmath>
#include <limits>

#include <gtest/gtest.h>

namespace plumage {
namespace {

TEST(RelativeL1, WeightedSumsOfDifferenceOverReference) {
    RelativeL1 l1;
    l1.add(1.5, 1.0, 2.0);    // |0.5| · 2
    l1.add(2.0, 3.0, 1.0);    // |−1| · 1
    l1.add(-1.0, -2.0, 0.5);  // |1| · 0.5, reference |−2| · 0.5
    EXPECT_DOUBLE_EQ(l1.difference(), 2.5);
    EXPECT_DOUBLE_EQ(l1.reference(), 6.0);
    EXPECT_DOUBLE_EQ(l1.value(), 2.5 / 6.0);
}

TEST(RelativeL1, AnEmptyReferenceIsZeroOnlyWhenMatched) {
    RelativeL1 matched;
    matched.add(0.0, 0.0);
    EXPECT_EQ(matched.value(), 0.0);
    RelativeL1 missed;
    missed.add(1e-30, 0.0);
    EXPECT_EQ(missed.value(), std::numeric_limits<double>::infinity());
    EXPECT_EQ(RelativeL1::of(0.0, 0.0), 0.0);
    EXPECT_EQ(RelativeL1().value(), 0.0);  // nothing compared
}

}  // namespace
}  // namespace plumage
