// Seeds from seeds: DESIGN.md's (seed, purpose, index) rule, shared by every floor (the
// geometry's jitter, the tracer's streams, the studies' instruments).
#pragma once

#include <cstdint>
#include <string_view>

namespace plumage {

// SplitMix64 (Steele, Lea and Flood 2014): a bijective 64-bit mixer.
std::uint64_t splitmix64(std::uint64_t x);

// The seed of one purpose (an instrument, a Monte Carlo loop, a geometry's jitter), e.g.
// derive_seed(seed, "species/brdf", species_index): the only way seeds are derived from a
// user's `seed`. Purpose and index are hashed, never added to the seed, so that seed S and
// S + 1 (or S + 100) share no stream, and neither do two purposes of one seed.
std::uint64_t derive_seed(std::uint64_t seed, std::string_view purpose, std::uint64_t index = 0);

}  // namespace plumage
