#include "analysis/models/filip2024.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "common/constants.h"
#include "common/error.h"

namespace plumage::analysis {
namespace {

// Eq. 4: E = 1.1 − cos θi cos θo. The 0.1 keeps E > 0 at normal incidence and view.
constexpr double kElevationOffset = 1.1;
// Share of the cosine-weighted hemisphere in the sampling mixture, whatever the lobe estimates
// say: it covers every term, so the weight f |cos θo| / pdf stays below 10π max f.
constexpr double kDefensiveShare = 0.1;

double deg(double degrees) { return degrees * kPi / 180.0; }

// Into [−π, π]: IEEE remainder is exact, so a difference that is already in range is unchanged.
double wrap_angle(double a) { return std::remainder(a, kTwoPi); }

// The E^k density on cos θo ∈ [0, 1] (sampling component 3). With s = E/a = 1 − (b/a) μ,
// a = 1.1 and b = cos θi, the density is ∝ s^k. q = 1 − r^(k+1), r = 1 − b/a, is its
// normaliser up to (k+1) a/b; log1p and expm1 keep it exact as b → 0 (grazing light), where
// the density tends to uniform.
struct ElevationDensity {
    double b_over_a;
    double exponent;  // k
    double q;         // 1 − r^(k+1)

    ElevationDensity(double cos_theta_i, double k)
        : b_over_a(cos_theta_i / kElevationOffset),
          exponent(k),
          q(-std::expm1((k + 1.0) * std::log1p(-cos_theta_i / kElevationOffset))) {}

    bool uniform() const { return b_over_a < 1e-12; }

    double pdf(double mu) const {
        if (uniform()) return 1.0;
        const double s = 1.0 - b_over_a * mu;
        return (exponent + 1.0) * std::pow(s, exponent) * b_over_a / q;
    }

    double sample(double u) const {
        if (uniform()) return u;
        // s^(k+1) = 1 − (1 − u) q, so 1 − s = −expm1(log1p(−(1 − u) q) / (k + 1)).
        const double one_minus_s = -std::expm1(std::log1p(-(1.0 - u) * q) / (exponent + 1.0));
        return std::clamp(one_minus_s / b_over_a, 0.0, 1.0);
    }

