#include "sim/optics/colour.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "common/constants.h"
#include "common/error.h"
#include "sim/optics/cie_data.h"

namespace plumage::optics {

double illuminant_power(Illuminant illuminant, double lambda_nm) {
    if (illuminant == Illuminant::equal_energy) return 1.0;
    return interpolate_uniform_table(cie_data::kD65, cie_data::kD65FirstNm, cie_data::kD65StepNm,
                                     lambda_nm);
}

Xyz colour_matching(double lambda_nm) {
    using namespace cie_data;
    return {interpolate_uniform_table(kCie1931X, kCmfFirstNm, kCmfStepNm, lambda_nm),
            interpolate_uniform_table(kCie1931Y, kCmfFirstNm, kCmfStepNm, lambda_nm),
            interpolate_uniform_table(kCie1931Z, kCmfFirstNm, kCmfStepNm, lambda_nm)};
}

bool carries_colour(std::span<const double> wavelengths_nm) {
    return wavelengths_nm.size() >= 2 && wavelengths_nm.front() >= kColourGridMinNm &&
           wavelengths_nm.back() <= kCmfMaxNm && wavelengths_nm.back() > kCmfMinNm;
}

ReflectanceToXyz::ReflectanceToXyz(const WavelengthGrid& grid, Illuminant illuminant) {
    if (grid.first() < kColourGridMinNm || grid.last() > kCmfMaxNm) {
        throw InputError(fmt::format(
            "colour needs wavelengths within {}–{} nm (the CIE 1931 colour-matching functions "
            "cover {}–{} nm; below that UV light has weight 0); the grid spans {}–{} nm",
            kColourGridMinNm, kCmfMaxNm, kCmfMinNm, kCmfMaxNm, grid.first(), grid.last()));
    }
    const std::size_t n = grid.size();
    wx_.assign(n, 0.0);
    wy_.assign(n, 0.0);
    wz_.assign(n, 0.0);
    // Trapezoidal weights; a single wavelength integrates as a 1 nm band (the ratio to
    // the white is all that matters).
    for (std::size_t i = 0; i < n; ++i) {
        double width = 1.0;
        if (n > 1) {
            const double left = i > 0 ? grid[i] - grid[i - 1] : 0.0;
            const double right = i + 1 < n ? grid[i + 1] - grid[i] : 0.0;
            width = 0.5 * (left + right);
        }
        const double s = illuminant_power(illuminant, grid[i]) * width;
        const Xyz cmf = colour_matching(grid[i]);
        wx_[i] = s * cmf.x;
        wy_[i] = s * cmf.y;
        wz_[i] = s * cmf.z;
    }
    double y_white = 0.0;
    for (double w : wy_) y_white += w;
    if (!(y_white > 0.0)) {
        throw InputError(
            "colour: the wavelength grid carries no luminance (ȳ · illuminant is zero "
            "on every sample)");
    }
    for (std::size_t i = 0; i < n; ++i) {
        wx_[i] /= y_white;
        wy_[i] /= y_white;
        wz_[i] /= y_white;
        white_.x += wx_[i];
        white_.y += wy_[i];
        white_.z += wz_[i];
    }
}

Xyz ReflectanceToXyz::operator()(std::span<const double> reflectance) const {
    PLUMAGE_CHECK(reflectance.size() == wx_.size(),
                  fmt::format("spectrum has {} samples, grid {}", reflectance.size(), wx_.size()));
    Xyz xyz{0.0, 0.0, 0.0};
    for (std::size_t i = 0; i < reflectance.size(); ++i) {
        xyz.x += wx_[i] * reflectance[i];
        xyz.y += wy_[i] * reflectance[i];
        xyz.z += wz_[i] * reflectance[i];
    }
    return xyz;
}

Rgb linear_srgb_from_xyz(const Xyz& c) {
    // IEC 61966-2-1 matrix (D65 white), to the precision of the standard's primaries.
    return {3.2404542 * c.x - 1.5371385 * c.y - 0.4985314 * c.z,
            -0.9692660 * c.x + 1.8760108 * c.y + 0.0415560 * c.z,
            0.0556434 * c.x - 0.2040259 * c.y + 1.0572252 * c.z};
}

double srgb_encode(double linear) {
    const double v = std::clamp(linear, 0.0, 1.0);
    return v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(v, 1.0 / 2.4) - 0.055;
}

Lab lab_from_xyz(const Xyz& xyz, const Xyz& white) {
    constexpr double epsilon = 216.0 / 24389.0;
    constexpr double kappa = 24389.0 / 27.0;
    auto f = [](double t) { return t > epsilon ? std::cbrt(t) : (kappa * t + 16.0) / 116.0; };
    const double fx = f(xyz.x / white.x);
    const double fy = f(xyz.y / white.y);
    const double fz = f(xyz.z / white.z);
    return {116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz)};
}

