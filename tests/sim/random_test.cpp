// Random streams (sim/scatterer/random.h): a study's seeds derive from (seed, purpose, index) by
// hashing, so nearby seeds, purposes and indices never share a stream. Before derive_seed the
// species study offset the seed (seed + si, seed + 100 + si, ...): seed S's in-plane sweep of
// species 0 reused seed S + 100's BRDF stream of species 0.
#include "sim/scatterer/random.h"

#include <cmath>
#include <cstdint>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace plumage {
namespace {

TEST(RandomStreams, DerivedSeedsNeverCollideAcrossSeedsPurposesAndIndices) {
    std::set<std::uint64_t> seen;
    std::size_t derived = 0;
    for (std::uint64_t seed = kDefaultSeed; seed < kDefaultSeed + 300; ++seed) {
        for (const char* purpose :
             {"species/brdf", "species/in_plane", "species/btf", "species/albedo"}) {
            for (std::uint64_t index = 0; index < 16; ++index) {
                seen.insert(derive_seed(seed, purpose, index));
                ++derived;
            }
        }
    }
    // 19 200 64-bit values: a collision by chance has probability ~1e-11.
    EXPECT_EQ(seen.size(), derived);
    EXPECT_NE(derive_seed(1, "a", 0), derive_seed(1, "b", 0));
    EXPECT_EQ(derive_seed(7, "species/brdf", 3), derive_seed(7, "species/brdf", 3));
}

// Streams from adjacent derived seeds are uncorrelated: the sample correlation of 10^5 pairs
// of uniforms stays within 5 standard errors (1/sqrt(n)) of 0.
TEST(RandomStreams, AdjacentPurposesGiveUncorrelatedStreams) {
    const int n = 100000;
    Rng a(derive_seed(kDefaultSeed, "species/brdf", 0), 0);
    Rng b(derive_seed(kDefaultSeed + 100, "species/brdf", 0), 0);
    Rng c(derive_seed(kDefaultSeed, "species/in_plane", 0), 0);
    double sab = 0.0, sac = 0.0;
    for (int i = 0; i < n; ++i) {
        const double x = a.uniform() - 0.5, y = b.uniform() - 0.5, z = c.uniform() - 0.5;
        sab += x * y;
        sac += x * z;
    }
    const double variance = 1.0 / 12.0;
    const double bound = 5.0 / std::sqrt(static_cast<double>(n));
    EXPECT_LT(std::abs(sab / n / variance), bound);
    EXPECT_LT(std::abs(sac / n / variance), bound);
}

}  // namespace
}  // namespace plumage
