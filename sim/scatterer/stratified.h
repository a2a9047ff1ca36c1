// Stratified draws for a group of quanta: randomised quasi-Monte Carlo on the first few
// dimensions of a quantum (where it starts on the detector and in which direction), so that a
// group of 2^m quanta covers them evenly instead of clumping as independent draws do.
//
// The points: Sobol's sequence in four dimensions (Joe and Kuo's direction numbers: dimension 0
// the van der Corput sequence, then the primitive polynomials x + 1, x² + x + 1, x³ + x + 1),
// each dimension's 32-bit digits scrambled by a hash-based nested uniform (Owen) scramble
// (Burley 2020, "Practical Hash-based Owen Scrambling", the Laine–Karras form with his
// constants) under a key of its own, and then XOR-ed with a uniform random 32-bit shift.
//  - The shift makes every point of every group exactly uniform on the 2^-32 grid, whatever the
//    hash's quality (x ⊕ U is uniform for U uniform and independent of x), so a group's mean is
//    an unbiased estimate for any integrand.
//  - Scramble and shift are digit-wise bijections that keep Sobol's nets: the first 2^m points
//    put exactly one point in every interval [j / 2^m, (j + 1) / 2^m) of each dimension and in
//    every elementary box of area 2^-m of dimensions (0, 1), and 2^t points in every box of
//    2^(t − m) of dimensions (2, 3), t = 1 from 2^5 points on (tests/sim/stratified_test.cpp). That
//    is where the variance goes: for an integrand with smooth parts and jumps along curves (a
//    pixel's edge of a highlight, a cone's rim) the variance of the group's mean falls faster than
//    1/2^m.
//  - Groups are independent (keys and shifts from the group's own stream), so the spread of the
//    group means is an honest standard error; the spread of the single quanta is not (it
//    overstates the error of a stratified mean).
// Draw a group's keys from its own Rng (the (seed, purpose, index) rule): bit-identical for any
// thread count.
#pragma once

#include <array>
#include <cstdint>

#include "sim/scatterer/random.h"

namespace plumage {

class ScrambledSobolGroup {
public:
    static constexpr int kDimensions = 4;
    // Draws the group's scramble keys and shifts from rng (8 words).
    explicit ScrambledSobolGroup(Rng& rng);
    // Point `index` of the group in dimension `dimension` (0 … 3): in [0, 1), 2^-32 resolution
    // (the resolution of Rng::uniform()). Indices 0 … 2^m − 1 form the stratified set.
    double uniform(std::uint32_t index, int dimension) const;
    // The scrambled 32-bit digits of the same point (for tests of the nets).
    std::uint32_t digits(std::uint32_t index, int dimension) const;

private:
    std::array<std::uint32_t, kDimensions> key_{}, shift_{};
};

}  // namespace plumage
