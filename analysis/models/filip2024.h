// Jiří Filip, Frank J. Maile and Radomír Vávra, "Angle-dependent analysis and modeling of
// absorption and structural colors in feathers", CVCS 2024, the 12th Colour and Visual Computing
// Symposium, Gjøvik, Norway, 2024: the five-term analytic feather BRDF of their Eqs. 1–6 with
// the Table 1 presets, as a Scatterer.
//
//   f = (1 − M) C_b                                   background              (lobe 0)
//     +      M  C_a                                   anisotropic highlight   (lobe 1)
//     + (1 − M) C_s E D(0) F                          near-specular highlight (lobe 2)
//     + (1 − M) C_r E D(π)^γ F                        retro-reflective        (lobe 3)
//     +      M  α E^β D(0)                            specular highlight      (lobe 4)
//
//   x = 1 − |H·U|, H = (ωi + ωo)/|ωi + ωo|, U = (sin φa, cos φa, 0)          (Eq. 1)
//   M = S((x − w + d_w) / (2 d_w)), S(y) = y²(3 − 2y) for y in [0, 1],      (Eq. 2, see below)
//       i.e. M = 0 for x ≤ w − d_w and M = 1 for x ≥ w + d_w
//   E = 1.1 − cos θi cos θo                                                  (Eq. 4)
//   D(δ) = |wrap(φi − φo − δ)| / (2π), wrap into [−π, π]                     (Eq. 5, see below)
//   F = max(0, 1 − |θi − θo| / θmax)                                         (Eq. 6, see below)
//
// Readings of the printed equations (the print is not self-consistent; issue "Filip 2024 model"):
//  - Eq. 2 prints M = 1 for x ≤ w − d_w and M = 0 for x ≥ w + d_w, joined by a smoothstep
//    y²(3 − 2y) with y = (x − w + d_w)/(2d). That smoothstep RISES from 0 at x = w − d_w to 1 at
//    x = w + d_w, so the printed cases make M jump at both ends. Two continuous readings exist:
//    (a) keep the cases and use 1 − S (M falls with x), or (b) keep the smoothstep and swap the
//    cases (M rises with x). We use (b), and "2d" as 2 d_w (the only width in the equation), for
//    three reasons from the paper itself: M is "a support mask around the highlights", and
//    Eq. 1 and its text put the anisotropic highlights where H is orthogonal to U, i.e. at
//    x = 1, where (b) gives M = 1 and (a) gives M = 0; the fifth term, called the specular
//    highlight, is multiplied by M, and at the mirror direction H is the normal, so x = 1 — under
//    (a) the rooster preset would scale its specular highlight by 1 − M = 0.04 there; and every
//    preset has C_a brighter than C_b, the highlight colour on the highlight band. Reading (a)
//    is a one-line change in filip2024_mask().
//    Note that x ≤ 1 always and w + d_w > 1 in all four presets, so M never reaches 1 with the
//    paper's values (M(x = 1) = 0.59, 0.96, 0.84, 0.74 for parrot, rooster, flamingo, stork).
//  - Eq. 5 prints D(δ) = |φi − φo − δ|/(2π) without wrapping: the same pair of directions then
//    gets different D depending on how its azimuths are written (φ and φ + 2π), D jumps where an
//    azimuth crosses ±π, and D(π) is not symmetric in (ωi, ωo). We wrap the difference into
//    [−π, π] so that D(δ) is the true angular distance from δ, over the printed 2π: D ∈ [0, 1/2].
//    (Dividing by π instead would make D ∈ [0, 1]; the paper does not decide it. We keep the
//    print, so the retro term of the parrot, γ = 4, is at most C_r E F / 16.) With the wrap the
//    model is reciprocal: f(ωi, ωo) = f(ωo, ωi). Unwrapped, the retro term (D(π), γ > 0) breaks
//    reciprocity; D(0) does not.
//  - D(0) is largest when the light and the view are on opposite sides (φo = φi + π, the mirror
//    azimuth in our convention of directions pointing away from the patch), D(π) when they are
//    on the same side (retro-reflection): the term built on D(0) is the paper's (near-)specular
//    term and the one on D(π) its retro-reflective term, as the paper names them.
//  - Eq. 6 makes F negative when |θi − θo| > θmax (outside the captured range, 75°). We clamp F
//    at 0 so that f ≥ 0 everywhere; inside the captured range nothing changes.
//  - γ = 0 gives D(π)^0 = 1 everywhere (including D = 0, where pow(0, 0) = 1).
//
// Frame. Our patch frame (sim/scatterer/scatterer.h): +z the patch normal, +x the barb axis, +y the
// barbules' direction, directions pointing away from the patch. The paper's ωi = [θi, φi] and
// ωv = [θv, φv] also point away from the surface (its half vector is (ωi + ωv)/|ωi + ωv|); we
// identify its axes with ours: θ is the polar angle from +z, φ the azimuth from +x towards +y
// (φ = atan2(y, x), and φ = 0 for a direction exactly on the normal), ωv is our ωo, and
// U(φa) = (sin φa, cos φa, 0) in our (x, y, z) as printed. The paper draws no axes against the
// barb; with this identification the parrot's U (φa = 90°) is the barb axis +x, which matches its
// text (the parrot's highlight comes from the cylindrical barbs). Since |H·U| enters, φa and
// φa ± π are the same model. The model depends on φi at the pole (D(δ) uses φi − φo): it is
// discontinuous at θi = 0 and θo = 0, where the φ = 0 convention above decides.
//
// Units. The paper does not state the units of its BRDF values. A white stork feather with
// C_b ≈ 0.8 read as 0.8 sr⁻¹ would reflect 2.5 times the incident power; read as a reflectance
// factor (the ratio to an ideal white diffuser, the usual calibration of a gonioreflectometer),
// 0.8 means 0.8/π sr⁻¹. We therefore return f = brdf_scale_per_sr × (Eq. 3), default 1/π.
// Energy with that default (directional albedo by quadrature, max over azimuth and channel):
//   parrot    ≤ 0.42 for θi ≤ 75°, 0.66 at θi = 89°: conserves energy everywhere;
//   rooster   ≤ 0.50 for θi ≤ 75°, but > 1 for θi ≥ 88° (1.11 at 89°): the specular highlight
//             α E^β D(0) with β = 12 grows as E → 1.1 at grazing light;
//   flamingo  0.72–0.88 at normal incidence, > 1 from θi ≈ 25°, 1.45 at 75°;
//   stork     0.92–0.94 at normal incidence, > 1 from θi ≈ 16°, 1.50 at 75°:
//             background plus a retro term that, with γ = 0 and C_r = C_b, adds C_b E F again.
// analysis/metrics/energy.h measures and flags this; nothing is clamped or hidden. With
// brdf_scale_per_sr = 1 all four presets exceed 1 (stork: 2.9 at normal incidence).
//
// Spectrum. The paper's colours are camera RGB. We associate each channel with a band and make
// the model piecewise constant in wavelength over 380–780 nm:
//   blue [380, 490) nm, green [490, 580) nm, red [580, 780] nm
// (edges near the crossovers of typical camera sensitivities, peaks ≈ 460, 540, 600 nm).
// Limits: a box spectrum is not a spectral upsampling — integrating it against the CIE 1931
// observer does not give back the paper's RGB (the camera's primaries are not sRGB's, and the
// bands are broad); there is no hue shift within a band; the spectrum jumps at the edges; outside
// 380–780 nm the model is undefined and eval()/pdf()/sample() throw InputError. The α E^β term
// (the specular highlight) is achromatic in the paper and here.
//
// Parameters (kFilip2024ParameterTable below is the machine-readable table the constructor
// validates against; the defaults are the parrot preset):
//
// clang-format off
//  | name              | sym  | unit | default (parrot) | range      | meaning                   |
//  |-------------------|------|------|------------------|------------|---------------------------|
//  | phi_a_rad         | φa   | rad  | π/2 (90°)        | [−π, π]    | anisotropy direction U    |
//  | c_b               | C_b  | 1    | .155, .214, .290 | [0, 10]    | background colour R, G, B |
//  | c_a               | C_a  | 1    | .390, .384, .416 | [0, 10]    | anisotropic highlight     |
//  | c_s               | C_s  | 1    | .206, .285, .387 | [0, 10]    | near-specular colour      |
//  | c_r               | C_r  | 1    | .107, .277, .446 | [0, 10]    | retro-reflective colour   |
//  | alpha             | α    | 1    | 3                | [0, 100]   | specular highlight scale  |
//  | beta              | β    | 1    | 12               | [0, 50]    | its elevation exponent    |
//  | gamma             | γ    | 1    | 4                | [0, 50]    | retro lobe sharpness      |
//  | w                 | w    | 1    | 0.95             | [0, 2]     | mask centre, units of x   |
//  | d_w               | d_w  | 1    | 0.40             | [0.001, 1] | mask half-width           |
//  | theta_max_rad     | θmax | rad  | 75° (5π/12)      | [1°, 90°]  | largest captured θ        |
//  | brdf_scale_per_sr | —    | 1/sr | 1/π              | [1e-6, 10] | Eq. 3 → BRDF (Units)      |
// clang-format on
//
// Colours are dimensionless reflectance factors (see Units). d_w > 0 keeps M continuous
// (d_w → 0 is a hard step).
#pragma once