namespace {
double degrees_0_360(double y, double x) {
    if (x == 0.0 && y == 0.0) return 0.0;
    double h = std::atan2(y, x) / kDeg;
    return h < 0.0 ? h + 360.0 : h;
}
}  // namespace

double hue_angle_deg(const Lab& lab) { return degrees_0_360(lab.b, lab.a); }
double chroma(const Lab& lab) { return std::hypot(lab.a, lab.b); }

double ciede2000(const Lab& c1, const Lab& c2, double k_l, double k_c, double k_h) {
    const double c_star_mean = 0.5 * (chroma(c1) + chroma(c2));
    const double c7 = std::pow(c_star_mean, 7.0);
    const double g = 0.5 * (1.0 - std::sqrt(c7 / (c7 + std::pow(25.0, 7.0))));
    const double a1 = (1.0 + g) * c1.a;
    const double a2 = (1.0 + g) * c2.a;
    const double cp1 = std::hypot(a1, c1.b);
    const double cp2 = std::hypot(a2, c2.b);
    const double hp1 = degrees_0_360(c1.b, a1);
    const double hp2 = degrees_0_360(c2.b, a2);

    const double dl = c2.l - c1.l;
    const double dc = cp2 - cp1;
    double dh_angle = 0.0;
    if (cp1 * cp2 != 0.0) {
        dh_angle = hp2 - hp1;
        if (dh_angle > 180.0) dh_angle -= 360.0;
        if (dh_angle < -180.0) dh_angle += 360.0;
    }
    const double dh = 2.0 * std::sqrt(cp1 * cp2) * std::sin(0.5 * dh_angle * kDeg);

    const double l_mean = 0.5 * (c1.l + c2.l);
    const double cp_mean = 0.5 * (cp1 + cp2);
    double hp_mean = hp1 + hp2;
    if (cp1 * cp2 != 0.0) {
        if (std::abs(hp1 - hp2) <= 180.0) {
            hp_mean *= 0.5;
        } else {
            hp_mean = hp_mean < 360.0 ? 0.5 * (hp_mean + 360.0) : 0.5 * (hp_mean - 360.0);
        }
    }
    const double t = 1.0 - 0.17 * std::cos((hp_mean - 30.0) * kDeg) +
                     0.24 * std::cos(2.0 * hp_mean * kDeg) +
                     0.32 * std::cos((3.0 * hp_mean + 6.0) * kDeg) -
                     0.20 * std::cos((4.0 * hp_mean - 63.0) * kDeg);
    const double d_theta = 30.0 * std::exp(-std::pow((hp_mean - 275.0) / 25.0, 2.0));
    const double cp7 = std::pow(cp_mean, 7.0);
    const double r_c = 2.0 * std::sqrt(cp7 / (cp7 + std::pow(25.0, 7.0)));
    const double l50 = (l_mean - 50.0) * (l_mean - 50.0);
    const double s_l = 1.0 + 0.015 * l50 / std::sqrt(20.0 + l50);
    const double s_c = 1.0 + 0.045 * cp_mean;
    const double s_h = 1.0 + 0.015 * cp_mean * t;
    const double r_t = -std::sin(2.0 * d_theta * kDeg) * r_c;

    const double tl = dl / (k_l * s_l);
    const double tc = dc / (k_c * s_c);
    const double th = dh / (k_h * s_h);
    return std::sqrt(tl * tl + tc * tc + th * th + r_t * tc * th);
}

}  // namespace plumage::optics
