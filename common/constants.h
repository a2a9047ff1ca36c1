// Mathematical constants shared by every floor of Plumage: one definition each, so that
// every file converts degrees and integrates over the sphere with the same double.
// The expressions are the ones the files used before this header existed; changing one
// changes numbers in the records.
#pragma once

#include <numbers>

namespace plumage {

inline constexpr double kPi = std::numbers::pi;           // π (dimensionless; rad per half turn)
inline constexpr double kTwoPi = 2.0 * std::numbers::pi;  // 2π (rad per turn)
inline constexpr double kDeg = kPi / 180.0;               // one degree in radians (rad/deg)
inline constexpr double kSqrt2 = std::numbers::sqrt2;     // √2 (dimensionless)

}  // namespace plumage