#include <array>
#include <numbers>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "common/parameter_spec.h"

#include "sim/scatterer/scatterer.h"

namespace plumage::analysis {

enum class RgbChannel : int { kRed = 0, kGreen = 1, kBlue = 2 };
using Rgb = std::array<double, 3>;  // indexed by RgbChannel: R, G, B

// The band of each channel (nm): blue [380, 490), green [490, 580), red [580, 780].
inline constexpr double kFilip2024MinWavelengthNm = 380.0;
inline constexpr double kFilip2024BlueGreenEdgeNm = 490.0;
inline constexpr double kFilip2024GreenRedEdgeNm = 580.0;
inline constexpr double kFilip2024MaxWavelengthNm = 780.0;

// The channel whose band holds lambda_nm; InputError outside [380, 780] nm.
RgbChannel filip2024_channel(double lambda_nm);
// A wavelength inside the channel's band (its centre), for feeding RGB data to eval().
double filip2024_band_centre_nm(RgbChannel channel);

// Every scalar parameter, in the order of kFilip2024ParameterTable (and of the fit's vector).
// clang-format off
enum Filip2024ParameterIndex : int {
    kFilipPhiA = 0,
    kFilipCbR, kFilipCbG, kFilipCbB,
    kFilipCaR, kFilipCaG, kFilipCaB,
    kFilipCsR, kFilipCsG, kFilipCsB,
    kFilipCrR, kFilipCrG, kFilipCrB,
    kFilipAlpha, kFilipBeta, kFilipGamma, kFilipW, kFilipDw,
    kFilipThetaMax, kFilipBrdfScale,
    kFilip2024ParameterCount
};
// clang-format on

// The machine-readable table (common/parameter_spec.h): the fit's bounds, the constructor's
// validation, the Python names.
using Filip2024ParameterInfo = ParameterSpec;

namespace filip2024_detail {
constexpr ParameterSpec colour(std::string_view name, double value, std::string_view meaning) {
    return {.name = name,
            .unit = "1",
            .default_value = value,
            .min = 0.0,
            .max = 10.0,
            .meaning = meaning};
}
}  // namespace filip2024_detail

// clang-format off
inline constexpr std::array<Filip2024ParameterInfo, kFilip2024ParameterCount>
    kFilip2024ParameterTable = {{
    {.name = "phi_a", .unit = "rad", .default_value = std::numbers::pi / 2,
     .min = -std::numbers::pi, .max = std::numbers::pi, .meaning = "anisotropy direction U"},
    filip2024_detail::colour("C_b[R]", 0.155, "background colour, red"),
    filip2024_detail::colour("C_b[G]", 0.214, "background colour, green"),
    filip2024_detail::colour("C_b[B]", 0.290, "background colour, blue"),
    filip2024_detail::colour("C_a[R]", 0.390, "anisotropic highlight, red"),
    filip2024_detail::colour("C_a[G]", 0.384, "anisotropic highlight, green"),
    filip2024_detail::colour("C_a[B]", 0.416, "anisotropic highlight, blue"),
    filip2024_detail::colour("C_s[R]", 0.206, "near-specular colour, red"),
    filip2024_detail::colour("C_s[G]", 0.285, "near-specular colour, green"),
    filip2024_detail::colour("C_s[B]", 0.387, "near-specular colour, blue"),
    filip2024_detail::colour("C_r[R]", 0.107, "retro-reflective colour, red"),
    filip2024_detail::colour("C_r[G]", 0.277, "retro-reflective colour, green"),
    filip2024_detail::colour("C_r[B]", 0.446, "retro-reflective colour, blue"),
    {.name = "alpha", .unit = "1", .default_value = 3.0, .min = 0.0, .max = 100.0,
     .meaning = "specular highlight scale"},
    {.name = "beta", .unit = "1", .default_value = 12.0, .min = 0.0, .max = 50.0,
     .meaning = "the highlight's elevation exponent"},
    {.name = "gamma", .unit = "1", .default_value = 4.0, .min = 0.0, .max = 50.0,
     .meaning = "retro lobe sharpness"},
    {.name = "w", .unit = "1", .default_value = 0.95, .min = 0.0, .max = 2.0,
     .meaning = "mask centre, units of x"},
    {.name = "d_w", .unit = "1", .default_value = 0.40, .min = 0.001, .max = 1.0,
     .meaning = "mask half-width"},
    {.name = "theta_max", .unit = "rad", .default_value = 75.0 * std::numbers::pi / 180,
     .min = std::numbers::pi / 180, .max = std::numbers::pi / 2,
     .meaning = "largest captured polar angle"},
    {.name = "brdf_scale", .unit = "1/sr", .default_value = 1.0 / std::numbers::pi, .min = 1e-6,
     .max = 10.0, .meaning = "Eq. 3 to BRDF"},
}};
// clang-format on

struct Filip2024Parameters {
    double phi_a_rad = kFilip2024ParameterTable[kFilipPhiA].default_value;
    Rgb c_b = {kFilip2024ParameterTable[kFilipCbR].default_value,
               kFilip2024ParameterTable[kFilipCbG].default_value,
               kFilip2024ParameterTable[kFilipCbB].default_value};
    Rgb c_a = {kFilip2024ParameterTable[kFilipCaR].default_value,
               kFilip2024ParameterTable[kFilipCaG].default_value,
               kFilip2024ParameterTable[kFilipCaB].default_value};
    Rgb c_s = {kFilip2024ParameterTable[kFilipCsR].default_value,
               kFilip2024ParameterTable[kFilipCsG].default_value,
               kFilip2024ParameterTable[kFilipCsB].default_value};
    Rgb c_r = {kFilip2024ParameterTable[kFilipCrR].default_value,
               kFilip2024ParameterTable[kFilipCrG].default_value,
               kFilip2024ParameterTable[kFilipCrB].default_value};
    double alpha = kFilip2024ParameterTable[kFilipAlpha].default_value;
    double beta = kFilip2024ParameterTable[kFilipBeta].default_value;
    double gamma = kFilip2024ParameterTable[kFilipGamma].default_value;
    double w = kFilip2024ParameterTable[kFilipW].default_value;
    double d_w = kFilip2024ParameterTable[kFilipDw].default_value;
    double theta_max_rad = kFilip2024ParameterTable[kFilipThetaMax].default_value;
    double brdf_scale_per_sr = kFilip2024ParameterTable[kFilipBrdfScale].default_value;
};

// The parameters as a flat vector in table order, and back.
std::array<double, kFilip2024ParameterCount> to_vector(const Filip2024Parameters& p);
Filip2024Parameters from_vector(const std::array<double, kFilip2024ParameterCount>& v);

// Throws InputError naming the first parameter outside its range (or not finite) and the range.
void validate(const Filip2024Parameters& p);

// Table 1 of the paper: "parrot", "rooster", "flamingo", "stork" (θmax = 75°, brdf_scale = 1/π).
// Unknown names throw InputError listing the valid ones.
Filip2024Parameters filip2024_preset(std::string_view name);
std::span<const std::string_view> filip2024_preset_names();

// Eq. 2 in our reading (see above): 0 for x ≤ w − d_w, 1 for x ≥ w + d_w, smoothstep between.
double filip2024_mask(double x, double w, double d_w);
// Eq. 5 in our reading: |φi − φo − δ| wrapped into [0, π], over 2π.
double filip2024_azimuth_distance(double phi_i, double phi_o, double delta);
// Azimuth of a direction in the patch frame, atan2(y, x), with 0 on the normal.
double patch_azimuth(const Vec3d& w);

// The direction-only quantities of Eqs. 1–6 for one pair (both above the patch). The fit
// evaluates thousands of parameter sets on the same pairs, so they are computed once.
struct Filip2024Geometry {
    Vec3d half_vector;            // H of Eq. 1
    double elevation;             // E of Eq. 4
    double d_specular;            // D(0) of Eq. 5
    double d_retro;               // D(π) of Eq. 5
    double polar_difference_rad;  // |θi − θo| of Eq. 6
};
Filip2024Geometry filip2024_geometry(const Vec3d& wi, const Vec3d& wo);

enum Filip2024Lobe : int {
    kBackgroundLobe = 0,
    kAnisotropicHighlightLobe,
    kNearSpecularLobe,
    kRetroreflectiveLobe,
    kSpecularHighlightLobe,
    kFilip2024LobeCount
};

// The five terms of Eq. 3 in 1/sr (brdf_scale applied) for one channel, and the mask M.
struct Filip2024Terms {
    std::array<double, kFilip2024LobeCount> lobes;
    double mask;
    double total() const;
};
Filip2024Terms filip2024_terms(const Filip2024Parameters& p, const Filip2024Geometry& g,
                               RgbChannel channel);

// The model as a Scatterer. Reflection only: f = 0 unless ωi.z > 0 and ωo.z > 0; light from
// below the patch is absorbed (sample() returns nothing). The light leaves where it arrived.
//
// Sampling: a mixture of four product densities p(cos θo) p(φo), each matched to terms of f:
//   0 cosine-weighted hemisphere            (background and anisotropic terms; ≥ 10 % always)
//   1 cosine in θo × |ψ| in ψ = φi − φo      (near-specular: D(0) is linear in |ψ|)
//   2 cosine in θo × |ψ − π|^γ               (retro-reflective: D(π)^γ)
//   3 ∝ E^β in cos θo × |ψ|                  (specular highlight α E^β D(0))
// with weights from each term's albedo bound at (ωi, channel) (M ≤ 1, F ≤ 1). pdf() is the
// exact mixture density; weight = f |cos θo| / pdf ≤ 10π max f. The reported lobe is drawn with
// probability f_lobe / f, so per-lobe tallies are unbiased.
class Filip2024Brdf final : public Scatterer {
public:
    explicit Filip2024Brdf(const Filip2024Parameters& parameters, std::string label = "filip2024");

    std::string name() const override { return label_; }
    const std::vector<std::string>& lobe_names() const override;
    std::optional<ScatterEvent> sample(const Vec3d& wi, double lambda_nm, const Vec2& position_um,
                                       Rng& rng) const override;
    bool can_evaluate() const override { return true; }
    double eval(const Vec3d& wi, const Vec3d& wo, double lambda_nm,
                std::span<double> per_lobe = {}) const override;
    double pdf(const Vec3d& wi, const Vec3d& wo, double lambda_nm) const override;

    // The paper's own evaluation: one RGB channel instead of a wavelength.
    double eval_rgb(const Vec3d& wi, const Vec3d& wo, RgbChannel channel,
                    std::span<double> per_lobe = {}) const;

    const Filip2024Parameters& parameters() const { return parameters_; }

private:
    std::array<double, 4> mixture_weights(double cos_theta_i, RgbChannel channel) const;
    double mixture_pdf(const std::array<double, 4>& weights, double cos_theta_i, double psi,
                       double mu) const;

    Filip2024Parameters parameters_;
    std::string label_;
    double sin_phi_a_, cos_phi_a_;  // of the highlight axis φa, for every evaluation
};

}  // namespace plumage::analysis
