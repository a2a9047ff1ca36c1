#include "analysis/models/fibre_baseline.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <string_view>

#include <fmt/format.h>

#include "analysis/metrics/statistics.h"
#include "common/constants.h"
#include "common/error.h"
#include "common/require.h"
#include "sim/optics/fresnel.h"

namespace plumage::analysis {
namespace {

// log √(2π)
constexpr double kLogSqrtTwoPi = 0.91893853320467274178;
// Incident directions closer than this (in cos θ) to the fibre axis are treated at this cosine:
// the cross-section sees them edge-on and Bravais' index diverges.
constexpr double kMinimumCosTheta = 1e-6;

// Upper tail Q(x) = 1 − Φ(x), accurate in both tails.
double upper_tail(double x) { return 0.5 * std::erfc(x / kSqrt2); }

double wrap(double angle) { return std::remainder(angle, kTwoPi); }  // into [−π, π]

}  // namespace

double FibreFrame::azimuth(const Vec3d& w) const { return std::atan2(w.dot(side), w.dot(up)); }

Vec3d FibreFrame::direction(double theta, double psi) const {
    const double c = std::cos(theta);
    return std::sin(theta) * axis + c * (std::cos(psi) * up + std::sin(psi) * side);
}

LongitudinalLobe::LongitudinalLobe(double theta_i, double alpha, double beta)
    : mean_(2.0 * alpha - theta_i), sigma_(2.0 * beta) {
    a_ = (-0.5 * kPi - mean_) / sigma_;
    b_ = (0.5 * kPi - mean_) / sigma_;
    // Φ(b) − Φ(a) from the tail that keeps its digits.
    double mass;
    if (a_ > 0.0)
        mass = upper_tail(a_) - upper_tail(b_);
    else if (b_ < 0.0)
        mass = upper_tail(-b_) - upper_tail(-a_);
    else
        mass = 1.0 - upper_tail(b_) - upper_tail(-a_);
    PLUMAGE_CHECK(
        mass > 0.0 && std::isfinite(mass),
        fmt::format("longitudinal lobe mass {} (mean {}, sigma {})", mass, mean_, sigma_));
    log_norm_ = std::log(sigma_) + kLogSqrtTwoPi + std::log(mass);
}

double LongitudinalLobe::density(double theta_o) const {
    if (theta_o < -0.5 * kPi || theta_o > 0.5 * kPi) return 0.0;
    const double z = (theta_o - mean_) / sigma_;
    return std::exp(-0.5 * z * z - log_norm_);
}

double LongitudinalLobe::sample(Rng& rng) const {
    // Far tails: Robert (1995) exponential proposal with rate λ = (a + √(a² + 4))/2, accepted
    // with probability exp(−(z − λ)²/2): exact, about one draw per sample for a >= 5.
    auto tail = [&rng](double lo, double hi) {
        const double rate = 0.5 * (lo + std::sqrt(lo * lo + 4.0));
        for (;;) {
            const double z = lo - std::log1p(-rng.uniform()) / rate;
            if (z > hi) continue;
            if (rng.uniform() <= std::exp(-0.5 * (z - rate) * (z - rate))) return z;
        }
    };
    double z;
    if (a_ >= 5.0) {
        z = tail(a_, b_);
    } else if (b_ <= -5.0) {
        z = -tail(-b_, -a_);
    } else {
        const double u = rng.uniform();
        if (a_ > 0.0) {
            const double qa = upper_tail(a_), qb = upper_tail(b_);
            z = -normal_quantile(qa - u * (qa - qb));
        } else {
            const double pa = upper_tail(-a_), pb = upper_tail(-b_);
            z = normal_quantile(pa + u * (pb - pa));
        }
        z = std::clamp(z, a_, b_);
    }
    return std::clamp(mean_ + sigma_ * z, -0.5 * kPi, 0.5 * kPi);
}

std::array<LobeShape, 3> marschner_lobe_shapes(double alpha_r, double beta_r) {
    return {LobeShape{alpha_r, beta_r}, LobeShape{-0.5 * alpha_r, 0.5 * beta_r},
            LobeShape{-1.5 * alpha_r, 2.0 * beta_r}};
}

void AzimuthalTable::reset() {
    value_.fill(0.0);
    cdf_.fill(0.0);
    mass_ = 0.0;
}

void AzimuthalTable::deposit(double psi, double mass) {
    // Bin centres at −π + (i + ½) Δ: split between the two centres around ψ.
    const double x = (wrap(psi) + kPi) / bin_width() - 0.5;
    const double lower = std::floor(x);
    const double frac = x - lower;
    const int i0 = ((static_cast<int>(lower) % kBins) + kBins) % kBins;
    value_[i0] += mass * (1.0 - frac);
    value_[(i0 + 1) % kBins] += mass * frac;
}

void AzimuthalTable::smooth(double roughness_rad) {
    const double width = bin_width();
    const int half = std::min(kBins / 2, static_cast<int>(std::ceil(4.0 * roughness_rad / width)));
    std::vector<double> kernel(2 * half + 1);
    double sum = 0.0;
    for (int j = -half; j <= half; ++j) {
        const double x = j * width / roughness_rad;
        kernel[j + half] = std::exp(-0.5 * x * x);
        sum += kernel[j + half];
    }
    for (double& k : kernel) k /= sum;  // discrete normalisation: the convolution keeps the mass
    std::array<double, kBins> out{};
    for (int i = 0; i < kBins; ++i) {
        if (value_[i] == 0.0) continue;
        for (int j = -half; j <= half; ++j)
            out[((i + j) % kBins + kBins) % kBins] += value_[i] * kernel[j + half];
    }
    value_ = out;
    double running = 0.0;
    for (int i = 0; i < kBins; ++i) {
        running += value_[i];
        cdf_[i] = running;
    }
    mass_ = running;
}

double AzimuthalTable::density(double psi) const {
    const int bin = std::clamp(static_cast<int>((wrap(psi) + kPi) / bin_width()), 0, kBins - 1);
    return value_[bin] / bin_width();
}

double AzimuthalTable::sample(double u) const {
    const double target = u * mass_;
    int bin = static_cast<int>(std::upper_bound(cdf_.begin(), cdf_.end(), target) - cdf_.begin());
    if (bin >= kBins) {  // round-off at u → 1: the last bin with mass
        bin = kBins - 1;
        while (bin > 0 && value_[bin] == 0.0) --bin;
    }
    const double before = bin > 0 ? cdf_[bin - 1] : 0.0;
    const double frac =
        value_[bin] > 0.0 ? std::clamp((target - before) / value_[bin], 0.0, 1.0) : 0.5;
    return -kPi + (bin + frac) * bin_width();
}

void circular_fibre_azimuthal(double eta, double absorption_per_um, double diameter_um,
                              double sin_theta_i, double azimuthal_roughness_rad, int offsets,
                              FibreAzimuthalScattering& out) {
    if (offsets < 16)
        throw InputError(fmt::format("circular fibre: offsets = {}: expected >= 16", offsets));
    for (auto& lobe : out.lobes) lobe.reset();
    out.medulla = 0.0;
    const double s = std::clamp(sin_theta_i, -1.0, 1.0);
    const double cos_theta = std::max(kMinimumCosTheta, std::sqrt(1.0 - s * s));
    const double eta_projected = std::sqrt(eta * eta - s * s) / cos_theta;  // Bravais
    const double sin_theta_t = s / eta;
    const double cos_theta_t = std::sqrt(1.0 - sin_theta_t * sin_theta_t);
    // Offsets h = sin γ with γ at the midpoints of `offsets` equal steps of (−π/2, π/2), weight
    // cos γ: the quadrature of ½ ∫ dh.
    const double step = kPi / offsets;
    double weight_sum = 0.0;
    for (int k = 0; k < offsets; ++k) weight_sum += std::cos(-0.5 * kPi + (k + 0.5) * step);
    for (int k = 0; k < offsets; ++k) {
        const double gamma = -0.5 * kPi + (k + 0.5) * step;
        const double w = std::cos(gamma) / weight_sum;
        const double gamma_t = std::asin(std::sin(gamma) / eta_projected);
        const double fresnel = optics::fresnel_intensities_unpolarised(
                                   1.0, eta, std::clamp(cos_theta * std::cos(gamma), 0.0, 1.0))
                                   .reflectance;
        const double transmittance =
            std::exp(-absorption_per_um * diameter_um * std::cos(gamma_t) / cos_theta_t);
        const double enter = (1.0 - fresnel) * (1.0 - fresnel);
        out.lobes[kFibreR].deposit(-2.0 * gamma, w * fresnel);
        out.lobes[kFibreTT].deposit(2.0 * gamma_t - 2.0 * gamma + kPi, w * enter * transmittance);
        out.lobes[kFibreTRT].deposit(4.0 * gamma_t - 2.0 * gamma + 2.0 * kPi,
                                     w * enter * fresnel * transmittance * transmittance);
    }
    for (auto& lobe : out.lobes) lobe.smooth(azimuthal_roughness_rad);
}

// ---------------------------------------------------------------------------------------------

namespace {

// The name that prefixes this file's input errors.
constexpr std::string_view kWhat = "fibre baseline";

void validate(const FibreBaselineParams& p) {
    auto in = [](double v, double lo, double hi) { return std::isfinite(v) && v >= lo && v <= hi; };
    require(in(p.eta, 1.01, 3.0), kWhat, "eta", p.eta, "a value in [1.01, 3]");
    require(in(p.absorption_per_um, 0.0, 10.0), kWhat, "absorption_per_um", p.absorption_per_um,
            "a value in [0, 10] (1/um)");
    require(std::isfinite(p.diameter_um) && p.diameter_um > 0.0 && p.diameter_um <= 1e4, kWhat,
            "diameter_um", p.diameter_um, "a value in (0, 10000] (um)");
    require(in(p.alpha_r_rad, -0.35, 0.35), kWhat, "alpha_r_rad", p.alpha_r_rad,
            "a value in [-0.35, 0.35] (rad)");
    require(in(p.beta_r_rad, 0.01, 0.5), kWhat, "beta_r_rad", p.beta_r_rad,
            "a value in [0.01, 0.5] (rad)");
    require(in(p.azimuthal_roughness_rad, 0.03, 1.5), kWhat, "azimuthal_roughness_rad",
            p.azimuthal_roughness_rad, "a value in [0.03, 1.5] (rad)");
    require(p.offsets >= 16 && p.offsets <= 65536, kWhat, "offsets", p.offsets,
            "an integer in [16, 65536]");
}

void require_wavelength(double lambda_nm) {
    if (!(std::isfinite(lambda_nm) && lambda_nm > 0.0)) {
        throw InputError(fmt::format(
            "fibre baseline: wavelength = {} nm: expected a finite value > 0", lambda_nm));
    }
}

}  // namespace

struct FibreBaselineBsdf::State {
    const FibreBaselineBsdf* owner = nullptr;
    std::uint64_t generation = 0;
    double sin_theta_i = 2.0;  // impossible: the first call computes
    double psi_i = 0.0;
    std::array<LongitudinalLobe, 3> longitudinal;
    FibreAzimuthalScattering azimuthal;
};

FibreBaselineBsdf::FibreBaselineBsdf(const FibreBaselineParams& params) : params_(params) {
    validate(params_);
    static std::atomic<std::uint64_t> counter{0};
    generation_ = ++counter;
}

const std::vector<std::string>& FibreBaselineBsdf::lobe_names() const {
    static const std::vector<std::string> names = {"R", "TT", "TRT"};
    return names;
}

const FibreFrame& FibreBaselineBsdf::frame() {
    static const FibreFrame f{Vec3d::UnitX(), Vec3d::UnitZ(), Vec3d::UnitY()};
    return f;
}

const FibreBaselineBsdf::State& FibreBaselineBsdf::state_for(const Vec3d& wi) const {
    thread_local State state;
    const double s = std::clamp(frame().sin_theta(wi), -1.0, 1.0);
    state.psi_i = frame().azimuth(wi);
    if (state.owner != this || state.generation != generation_ || state.sin_theta_i != s) {
        const double theta_i = std::asin(s);
        const auto shapes = marschner_lobe_shapes(params_.alpha_r_rad, params_.beta_r_rad);
        for (int p = 0; p < 3; ++p)
            state.longitudinal[p] = LongitudinalLobe(theta_i, shapes[p].alpha, shapes[p].beta);
        circular_fibre_azimuthal(params_.eta, params_.absorption_per_um, params_.diameter_um, s,
                                 params_.azimuthal_roughness_rad, params_.offsets, state.azimuthal);
        state.owner = this;
        state.generation = generation_;
        state.sin_theta_i = s;
    }
    return state;
}

double FibreBaselineBsdf::density(const State& s, const Vec3d& wo,
                                  std::span<double> per_lobe) const {
    const double sin_o = std::clamp(frame().sin_theta(wo), -1.0, 1.0);
    const double cos_o = std::sqrt(1.0 - sin_o * sin_o);
    if (!(cos_o > 0.0)) return 0.0;  // along the axis: a set of measure zero
    const double theta_o = std::asin(sin_o);
    const double phi = frame().azimuth(wo) - s.psi_i;
    double total = 0.0;
    for (int p = 0; p < 3; ++p) {
        const double v =
            s.longitudinal[p].density(theta_o) * s.azimuthal.lobes[p].density(phi) / cos_o;
        if (!per_lobe.empty()) per_lobe[p] = v;
        total += v;
    }
    return total;
}

double FibreBaselineBsdf::eval(const Vec3d& wi, const Vec3d& wo, double lambda_nm,
                               std::span<double> per_lobe) const {
    require_wavelength(lambda_nm);
    PLUMAGE_CHECK(
        per_lobe.empty() || per_lobe.size() == 3,
        fmt::format("per_lobe has {} entries; the fibre baseline has 3 lobes", per_lobe.size()));
    const double cos_o = std::abs(wo.z());
    if (!(cos_o > 0.0)) {
        std::fill(per_lobe.begin(), per_lobe.end(), 0.0);
        return 0.0;
    }
    const double f = density(state_for(wi), wo, per_lobe) / cos_o;
    for (double& v : per_lobe) v /= cos_o;
    return f;
}

double FibreBaselineBsdf::pdf(const Vec3d& wi, const Vec3d& wo, double lambda_nm) const {
    require_wavelength(lambda_nm);
    if (!(std::abs(wo.z()) > 0.0)) return 0.0;
    return density(state_for(wi), wo, {});
}

std::array<double, 3> FibreBaselineBsdf::lobe_albedos(const Vec3d& wi) const {
    const State& s = state_for(wi);
    return {s.azimuthal.lobes[0].mass(), s.azimuthal.lobes[1].mass(), s.azimuthal.lobes[2].mass()};
}

std::optional<ScatterEvent> FibreBaselineBsdf::sample(const Vec3d& wi, double lambda_nm,
                                                      const Vec2& position_um, Rng& rng) const {
    require_wavelength(lambda_nm);
    const State& s = state_for(wi);
    // Analog play: lobe p with probability Ā_p, absorbed (or lost beyond TRT) otherwise.
    double u = rng.uniform();
    int lobe = -1;
    for (int p = 0; p < 3; ++p) {
        const double m = s.azimuthal.lobes[p].mass();
        if (u < m) {
            lobe = p;
            break;
        }
        u -= m;
    }
    if (lobe < 0) return std::nullopt;
    const double theta_o = s.longitudinal[lobe].sample(rng);
    const double psi_o = s.psi_i + s.azimuthal.lobes[lobe].sample(rng.uniform());
    const Vec3d wo = frame().direction(theta_o, psi_o).normalized();
    if (!(std::abs(wo.z()) > 0.0) || !(std::abs(frame().sin_theta(wo)) < 1.0))
        return std::nullopt;  // measure zero
    return ScatterEvent{wo, 1.0, lobe, position_um};
}

}  // namespace plumage::analysis
