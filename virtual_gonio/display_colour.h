// Measured spectra → what a person sees on screen: one implementation for every image
// the instruments write (scatterograms, BRDF fingerprints, BTF images).
//
//  - XYZ under D65 with the CIE 1931 2° observer on the record's wavelength grid,
//    white-balanced so that a flat spectrum maps to the D65 white point on any grid
//    (a few wavelengths do not span the visible; colour casts must be the scatterer's,
//    not the sampling's). Grids that cannot carry colour (optics::carries_colour: one
//    wavelength, or outside 300–830 nm) give grey from the mean; UV samples weigh 0.
//  - Display: exposure scales luminance; negative (out-of-gamut) sRGB components clip to
//    0; over-range colours are scaled by their largest component so the hue survives;
//    then the sRGB transfer curve, 8 bits.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "sim/optics/colour.h"

namespace plumage::gonio {

class SpectrumToDisplay {
public:
    explicit SpectrumToDisplay(const std::vector<double>& wavelengths_nm);
    optics::Xyz xyz(std::span<const double> spectrum) const;
    bool colour() const { return to_xyz_.has_value(); }

private:
    std::optional<optics::ReflectanceToXyz> to_xyz_;
};

// Linear display sRGB in [0, 1]: exposure, negatives clipped, over-range scaled by the largest
// component (the rule above, before the transfer curve).
optics::Rgb display_linear(const optics::Xyz& xyz, double exposure);
std::array<std::uint8_t, 3> display_bytes(const optics::Xyz& xyz, double exposure);

}  // namespace plumage::gonio