    // Mean of E^k over cos θo uniform in [0, 1], for the mixture weights.
    double mean_elevation_power() const {
        const double a_k = std::pow(kElevationOffset, exponent);
        if (uniform()) return a_k;
        return a_k * q / ((exponent + 1.0) * b_over_a);
    }
};

// Densities of ψ = wrap(φi − φo) ∈ [−π, π] (|dψ/dφo| = 1, so they are densities of φo too).
double specular_azimuth_pdf(double psi) { return std::abs(psi) / (kPi * kPi); }

double retro_azimuth_pdf(double psi, double gamma) {
    const double eta = std::abs(wrap_angle(psi - kPi));
    return (gamma + 1.0) * std::pow(eta / kPi, gamma) / kTwoPi;
}

void require_lobe_span(std::span<double> per_lobe) {
    PLUMAGE_CHECK(per_lobe.empty() || per_lobe.size() == kFilip2024LobeCount,
                  fmt::format("per_lobe has {} entries; Filip 2024 has {} lobes", per_lobe.size(),
                              static_cast<int>(kFilip2024LobeCount)));
}

struct Preset {
    std::string_view name;
    double phi_a_deg;
    Rgb c_b, c_a, c_s, c_r;
    double alpha, beta, gamma, w, d_w;
};

// Table 1 of the paper, as printed.
// clang-format off
constexpr std::array<Preset, 4> kPresets = {{
    {"parrot",   90.0,  {0.155, 0.214, 0.290}, {0.390, 0.384, 0.416}, {0.206, 0.285, 0.387},
                        {0.107, 0.277, 0.446}, 3.0, 12.0, 4.0, 0.95, 0.40},
    {"rooster",  -20.0, {0.089, 0.198, 0.194}, {0.344, 0.413, 0.415}, {0.104, 0.190, 0.187},
                        {0.089, 0.198, 0.194}, 5.0, 12.0, 0.0, 0.85, 0.20},
    {"flamingo", -80.0, {0.701, 0.607, 0.535}, {0.891, 0.819, 0.768}, {0.961, 0.851, 0.771},
                        {0.779, 0.674, 0.595}, 5.0, 5.0, 0.0, 0.80, 0.40},
    {"stork",    -20.0, {0.792, 0.809, 0.812}, {0.874, 0.888, 0.888}, {0.422, 0.429, 0.429},
                        {0.792, 0.809, 0.812}, 5.0, 5.0, 0.0, 0.80, 0.60},
}};
constexpr std::array<std::string_view, 4> kPresetNames = {"parrot", "rooster", "flamingo", "stork"};
// clang-format on

}  // namespace

RgbChannel filip2024_channel(double lambda_nm) {
    if (!(lambda_nm >= kFilip2024MinWavelengthNm && lambda_nm <= kFilip2024MaxWavelengthNm)) {
        throw InputError(fmt::format(
            "Filip 2024 BRDF: wavelength = {} nm: expected a value in [{}, {}] nm (the model's "
            "RGB bands)",
            lambda_nm, kFilip2024MinWavelengthNm, kFilip2024MaxWavelengthNm));
    }
    if (lambda_nm < kFilip2024BlueGreenEdgeNm) return RgbChannel::kBlue;
    if (lambda_nm < kFilip2024GreenRedEdgeNm) return RgbChannel::kGreen;
    return RgbChannel::kRed;
}

double filip2024_band_centre_nm(RgbChannel channel) {
    switch (channel) {
        case RgbChannel::kBlue:
            return 0.5 * (kFilip2024MinWavelengthNm + kFilip2024BlueGreenEdgeNm);
        case RgbChannel::kGreen:
            return 0.5 * (kFilip2024BlueGreenEdgeNm + kFilip2024GreenRedEdgeNm);
        case RgbChannel::kRed:
            return 0.5 * (kFilip2024GreenRedEdgeNm + kFilip2024MaxWavelengthNm);
    }
    throw InvariantError("filip2024_band_centre_nm: unknown channel");
}

std::array<double, kFilip2024ParameterCount> to_vector(const Filip2024Parameters& p) {
    std::array<double, kFilip2024ParameterCount> v{};
    v[kFilipPhiA] = p.phi_a_rad;
    for (int c = 0; c < 3; ++c) {
        v[kFilipCbR + c] = p.c_b[c];
        v[kFilipCaR + c] = p.c_a[c];
        v[kFilipCsR + c] = p.c_s[c];
        v[kFilipCrR + c] = p.c_r[c];
    }
    v[kFilipAlpha] = p.alpha;
    v[kFilipBeta] = p.beta;
    v[kFilipGamma] = p.gamma;
    v[kFilipW] = p.w;
    v[kFilipDw] = p.d_w;
    v[kFilipThetaMax] = p.theta_max_rad;
    v[kFilipBrdfScale] = p.brdf_scale_per_sr;
    return v;
}

Filip2024Parameters from_vector(const std::array<double, kFilip2024ParameterCount>& v) {
    Filip2024Parameters p;
    p.phi_a_rad = v[kFilipPhiA];
    for (int c = 0; c < 3; ++c) {
        p.c_b[c] = v[kFilipCbR + c];
        p.c_a[c] = v[kFilipCaR + c];
        p.c_s[c] = v[kFilipCsR + c];
        p.c_r[c] = v[kFilipCrR + c];
    }
    p.alpha = v[kFilipAlpha];
    p.beta = v[kFilipBeta];
    p.gamma = v[kFilipGamma];
    p.w = v[kFilipW];
    p.d_w = v[kFilipDw];
    p.theta_max_rad = v[kFilipThetaMax];
    p.brdf_scale_per_sr = v[kFilipBrdfScale];
    return p;
}

void validate(const Filip2024Parameters& p) {
    const auto v = to_vector(p);
    for (int i = 0; i < kFilip2024ParameterCount; ++i) {
        const auto& info = kFilip2024ParameterTable[i];
        if (!(std::isfinite(v[i]) && v[i] >= info.min && v[i] <= info.max)) {
            const std::string unit = info.unit == "1" ? "" : fmt::format(" {}", info.unit);
            throw InputError(
                fmt::format("Filip 2024 BRDF: {} = {}{}: expected a finite value in [{}, {}]{}",
                            info.name, v[i], unit, info.min, info.max, unit));
        }
    }
}

Filip2024Parameters filip2024_preset(std::string_view name) {
    for (const auto& preset : kPresets) {
        if (preset.name != name) continue;
        Filip2024Parameters p;
        p.phi_a_rad = deg(preset.phi_a_deg);
        p.c_b = preset.c_b;
        p.c_a = preset.c_a;
        p.c_s = preset.c_s;
        p.c_r = preset.c_r;
        p.alpha = preset.alpha;
        p.beta = preset.beta;
        p.gamma = preset.gamma;
        p.w = preset.w;
        p.d_w = preset.d_w;
        p.theta_max_rad = deg(75.0);
        p.brdf_scale_per_sr = 1.0 / kPi;
        return p;
    }
    throw InputError(fmt::format("Filip 2024 BRDF: unknown preset '{}': expected one of {}", name,
                                 fmt::join(kPresetNames, ", ")));
}

std::span<const std::string_view> filip2024_preset_names() { return kPresetNames; }

// Eq. 2, read so that M is continuous (header: the printed cases and smoothstep disagree at both
// edges). The smoothstep is kept as printed, "2d" is 2 d_w, and the cases follow it: M = 0 below
// w − d_w, rising to 1 at w + d_w, so that M = 1 on the highlight line x = 1 (H ⟂ U) of Eq. 1.
// The clamp makes both cases exact: y = 0 gives 0, y = 1 gives 1.
double filip2024_mask(double x, double w, double d_w) {
    const double y = std::clamp((x - w + d_w) / (2.0 * d_w), 0.0, 1.0);
    return y * y * (3.0 - 2.0 * y);
}

// Eq. 5 with the difference wrapped: the true angular distance from δ, whatever branch the
// azimuths come from, over the printed 2π. Without the wrap D jumps where an azimuth crosses ±π
// and D(π) is not symmetric in (ωi, ωo).
double filip2024_azimuth_distance(double phi_i, double phi_o, double delta) {
    return std::abs(wrap_angle(phi_i - phi_o - delta)) / kTwoPi;
}

double patch_azimuth(const Vec3d& w) {
    if (w.x() == 0.0 && w.y() == 0.0) return 0.0;
    return std::atan2(w.y(), w.x());
}

// Every model evaluation and fit residual computes these, so they take one atan2 each instead
// of two atan2, two hypot and a remainder (7.2 → ≥ 10 M evaluations/s, bench/README.md):
//  - ψ = wrap(φi − φo) is the signed angle between the projections of ωo and ωi on the patch,
//    atan2(cross, dot), in [−π, π] like the wrapped difference; D(π) = |wrap(ψ − π)| / 2π is
//    (π − |ψ|) / 2π on that range. A direction along the normal has azimuth 0 (patch_azimuth),
//    so its projection reads as +x.
//  - |θi − θo| is the angle between (sin θ, cos θ) pairs: atan2(|sᵢcₒ − cᵢsₒ|, cᵢcₒ + sᵢsₒ),
//    exact near the pole as atan2(sin θ, cos θ) is.
Filip2024Geometry filip2024_geometry(const Vec3d& wi, const Vec3d& wo) {
    Filip2024Geometry g;
    g.half_vector = (wi + wo).normalized();
    g.elevation = kElevationOffset - wi.z() * wo.z();
    const bool i_on_pole = wi.x() == 0.0 && wi.y() == 0.0;
    const bool o_on_pole = wo.x() == 0.0 && wo.y() == 0.0;
    const double xi = i_on_pole ? 1.0 : wi.x(), yi = wi.y();
    const double xo = o_on_pole ? 1.0 : wo.x(), yo = wo.y();
    const double abs_psi = std::abs(std::atan2(xo * yi - yo * xi, xo * xi + yo * yi));
    g.d_specular = abs_psi / kTwoPi;
    g.d_retro = (kPi - abs_psi) / kTwoPi;
    const double si = std::sqrt(wi.x() * wi.x() + wi.y() * wi.y());
    const double so = std::sqrt(wo.x() * wo.x() + wo.y() * wo.y());
    g.polar_difference_rad =
        std::atan2(std::abs(si * wo.z() - wi.z() * so), wi.z() * wo.z() + si * so);
    return g;
}

double Filip2024Terms::total() const {
    double sum = 0.0;
    for (double v : lobes) sum += v;
    return sum;
}

namespace {

// x^y for the exponents of Eqs. 3–5 (γ, β). Whole exponents up to 16 (every preset's) by
// repeated squaring, a few times faster than pow and within a few ulp of it; others by pow.
double power(double x, double y) {
    if (y == 0.0) return 1.0;
    if (y > 0.0 && y <= 16.0 && y == std::floor(y)) {
        auto n = static_cast<unsigned>(y);
        double result = 1.0;
        while (true) {
            if (n & 1U) result *= x;
            n >>= 1U;
            if (n == 0U) return result;
            x *= x;
        }
    }
    return std::pow(x, y);
}

// Eq. 3 with sin φa and cos φa given: the Scatterer computes them once, not per evaluation.
Filip2024Terms terms_with_axis(const Filip2024Parameters& p, const Filip2024Geometry& g,
                               RgbChannel channel, double sin_phi_a, double cos_phi_a) {
    const int c = static_cast<int>(channel);
    const double h_dot_u = g.half_vector.x() * sin_phi_a + g.half_vector.y() * cos_phi_a;
    const double m = filip2024_mask(1.0 - std::abs(h_dot_u), p.w, p.d_w);
    // Eq. 6, clamped: beyond the captured range (|θi − θo| > θmax) the print goes negative.
    const double falloff = std::max(0.0, 1.0 - g.polar_difference_rad / p.theta_max_rad);
    const double s = p.brdf_scale_per_sr;
    Filip2024Terms t;
    t.mask = m;
    t.lobes[kBackgroundLobe] = s * (1.0 - m) * p.c_b[c];
    t.lobes[kAnisotropicHighlightLobe] = s * m * p.c_a[c];
    t.lobes[kNearSpecularLobe] = s * (1.0 - m) * p.c_s[c] * g.elevation * g.d_specular * falloff;
    t.lobes[kRetroreflectiveLobe] =
        s * (1.0 - m) * p.c_r[c] * g.elevation * power(g.d_retro, p.gamma) * falloff;
    t.lobes[kSpecularHighlightLobe] = s * m * p.alpha * power(g.elevation, p.beta) * g.d_specular;
    return t;
}

}  // namespace

Filip2024Terms filip2024_terms(const Filip2024Parameters& p, const Filip2024Geometry& g,
                               RgbChannel channel) {
    return terms_with_axis(p, g, channel, std::sin(p.phi_a_rad), std::cos(p.phi_a_rad));
}

Filip2024Brdf::Filip2024Brdf(const Filip2024Parameters& parameters, std::string label)
    : parameters_(parameters),
      label_(std::move(label)),
      sin_phi_a_(std::sin(parameters.phi_a_rad)),
      cos_phi_a_(std::cos(parameters.phi_a_rad)) {
    validate(parameters_);
}

const std::vector<std::string>& Filip2024Brdf::lobe_names() const {
    static const std::vector<std::string> names = {"background", "anisotropic_highlight",
                                                   "near_specular", "retroreflective",
                                                   "specular_highlight"};
    return names;
}

double Filip2024Brdf::eval_rgb(const Vec3d& wi, const Vec3d& wo, RgbChannel channel,
                               std::span<double> per_lobe) const {
    require_lobe_span(per_lobe);
    if (!(wi.z() > 0.0 && wo.z() > 0.0)) {
        std::fill(per_lobe.begin(), per_lobe.end(), 0.0);
        return 0.0;
    }
    const Filip2024Terms t =
        terms_with_axis(parameters_, filip2024_geometry(wi, wo), channel, sin_phi_a_, cos_phi_a_);
    if (!per_lobe.empty()) std::copy(t.lobes.begin(), t.lobes.end(), per_lobe.begin());
    return t.total();
}

double Filip2024Brdf::eval(const Vec3d& wi, const Vec3d& wo, double lambda_nm,
                           std::span<double> per_lobe) const {
    return eval_rgb(wi, wo, filip2024_channel(lambda_nm), per_lobe);
}

// Weights ∝ an upper bound of each term's directional albedo ∫ f cos θo dω at this ωi (M ≤ 1,
// F ≤ 1), using ∫ D(0) dφ = π/2, ∫ D(π)^γ dφ = 2π 2^−γ / (γ + 1), ∫₀¹ E μ dμ = a/2 − b/3 and,
// for the E^β term, half the mean of E^β as the mean of E^β μ. They only steer the variance:
// pdf() recomputes the same weights, so any positive choice is unbiased.
std::array<double, 4> Filip2024Brdf::mixture_weights(double cos_theta_i, RgbChannel channel) const {
    const auto& p = parameters_;
    const int c = static_cast<int>(channel);
    const double mean_e_mu = kElevationOffset / 2.0 - cos_theta_i / 3.0;
    const std::array<double, 4> albedo = {
        kPi * std::max(p.c_b[c], p.c_a[c]), p.c_s[c] * (kPi / 2.0) * mean_e_mu,
        p.c_r[c] * kTwoPi * std::pow(0.5, p.gamma) / (p.gamma + 1.0) * mean_e_mu,
        p.alpha * (kPi / 2.0) * 0.5 * ElevationDensity(cos_theta_i, p.beta).mean_elevation_power()};
    const double total = albedo[0] + albedo[1] + albedo[2] + albedo[3];
    if (!(total > 0.0)) return {1.0, 0.0, 0.0, 0.0};
    std::array<double, 4> weights{};
    for (int k = 0; k < 4; ++k) weights[k] = (1.0 - kDefensiveShare) * albedo[k] / total;
    weights[0] += kDefensiveShare;
    return weights;
}

double Filip2024Brdf::mixture_pdf(const std::array<double, 4>& weights, double cos_theta_i,
                                  double psi, double mu) const {
    const double cosine_mu = 2.0 * mu;
    double pdf = weights[0] * cosine_mu / kTwoPi;
    if (weights[1] > 0.0) pdf += weights[1] * cosine_mu * specular_azimuth_pdf(psi);
    if (weights[2] > 0.0) pdf += weights[2] * cosine_mu * retro_azimuth_pdf(psi, parameters_.gamma);
    if (weights[3] > 0.0) {
        pdf += weights[3] * ElevationDensity(cos_theta_i, parameters_.beta).pdf(mu) *
               specular_azimuth_pdf(psi);
    }
    return pdf;
}

double Filip2024Brdf::pdf(const Vec3d& wi, const Vec3d& wo, double lambda_nm) const {
    const RgbChannel channel = filip2024_channel(lambda_nm);
    if (!(wi.z() > 0.0 && wo.z() > 0.0)) return 0.0;
    const double psi = wrap_angle(patch_azimuth(wi) - patch_azimuth(wo));
    return mixture_pdf(mixture_weights(wi.z(), channel), wi.z(), psi, wo.z());
}

std::optional<ScatterEvent> Filip2024Brdf::sample(const Vec3d& wi, double lambda_nm,
                                                  const Vec2& position_um, Rng& rng) const {
    const RgbChannel channel = filip2024_channel(lambda_nm);
    if (!(wi.z() > 0.0)) return std::nullopt;
    const double cos_theta_i = wi.z();
    const auto weights = mixture_weights(cos_theta_i, channel);

    const double pick = rng.uniform();
    int component = 0;
    double cumulative = weights[0];
    while (component < 3 && pick >= cumulative) cumulative += weights[++component];
    const double u_mu = rng.uniform();
    const double u_phi = rng.uniform();

    const double mu = component == 3 ? ElevationDensity(cos_theta_i, parameters_.beta).sample(u_mu)
                                     : std::sqrt(u_mu);
    double psi = 0.0;
    if (component == 0) {
        psi = kPi * (2.0 * u_phi - 1.0);
    } else {
        // One uniform gives the sign (which half) and the magnitude (rescaled half).
        const double sign = u_phi < 0.5 ? -1.0 : 1.0;
        const double v = u_phi < 0.5 ? 2.0 * u_phi : 2.0 * u_phi - 1.0;
        if (component == 2) {
            // |η| = |ψ − π| ∝ |η|^γ: the distance from the mirror azimuth.
            psi = kPi + sign * kPi * std::pow(v, 1.0 / (parameters_.gamma + 1.0));
        } else {
            psi = sign * kPi * std::sqrt(v);
        }
    }
    // μ = 0 lies in the patch plane, where f |cos θo| = 0: the quantum carries nothing.
    if (!(mu > 0.0)) return std::nullopt;

    const double phi_o = patch_azimuth(wi) - psi;
    const double sin_theta_o = std::sqrt(std::max(0.0, 1.0 - mu * mu));
    const Vec3d wo(sin_theta_o * std::cos(phi_o), sin_theta_o * std::sin(phi_o), mu);

    const Filip2024Terms terms =
        terms_with_axis(parameters_, filip2024_geometry(wi, wo), channel, sin_phi_a_, cos_phi_a_);
    const double f = terms.total();
    // The density at the direction actually built (its azimuth re-derived from wo), so that
    // weight = f cos θo / pdf(ωi, ωo) holds to round-off.
    const double density =
        mixture_pdf(weights, cos_theta_i, wrap_angle(patch_azimuth(wi) - patch_azimuth(wo)), mu);
    PLUMAGE_CHECK(density > 0.0 && std::isfinite(density),
                  fmt::format("Filip 2024 sampling density {} at a sampled direction", density));

    // Lobe drawn with probability f_lobe / f: unbiased per-lobe tallies from one quantum.
    int lobe = kBackgroundLobe;
    if (f > 0.0) {
        const double target = rng.uniform() * f;
        double running = 0.0;
        for (lobe = 0; lobe < kFilip2024LobeCount - 1; ++lobe) {
            running += terms.lobes[lobe];
            if (target < running) break;
        }
    }
    return ScatterEvent{wo, f * mu / density, lobe, position_um};
}

}  // namespace plumage::analysis
