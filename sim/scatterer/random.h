// Deterministic random streams. Every stream is derived from (seed, item index) so that
// results do not depend on thread count, scheduling or process count (docs/architecture.md).
// Generator: PCG32 (O'Neill 2014, XSH-RR output), 2^64 period per stream, 2^63 streams;
// the stream's increment and initial state are hashed from (seed, item) with SplitMix64.
#pragma once

#include <cstdint>

#include "common/seed.h"  // splitmix64, derive_seed

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

}  // namespace plumage
