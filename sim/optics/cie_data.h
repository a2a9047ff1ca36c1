// Tabulated colorimetric data: CIE 1931 2° standard observer and CIE standard
// illuminant D65. Pure data; interpolation and integration live in colour.h.
//
// Sources (the values are the CIE's published tables, transcribed verbatim):
//  - CIE 1931 2° colour-matching functions x̄, ȳ, z̄, 360–830 nm at 1 nm:
//    CIE 018:2019 / ISO/CIE 11664-1:2019 (also CIE 15:2004 Table T.4 at 5 nm).
//  - CIE standard illuminant D65 relative spectral power distribution,
//    300–830 nm at 5 nm, normalised to 100 at 560 nm: ISO/CIE 11664-2:2022
//    (CIE S 014-2, also CIE 15:2004 Table T.1).
#pragma once

#include <array>

namespace plumage::optics::cie_data {

inline constexpr double kCmfFirstNm = 360.0;
inline constexpr double kCmfStepNm = 1.0;
inline constexpr int kCmfCount = 471;  // 360..830 inclusive
extern const std::array<double, kCmfCount> kCie1931X;
extern const std::array<double, kCmfCount> kCie1931Y;
extern const std::array<double, kCmfCount> kCie1931Z;

inline constexpr double kD65FirstNm = 300.0;
inline constexpr double kD65StepNm = 5.0;
inline constexpr int kD65Count = 107;  // 300..830 inclusive
extern const std::array<double, kD65Count> kD65;

}  // namespace plumage::optics::cie_data
