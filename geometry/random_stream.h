// The random streams of geometry's generators (spongy_volume.cpp, hard_sphere_packing.cpp):
// std::mt19937_64 seeded through std::seed_seq from (seed, item, stream), and uniform variates
// from the raw 64-bit output, not from std::uniform_real_distribution, whose algorithm the
// standard leaves to the library. The same arguments give the same numbers with any standard
// library, on any machine. Each generator numbers its own streams, so that adding a draw to
// one cannot shift another. Internal to plumage_geometry.
#pragma once

#include <cstdint>
#include <random>

namespace plumage::geometry::detail {

inline std::mt19937_64 seeded_stream(std::uint64_t seed, std::uint64_t item, std::uint32_t stream) {
    auto low = [](std::uint64_t v) { return static_cast<std::uint32_t>(v & 0xffffffffu); };
    auto high = [](std::uint64_t v) { return static_cast<std::uint32_t>(v >> 32); };
    std::seed_seq sequence{low(seed), high(seed), low(item), high(item), stream};
    return std::mt19937_64(sequence);
}

// Uniform in [0, 1) from the top 53 bits.
inline double uniform01(std::mt19937_64& rng) {
    return static_cast<double>(rng() >> 11) * 0x1.0p-53;
}

}  // namespace plumage::geometry::detail
