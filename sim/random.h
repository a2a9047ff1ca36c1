// Deterministic random streams. Every stream is derived from (seed, item index) so that
// results do not depend on thread count, scheduling or process count (DESIGN.md).
// Generator: PCG32 (O'Neill 2014, XSH-RR output), 2^64 period per stream, 2^63 streams;
// the stream's increment and initial state are hashed from (seed, item) with SplitMix64.
#pragma once

#include <cstdint>
#include <string_view>

namespace plumage {

inline constexpr std::uint64_t kDefaultSeed = 20221122;

class Rng {
public:
    Rng(std::uint64_t seed, std::uint64_t item);
    std::uint32_t next_u32();
    // Uniform in [0, 1), 32 bits of randomness for speed (doubles of 2^-32 resolution).
    double uniform();

private:
    std::uint64_t state_;
    std::uint64_t increment_;
};

std::uint64_t splitmix64(std::uint64_t x);

// The seed of one purpose of a study (an instrument, a Monte Carlo loop), e.g.
// derive_seed(seed, "species/brdf", species_index): the only way a study derives seeds from
// its `seed` key. Purpose and index are hashed, never added to the seed, so that seed S and
// S + 1 (or S + 100) share no stream, and neither do two purposes of one seed.
std::uint64_t derive_seed(std::uint64_t seed, std::string_view purpose, std::uint64_t index = 0);

}  // namespace plumage
