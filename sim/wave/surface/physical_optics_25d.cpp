// Physical optics in 2.5D (physical_optics_25d.h has the derivation).
#include "sim/wave/surface/physical_optics_25d.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <mutex>
#include <optional>
#include <vector>

#include <fmt/format.h>

#include "common/constants.h"
#include "common/error.h"

namespace plumage::sim::wave {
namespace {

std::uint64_t next_generation() {
    static std::atomic<std::uint64_t> counter{0};
    return ++counter;
}

}  // namespace

struct PhysicalOptics25d::Prepared {
    Vec3d wi;
    double lambda_nm;
    double cos_ei;
    std::vector<FarFieldKernel2d> kernels;  // TE and TM per realisation; σ_t is their mean
    // The sampler's density of θ_o (header, "Sampling"): per bin of kSamplerBins over (−π, π],
    // its probability and the cumulative sum; filled on the first sample() or pdf() call.
    mutable std::once_flag table_once;
    mutable std::vector<double> bin_probability, cumulative;
};

namespace {

constexpr int kSamplerBins = 1440;            // 0.25° over the circle
constexpr double kSamplerUniformShare = 0.1;  // of θ_o drawn uniformly: every θ_o has density

double wrap_angle(double theta) {
    while (theta > kPi) theta -= 2.0 * kPi;
    while (theta <= -kPi) theta += 2.0 * kPi;
    return theta;
}

// The elevations ε_o at which the half vector of ω_i and ω_o(θ_o, ε_o) has h_y = target: h_y(ε)
// need not be monotone (towards ω_o ≈ −ω_i it turns), so the roots are bracketed on a grid of
// kRootBrackets and each refined by bisection.
constexpr int kRootBrackets = 64;

Vec3d direction_of(double theta_o, double eps) {
    return {std::cos(eps) * std::sin(theta_o), std::sin(eps), std::cos(eps) * std::cos(theta_o)};
}

double half_vector_y(const Vec3d& wi, double theta_o, double eps) {
    const Vec3d s = wi + direction_of(theta_o, eps);
    const double sn = s.norm();
    return sn > 1e-12 ? s.y() / sn : 0.0;
}

std::vector<double> elevations_with(const Vec3d& wi, double theta_o, double target) {
    std::vector<double> roots;
    const double lo = -0.5 * kPi + 1e-9, hi = 0.5 * kPi - 1e-9;
    double a = lo, fa = half_vector_y(wi, theta_o, a) - target;
    for (int m = 1; m <= kRootBrackets; ++m) {
        const double b = lo + (hi - lo) * m / kRootBrackets;
        const double fb = half_vector_y(wi, theta_o, b) - target;
        if ((fa <= 0.0) != (fb <= 0.0)) {
            double x0 = a, x1 = b;
            const bool rising = fa <= 0.0;
            for (int k = 0; k < 50; ++k) {
                const double mid = 0.5 * (x0 + x1);
                ((half_vector_y(wi, theta_o, mid) - target <= 0.0) == rising ? x0 : x1) = mid;
            }
            roots.push_back(0.5 * (x0 + x1));
        }
        a = b;
        fa = fb;
    }
    return roots;
}

// Where ω_o lies in the tilt band: the half vector's longitudinal sine h_y and |∂θ_h/∂ε_o| at
// fixed θ_o (header, 2. and 3.); nothing outside the band or at a degenerate ω_o.
struct TiltBand {
    double hy, dtheta_h;
};

std::optional<TiltBand> in_tilt_band(const Vec3d& wi, const Vec3d& wo, double theta_d) {
    const double cos_eo = std::hypot(wo.x(), wo.z());
    if (cos_eo < 1e-9) return std::nullopt;
    const Vec3d s = wi + wo;
    const double sn = s.norm();
    if (sn < 1e-12) return std::nullopt;
    const double hy = std::clamp(s.y() / sn, -1.0, 1.0);
    if (std::abs(std::asin(hy)) > theta_d) return std::nullopt;
    // ∂θ_h/∂ε_o: e = ∂ω_o/∂ε_o at fixed θ_o; s·e = ω_i·e since ω_o·e = 0.
    const Vec3d e(-wo.y() * wo.x() / cos_eo, cos_eo, -wo.y() * wo.z() / cos_eo);
    const double dhy = (e.y() * sn - s.y() * wi.dot(e) / sn) / (sn * sn);
    return TiltBand{hy, std::abs(dhy) / std::sqrt(std::max(1e-300, 1.0 - hy * hy))};
}

int bin_of(double theta) {
    const int b =
        static_cast<int>(std::floor((wrap_angle(theta) + kPi) / (2.0 * kPi) * kSamplerBins));
    return std::clamp(b, 0, kSamplerBins - 1);
}

}  // namespace

namespace {

constexpr const char* kWhat = "physical optics 2.5D";

}  // namespace

PhysicalOptics25d::PhysicalOptics25d(PhysicalOptics25dParams params)
    : params_(std::move(params)), generation_(next_generation()) {
    if (!std::isfinite(params_.theta_d) || !(params_.theta_d > 0.0) || params_.theta_d > kPi / 4.0)
        throw InputError(
            fmt::format("{}: theta_d = {:.4g} rad must be in (0, π/4] (θ_d = 0 is "
                        "a straight extrusion, a δ on the cone: no f to evaluate)",
                        kWhat, params_.theta_d));
    if (!std::isfinite(params_.row.spacing_um) || !(params_.row.spacing_um > 0.0))
        throw InputError(
            fmt::format("{}: row spacing {:.4g} µm must be > 0 (it sets the patch "
                        "width count · spacing)",
                        kWhat, params_.row.spacing_um));
    if (!std::isfinite(params_.step_um) || params_.step_um < 0.0)
        throw InputError(
            fmt::format("{}: step_um = {:.4g} must be finite and >= 0", kWhat, params_.step_um));
    place_row(params_.row, SampledCrossSection2d{}, 0);  // validates the row's fields
}

const std::vector<std::string>& PhysicalOptics25d::lobe_names() const {
    static const std::vector<std::string> names = {"R"};
    return names;
}

double PhysicalOptics25d::patch_width_um() const {
    return params_.row.count * params_.row.spacing_um;
}

// The last (ω_i, λ) and θ_o asked on this thread, for this object: instruments sweep ω_o at
// fixed ω_i, each thread its own cells. Per thread, not shared behind a lock: a shared entry
// made threads wait for each other and evict each other's work. generation_ tells apart objects
// that reuse an address.
struct PhysicalOptics25d::ThreadCache {
    const PhysicalOptics25d* owner = nullptr;
    std::uint64_t generation = 0;
    Vec3d wi = Vec3d::Zero();
    double lambda_nm = -1.0;
    std::shared_ptr<const Prepared> prepared;
    double theta_o = 0.0, sigma = -1.0;
};

PhysicalOptics25d::ThreadCache& PhysicalOptics25d::cache() const {
    thread_local ThreadCache cache;
    if (cache.owner != this || cache.generation != generation_) {
        cache = ThreadCache{};
        cache.owner = this;
        cache.generation = generation_;
    }
    return cache;
}

std::shared_ptr<const PhysicalOptics25d::Prepared> PhysicalOptics25d::prepare(
    const Vec3d& wi, double lambda_nm) const {
    ThreadCache& c = cache();
    if (c.prepared && c.wi == wi && c.lambda_nm == lambda_nm) return c.prepared;
    auto prepared = std::make_shared<Prepared>();
    prepared->wi = wi;
    prepared->lambda_nm = lambda_nm;
    prepared->cos_ei = std::hypot(wi.x(), wi.z());
    const double theta_i = std::atan2(wi.x(), wi.z());
    const double step = params_.step_um > 0.0 ? params_.step_um : 1e-3 * lambda_nm / 10.0;
    const SampledCrossSection2d cell = sample_cross_section(params_.row.cell, step);
    const bool jittered =
        params_.row.jitter_position_um > 0.0 || params_.row.jitter_rotation_rad > 0.0;
    const int realisations = jittered ? params_.row.realisations : 1;
    for (int m = 0; m < realisations; ++m) {
        const SampledCrossSection2d placed = place_row(params_.row, cell, m);
        for (Polarisation2d pol : {Polarisation2d::te, Polarisation2d::tm})
            prepared->kernels.push_back(
                prepare_far_field(params_.row.cell, placed,
                                  {lambda_nm, theta_i, pol, std::min(1.0, prepared->cos_ei)},
                                  FarFieldPart::reflected));
    }
    c.wi = wi;
    c.lambda_nm = lambda_nm;
    c.prepared = prepared;
    c.sigma = -1.0;
    return prepared;
}

double PhysicalOptics25d::sigma_t(const Prepared& prepared, double theta_o) const {
    ThreadCache& c = cache();
    const bool current = c.prepared.get() == &prepared;
    if (current && c.sigma >= 0.0 && std::abs(c.theta_o - theta_o) < 1e-12) return c.sigma;
    double sum = 0.0;
    for (const FarFieldKernel2d& kernel : prepared.kernels)
        sum += kernel.k / (8.0 * kPi) * std::norm(far_field_at(kernel, theta_o));
    const double sigma = sum / static_cast<double>(prepared.kernels.size());
    if (current) {
        c.theta_o = theta_o;
        c.sigma = sigma;
    }
    return sigma;
}

double PhysicalOptics25d::eval(const Vec3d& wi, const Vec3d& wo, double lambda_nm,
                               std::span<double> per_lobe) const {
    if (!per_lobe.empty()) std::fill(per_lobe.begin(), per_lobe.end(), 0.0);
    const double cos_ei = std::hypot(wi.x(), wi.z()), cos_eo = std::hypot(wo.x(), wo.z());
    if (cos_ei < 1e-9 || cos_eo < 1e-9 || std::abs(wi.z()) < 1e-12 || std::abs(wo.z()) < 1e-12)
        return 0.0;
    const std::optional<TiltBand> band = in_tilt_band(wi, wo, params_.theta_d);
    if (!band) return 0.0;
    const double dtheta_h = band->dtheta_h;
    const std::shared_ptr<const Prepared> prepared = prepare(wi, lambda_nm);
    const double sigma = sigma_t(*prepared, std::atan2(wo.x(), wo.z()));
    const double f = cos_ei * sigma * dtheta_h / (2.0 * params_.theta_d) /
                     (std::abs(wi.z()) * patch_width_um() * std::abs(wo.z()) * cos_eo);
    if (!per_lobe.empty()) per_lobe[0] = f;
    return f;
}

const PhysicalOptics25d::Prepared& PhysicalOptics25d::sampler_table(
    const std::shared_ptr<const Prepared>& prepared) const {
    std::call_once(prepared->table_once, [&] {
        std::vector<double> sigma(kSamplerBins);
        double total = 0.0;
        for (int b = 0; b < kSamplerBins; ++b) {
            sigma[static_cast<std::size_t>(b)] =
                sigma_t(*prepared, -kPi + (b + 0.5) * 2.0 * kPi / kSamplerBins);
            total += sigma[static_cast<std::size_t>(b)];
        }
        prepared->bin_probability.resize(kSamplerBins);
        prepared->cumulative.resize(kSamplerBins);
        double running = 0.0;
        for (int b = 0; b < kSamplerBins; ++b) {
            const double lobe = total > 0.0 ? sigma[static_cast<std::size_t>(b)] / total : 0.0;
            const double p =
                (1.0 - kSamplerUniformShare) * lobe + kSamplerUniformShare / kSamplerBins;
            prepared->bin_probability[static_cast<std::size_t>(b)] = p;
            running += p;
            prepared->cumulative[static_cast<std::size_t>(b)] = running;
        }
    });
    return *prepared;
}

// The density over solid angle of the sampler's ω_o (header, "Sampling"): p(θ_o) p(θ_h)
// |∂θ_h/∂ε_o| / (n cos ε_o), zero outside the tilt band; n the elevations that share (θ_o, θ_h),
// of which sample() picks one at random. sample() knows n; pdf() counts it.
double PhysicalOptics25d::density(const Vec3d& wi, const Vec3d& wo, double lambda_nm,
                                  std::size_t roots) const {
    const std::optional<TiltBand> band = in_tilt_band(wi, wo, params_.theta_d);
    if (!band) return 0.0;
    const double cos_eo = std::hypot(wo.x(), wo.z());
    const Prepared& table = sampler_table(prepare(wi, lambda_nm));
    const double theta_o = std::atan2(wo.x(), wo.z());
    const double p_theta = table.bin_probability[static_cast<std::size_t>(bin_of(theta_o))] *
                           kSamplerBins / (2.0 * kPi);
    const double n = static_cast<double>(std::max<std::size_t>(1, roots));
    return p_theta * band->dtheta_h / (2.0 * params_.theta_d) / cos_eo / n;
}

double PhysicalOptics25d::pdf(const Vec3d& wi, const Vec3d& wo, double lambda_nm) const {
    const std::optional<TiltBand> band = in_tilt_band(wi, wo, params_.theta_d);
    if (!band) return 0.0;
    return density(wi, wo, lambda_nm,
                   elevations_with(wi, std::atan2(wo.x(), wo.z()), band->hy).size());
}

std::optional<ScatterEvent> PhysicalOptics25d::sample(const Vec3d& wi, double lambda_nm,
                                                      const Vec2& position_um, Rng& rng) const {
    // θ_o from the tabulated σ_t (with a uniform share), θ_h uniform over the tilt band, and
    // ε_o one of the elevations where the half vector's longitudinal angle is θ_h.
    const Prepared& table = sampler_table(prepare(wi, lambda_nm));
    const double u = rng.uniform() * table.cumulative.back();
    const auto it = std::upper_bound(table.cumulative.begin(), table.cumulative.end(), u);
    const int b = std::min(kSamplerBins - 1, static_cast<int>(it - table.cumulative.begin()));
    const double theta_o = -kPi + (b + rng.uniform()) * 2.0 * kPi / kSamplerBins;
    const double target = std::sin(params_.theta_d * (2.0 * rng.uniform() - 1.0));
    const std::vector<double> roots = elevations_with(wi, theta_o, target);
    if (roots.empty()) return std::nullopt;
    const auto pick =
        std::min(roots.size() - 1,
                 static_cast<std::size_t>(rng.uniform() * static_cast<double>(roots.size())));
    const Vec3d wo = direction_of(theta_o, roots[pick]);
    const double p = density(wi, wo, lambda_nm, roots.size());
    if (!(p > 0.0)) return std::nullopt;
    const double weight = eval(wi, wo, lambda_nm) * std::abs(wo.z()) / p;
    if (!(weight > 0.0)) return std::nullopt;
    return ScatterEvent{wo, weight, 0, position_um};
}

double PhysicalOptics25d::reflected_fraction_2d(const Vec3d& wi, double lambda_nm,
                                                int angles) const {
    const std::shared_ptr<const Prepared> prepared = prepare(wi, lambda_nm);
    double sum = 0.0;
    for (int m = 0; m < angles; ++m) {
        const double theta = -kPi + 2.0 * kPi * (m + 1) / angles;
        double s = 0.0;
        for (const FarFieldKernel2d& kernel : prepared->kernels)
            s += kernel.k / (8.0 * kPi) * std::norm(far_field_at(kernel, theta));
        sum += s / static_cast<double>(prepared->kernels.size());
    }
    return prepared->cos_ei * sum * 2.0 * kPi / angles / (std::abs(wi.z()) * patch_width_um());
}

}  // namespace plumage::sim::wave
