#include "virtual_gonio/display_colour.h"

#include <algorithm>
#include <cmath>

namespace plumage::gonio {
namespace {
// CIE 15:2004 D65 white, Y = 1.
constexpr double kD65X = 0.95047, kD65Z = 1.08883;
}  // namespace

SpectrumToDisplay::SpectrumToDisplay(const std::vector<double>& wavelengths_nm) {
    if (optics::carries_colour(wavelengths_nm)) {
        to_xyz_.emplace(optics::WavelengthGrid(wavelengths_nm), optics::Illuminant::d65);
    }
}

optics::Xyz SpectrumToDisplay::xyz(std::span<const double> spectrum) const {
    if (!to_xyz_) {
        double mean = 0.0;
        for (double v : spectrum) mean += v / static_cast<double>(spectrum.size());
        return {kD65X * mean, mean, kD65Z * mean};
    }
    optics::Xyz c = (*to_xyz_)(spectrum);
    c.x *= kD65X / to_xyz_->white().x;
    c.z *= kD65Z / to_xyz_->white().z;
    return c;
}

optics::Rgb display_linear(const optics::Xyz& xyz, double exposure) {
    optics::Rgb c =
        optics::linear_srgb_from_xyz({xyz.x * exposure, xyz.y * exposure, xyz.z * exposure});
    for (double& v : c) v = std::max(0.0, v);
    const double top = std::max({c[0], c[1], c[2]});
    if (top > 1.0)
        for (double& v : c) v /= top;
    return c;
}

std::array<std::uint8_t, 3> display_bytes(const optics::Xyz& xyz, double exposure) {
    const optics::Rgb c = display_linear(xyz, exposure);
    std::array<std::uint8_t, 3> out{};
    for (int i = 0; i < 3; ++i)
        out[i] = static_cast<std::uint8_t>(std::lround(optics::srgb_encode(c[i]) * 255.0));
    return out;
}

}  // namespace plumage::gonio
