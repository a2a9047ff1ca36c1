#include "sim/scatterer/random.h"

namespace plumage {

Rng::Rng(std::uint64_t seed, std::uint64_t item) {
    const std::uint64_t a = splitmix64(seed ^ splitmix64(item));
    increment_ = (splitmix64(a + 1) << 1) | 1U;
    state_ = 0;
    next_u32();
    state_ += a;
    next_u32();
}

std::uint32_t Rng::next_u32() {
    const std::uint64_t old = state_;
    state_ = old * 6364136223846793005ULL + increment_;
    const auto xorshifted = static_cast<std::uint32_t>(((old >> 18U) ^ old) >> 27U);
    const auto rot = static_cast<std::uint32_t>(old >> 59U);
    return (xorshifted >> rot) | (xorshifted << ((-rot) & 31U));
}

double Rng::uniform() { return next_u32() * 0x1p-32; }

}  // namespace plumage
