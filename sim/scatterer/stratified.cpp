#include "sim/scatterer/stratified.h"

namespace plumage {
namespace {

using Directions = std::array<std::array<std::uint32_t, 32>, ScrambledSobolGroup::kDimensions>;

// Joe and Kuo's direction numbers v_k = m_k · 2^(32 − k): a primitive polynomial of degree s with
// inner coefficients a (bit s − 2 … 0 for x^(s−1) … x) and initial m_1 … m_s; beyond them
// m_k = 2^s m_(k−s) ⊕ m_(k−s) ⊕ Σ_j a_j 2^j m_(k−j).
constexpr std::array<std::uint32_t, 32> joe_kuo(int s, std::uint32_t a,
                                                std::array<std::uint32_t, 3> initial) {
    std::array<std::uint64_t, 33> m{};
    for (int k = 1; k <= s; ++k)
        m[static_cast<std::size_t>(k)] = initial[static_cast<std::size_t>(k - 1)];
    for (int k = s + 1; k <= 32; ++k) {
        std::uint64_t value =
            (m[static_cast<std::size_t>(k - s)] << s) ^ m[static_cast<std::size_t>(k - s)];
        for (int j = 1; j < s; ++j)
            if ((a >> (s - 1 - j)) & 1u) value ^= m[static_cast<std::size_t>(k - j)] << j;
        m[static_cast<std::size_t>(k)] = value;
    }
    std::array<std::uint32_t, 32> v{};
    for (int k = 1; k <= 32; ++k)
        v[static_cast<std::size_t>(k - 1)] =
            static_cast<std::uint32_t>(m[static_cast<std::size_t>(k)] << (32 - k));
    return v;
}

constexpr Directions make_directions() {
    Directions d{};
    for (int k = 0; k < 32; ++k) d[0][static_cast<std::size_t>(k)] = 1u << (31 - k);
    d[1] = joe_kuo(1, 0u, {1u, 0u, 0u});  // x + 1
    d[2] = joe_kuo(2, 1u, {1u, 3u, 0u});  // x² + x + 1
    d[3] = joe_kuo(3, 1u, {1u, 3u, 1u});  // x³ + x + 1
    return d;
}

constexpr Directions kDirections = make_directions();

std::uint32_t sobol(std::uint32_t index, int dimension) {
    const auto& v = kDirections[static_cast<std::size_t>(dimension)];
    std::uint32_t x = 0;
    for (std::size_t k = 0; index != 0; index >>= 1, ++k)
        if (index & 1u) x ^= v[k];
    return x;
}

std::uint32_t reverse_bits(std::uint32_t x) {
    x = ((x >> 1) & 0x55555555u) | ((x & 0x55555555u) << 1);
    x = ((x >> 2) & 0x33333333u) | ((x & 0x33333333u) << 2);
    x = ((x >> 4) & 0x0F0F0F0Fu) | ((x & 0x0F0F0F0Fu) << 4);
    x = ((x >> 8) & 0x00FF00FFu) | ((x & 0x00FF00FFu) << 8);
    return (x >> 16) | (x << 16);
}

// Burley's Laine–Karras permutation: each output bit depends only on the input bits below it,
// which on the reversed digits is a nested (Owen) scramble: a digit's flip depends only on the
// digits before it.
std::uint32_t nested_uniform_scramble(std::uint32_t x, std::uint32_t key) {
    x = reverse_bits(x);
    x += key;
    x ^= x * 0x6c50b47cu;
    x ^= x * 0xb82f1e52u;
    x ^= x * 0xc7afe638u;
    x ^= x * 0x8d22f6e6u;
    return reverse_bits(x);
}

}  // namespace

ScrambledSobolGroup::ScrambledSobolGroup(Rng& rng) {
    for (int d = 0; d < kDimensions; ++d) {
        key_[static_cast<std::size_t>(d)] = rng.next_u32();
        shift_[static_cast<std::size_t>(d)] = rng.next_u32();
    }
}

std::uint32_t ScrambledSobolGroup::digits(std::uint32_t index, int dimension) const {
    const auto d = static_cast<std::size_t>(dimension);
    return nested_uniform_scramble(sobol(index, dimension), key_[d]) ^ shift_[d];
}

double ScrambledSobolGroup::uniform(std::uint32_t index, int dimension) const {
    return static_cast<double>(digits(index, dimension)) * 0x1.0p-32;
}

}  // namespace plumage
