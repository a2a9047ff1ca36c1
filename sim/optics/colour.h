// Spectrum → colour: CIE 1931 2° XYZ, linear and gamma-encoded sRGB, CIELAB, CIEDE2000.
//
// Spectral first: colour is derived from a spectrum at the end, never the reverse.
// XYZ of a reflectance spectrum R(λ) under illuminant S(λ) is
//   X = ∫ R S x̄ dλ / ∫ S ȳ dλ   (likewise Y, Z),
// integrated with the trapezoidal rule on the caller's wavelength grid, with x̄ ȳ z̄
// (1 nm) and S (D65 at 5 nm) linearly interpolated onto it. The normalisation uses the
// same quadrature, so a perfect reflector has Y = 1 exactly on any grid.
// sRGB: IEC 61966-2-1 primaries and transfer curve, D65 white.
// CIELAB: CIE 15:2004 with the illuminant's own white. CIEDE2000: Sharma, Wu & Dalal,
// Color Res. Appl. 30, 21 (2005).
#pragma once

#include <array>
#include <span>
#include <vector>

#include "sim/optics/spectrum.h"

namespace plumage::optics {

struct Xyz {
    double x, y, z;
};
struct Lab {
    double l, a, b;
};
using Rgb = std::array<double, 3>;

enum class Illuminant { d65, equal_energy };

// Relative spectral power of an illuminant (D65: 100 at 560 nm; E: 1).
double illuminant_power(Illuminant illuminant, double lambda_nm);
// CIE 1931 2° colour-matching functions, linearly interpolated; zero outside 360–830 nm.
Xyz colour_matching(double lambda_nm);

inline constexpr double kCmfMinNm = 360.0;
inline constexpr double kCmfMaxNm = 830.0;
// Grids reaching into the ultraviolet (birds see it) still give a colour: D65 is tabulated from
// 300 nm, and below 360 nm the colour-matching functions are zero, so UV light is invisible in
// CIE colour (weight 0): colour integrates only over the part of the grid within 360–830 nm.
inline constexpr double kColourGridMinNm = 300.0;
// At least two wavelengths, all within kColourGridMinNm–kCmfMaxNm, the last above kCmfMinNm.
bool carries_colour(std::span<const double> wavelengths_nm);

class ReflectanceToXyz {
public:
    // Throws InputError if the grid reaches outside 300–830 nm or has no sample above 360 nm.
    ReflectanceToXyz(const WavelengthGrid& grid, Illuminant illuminant);

    // reflectance.size() must equal the grid's size.
    Xyz operator()(std::span<const double> reflectance) const;
    // XYZ of the perfect reflector (Y = 1): the white for CIELAB.
    const Xyz& white() const { return white_; }
    std::size_t size() const { return wx_.size(); }

private:
    std::vector<double> wx_, wy_, wz_;
    Xyz white_{};
};

Rgb linear_srgb_from_xyz(const Xyz& xyz);
double srgb_encode(double linear);  // IEC 61966-2-1 transfer curve, input clamped to [0, 1]
Lab lab_from_xyz(const Xyz& xyz, const Xyz& white);
// Hue angle h_ab in degrees, [0, 360).
double hue_angle_deg(const Lab& lab);
double chroma(const Lab& lab);
double ciede2000(const Lab& reference, const Lab& sample, double k_l = 1.0, double k_c = 1.0,
                 double k_h = 1.0);

}  // namespace plumage::optics
