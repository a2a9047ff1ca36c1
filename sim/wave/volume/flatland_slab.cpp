// Flatland slab Monte Carlo and its closed forms (conventions and parameter table in the
// header).
#include "sim/wave/volume/flatland_slab.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <thread>

#include <fmt/format.h>

#include "common/constants.h"
#include "common/error.h"
#include "common/seed.h"
#include "sim/optics/fresnel.h"
#include "sim/scatterer/random.h"

namespace plumage::sim::wave {
namespace {

constexpr std::uint64_t kBlockPaths = 4096;  // the unit of work; fixed, so sums are too

// p(θ) on [0, π], piecewise linear between the table's points, normalised to
// ∫_{−π}^{π} p dθ = 1; sampled by inverting its (piecewise quadratic) CDF.
class PhaseSampler {
public:
    explicit PhaseSampler(const FlatlandSlab& slab) : theta_(slab.theta_rad) {
        const auto n = theta_.size();
        cdf_.assign(n, 0.0);
        for (std::size_t i = 0; i + 1 < n; ++i) {
            cdf_[i + 1] = cdf_[i] + 0.5 * (slab.phase_per_rad[i] + slab.phase_per_rad[i + 1]) *
                                        (theta_[i + 1] - theta_[i]);
        }
        const double half_total = cdf_.back();
        p_.resize(n);
        for (std::size_t i = 0; i < n; ++i) p_[i] = slab.phase_per_rad[i] / (2.0 * half_total);
        for (double& c : cdf_) c /= half_total;  // CDF of |θ| on [0, π], from 0 to 1
    }
    // |θ| for a uniform ξ in [0, 1).
    double sample(double xi) const {
        const auto upper = std::upper_bound(cdf_.begin(), cdf_.end(), xi);
        std::size_t i = static_cast<std::size_t>(upper - cdf_.begin());
        i = std::clamp<std::size_t>(i, 1, cdf_.size() - 1) - 1;
        const double width = theta_[i + 1] - theta_[i];
        // Mass in [θ_i, θ_i + t] of the half-range density 2p: 2(a t + (b − a) t²/(2Δ)) = r.
        const double a = 2.0 * p_[i], b = 2.0 * p_[i + 1];
        const double r = xi - cdf_[i];
        const double disc = std::max(0.0, a * a + 2.0 * (b - a) * r / width);
        const double denom = a + std::sqrt(disc);
        const double t = denom > 0.0 ? 2.0 * r / denom : 0.0;
        return theta_[i] + std::min(t, width);
    }
    // p(θ) (normalised) at θ ∈ [0, π].
    double density(double theta) const {
        const auto upper = std::upper_bound(theta_.begin(), theta_.end(), theta);
        std::size_t i = static_cast<std::size_t>(upper - theta_.begin());
        i = std::clamp<std::size_t>(i, 1, theta_.size() - 1) - 1;
        const double w = (theta - theta_[i]) / (theta_[i + 1] - theta_[i]);
        return (1.0 - w) * p_[i] + w * p_[i + 1];
    }

private:
    std::vector<double> theta_, p_, cdf_;
};

void require_slab(const FlatlandSlab& slab) {
    constexpr const char* kWhat = "flatland slab";
    if (!(std::isfinite(slab.thickness_um) && slab.thickness_um > 0.0)) {
        throw InputError(fmt::format("{}: thickness_um = {}: expected a finite thickness > 0",
                                     kWhat, slab.thickness_um));
    }
    if (!(std::isfinite(slab.n_eff) && slab.n_eff >= 1.0 && slab.n_eff <= 10.0)) {
        throw InputError(
            fmt::format("{}: n_eff = {}: expected a real index in [1, 10]", kWhat, slab.n_eff));
    }
    if (!(std::isfinite(slab.mu_s_per_um) && slab.mu_s_per_um >= 0.0 &&
          slab.mu_s_per_um * slab.thickness_um <= 1000.0)) {
        throw InputError(fmt::format(
            "{}: mu_s_per_um = {} (optical thickness {}): expected mu_s >= 0 with mu_s d <= 1000",
            kWhat, slab.mu_s_per_um, slab.mu_s_per_um * slab.thickness_um));
    }
    const auto& th = slab.theta_rad;
    const auto& p = slab.phase_per_rad;
    if (th.size() < 2 || p.size() != th.size()) {
        throw InputError(
            fmt::format("{}: {} angles and {} phase values: expected >= 2 of each, equally many",
                        kWhat, th.size(), p.size()));
    }
    if (std::abs(th.front()) > 1e-12 || std::abs(th.back() - kPi) > 1e-9) {
        throw InputError(fmt::format("{}: theta_rad from {} to {}: expected a table from 0 to pi",
                                     kWhat, th.front(), th.back()));
    }
    double sum = 0.0;
    for (std::size_t i = 0; i < th.size(); ++i) {
        if (i > 0 && !(th[i] > th[i - 1])) {
            throw InputError(
                fmt::format("{}: theta_rad[{}] = {} after {}: expected strictly increasing angles",
                            kWhat, i, th[i], th[i - 1]));
        }
        if (!(std::isfinite(p[i]) && p[i] >= 0.0)) {
            throw InputError(fmt::format("{}: phase_per_rad[{}] = {}: expected finite values >= 0",
                                         kWhat, i, p[i]));
        }
        sum += p[i];
    }
    if (!(sum > 0.0)) {
        throw InputError(
            fmt::format("{}: phase function all zero: expected some p(theta) > 0", kWhat));
    }
}

struct Counts {
    std::uint64_t reflected = 0, transmitted = 0, reflected_single = 0, lost = 0, events = 0;
};

double fresnel_out(double n_eff, double cos_i, optics::Polarisation pol) {
    if (n_eff == 1.0) return 0.0;
    return optics::fresnel_intensities(n_eff, optics::Complex(1.0), cos_i, pol).reflectance;
}

void walk(const FlatlandSlab& slab, const PhaseSampler& phase, optics::Polarisation pol,
          std::uint64_t max_events, Rng& rng, Counts& counts) {
    const double d = slab.thickness_um, mu_s = slab.mu_s_per_um;
    constexpr double kInf = std::numeric_limits<double>::infinity();
    double z = 0.0, sx = 0.0, sz = 1.0;
    std::uint64_t scatterings = 0, events = 0;
    for (;;) {
        if (events >= max_events) {
            ++counts.lost;
            break;
        }
        ++events;
        const double flight = mu_s > 0.0 ? -std::log(1.0 - rng.uniform()) / mu_s : kInf;
        const double to_face = sz > 0.0 ? (d - z) / sz : (sz < 0.0 ? -z / sz : kInf);
        if (flight < to_face) {
            z += flight * sz;
            const double theta = phase.sample(rng.uniform());
            const double sign = rng.uniform() < 0.5 ? -1.0 : 1.0;
            const double c = std::cos(theta), s = sign * std::sin(theta);
            const double nx = c * sx - s * sz, nz = s * sx + c * sz;
            const double norm = std::hypot(nx, nz);
            sx = nx / norm;
            sz = nz / norm;
            ++scatterings;
            continue;
        }
        if (to_face == kInf) {  // μ_s = 0 and parallel to the faces: cannot happen from +z
            ++counts.lost;
            break;
        }
        const bool top = sz < 0.0;
        z = top ? 0.0 : d;
        if (rng.uniform() < fresnel_out(slab.n_eff, std::abs(sz), pol)) {
            sz = -sz;
            continue;
        }
        if (top) {
            ++counts.reflected;
            if (scatterings == 1) ++counts.reflected_single;
        } else {
            ++counts.transmitted;
        }
        break;
    }
    counts.events += events;
}

}  // namespace

FlatlandSlab FlatlandSlab::from_table(const FlatlandTable& table, double thickness_um) {
    FlatlandSlab slab;
    slab.thickness_um = thickness_um;
    slab.n_eff = table.n_eff;
    slab.mu_s_per_um = table.mu_s_per_um;
    slab.polarisation = table.polarisation;
    slab.theta_rad = table.theta_rad;
    slab.phase_per_rad = table.phase_per_rad;
    return slab;
}

FlatlandSlabResult simulate_flatland_slab(const FlatlandSlab& slab,
                                          const FlatlandSlabOptions& options) {
    require_slab(slab);
    if (options.paths < 1 || options.paths > 1000000000ULL) {
        throw InputError(
            fmt::format("flatland slab: paths = {}: expected 1 to 1e9", options.paths));
    }
    if (options.threads < 1 || options.threads > 256) {
        throw InputError(
            fmt::format("flatland slab: threads = {}: expected 1 to 256", options.threads));
    }
    if (options.max_events < 1) {
        throw InputError("flatland slab: max_events = 0: expected at least 1 interaction");
    }
    const PhaseSampler phase(slab);
    const optics::Polarisation pol =
        slab.polarisation == Polarisation2d::te ? optics::Polarisation::s : optics::Polarisation::p;
    const std::uint64_t stream = derive_seed(options.seed, "wave/flatland_slab");
    const std::uint64_t blocks = (options.paths + kBlockPaths - 1) / kBlockPaths;
    std::vector<Counts> block_counts(blocks);
    std::atomic<std::uint64_t> next{0};
    auto worker = [&] {
        for (std::uint64_t b = next++; b < blocks; b = next++) {
            const std::uint64_t end = std::min(options.paths, (b + 1) * kBlockPaths);
            for (std::uint64_t i = b * kBlockPaths; i < end; ++i) {
                Rng rng(stream, i);
                walk(slab, phase, pol, options.max_events, rng, block_counts[b]);
            }
        }
    };
    const auto threads = static_cast<std::uint64_t>(options.threads);
    if (threads == 1 || blocks == 1) {
        worker();
    } else {
        std::vector<std::thread> pool;
        for (std::uint64_t t = 0; t < std::min(threads, blocks); ++t) pool.emplace_back(worker);
        for (auto& t : pool) t.join();
    }
    Counts total;
    for (const Counts& c : block_counts) {  // integers: the order does not matter
        total.reflected += c.reflected;
        total.transmitted += c.transmitted;
        total.reflected_single += c.reflected_single;
        total.lost += c.lost;
        total.events += c.events;
    }
    const double n = static_cast<double>(options.paths);
    // The front face from air at normal incidence: ((n_eff − 1)/(n_eff + 1))² for s and p.
    const double r0 =
        optics::fresnel_intensities(1.0, optics::Complex(slab.n_eff), 1.0, pol).reflectance;
    const double entering = 1.0 - r0;
    const double pr = static_cast<double>(total.reflected) / n;
    const double pt = static_cast<double>(total.transmitted) / n;
    FlatlandSlabResult r;
    r.specular = r0;
    r.reflectance = r0 + entering * pr;
    r.transmittance = entering * pt;
    r.reflectance_se = entering * std::sqrt(pr * (1.0 - pr) / n);
    r.transmittance_se = entering * std::sqrt(pt * (1.0 - pt) / n);
    r.reflectance_single = entering * static_cast<double>(total.reflected_single) / n;
    r.mean_events = static_cast<double>(total.events) / n;
    r.paths = options.paths;
    r.lost = total.lost;
    return r;
}

SlabIntensities incoherent_slab(double n_eff, double tau) {
    if (!(std::isfinite(n_eff) && n_eff >= 1.0 && n_eff <= 10.0)) {
        throw InputError(
            fmt::format("incoherent slab: n_eff = {}: expected a real index in [1, 10]", n_eff));
    }
    if (!(std::isfinite(tau) && tau >= 0.0)) {
        throw InputError(
            fmt::format("incoherent slab: tau = {}: expected an optical thickness >= 0", tau));
    }
    const double r0 = std::pow((n_eff - 1.0) / (n_eff + 1.0), 2);
    const double a = std::exp(-tau);
    const double denom = 1.0 - r0 * r0 * a * a;
    return {r0 + (1.0 - r0) * (1.0 - r0) * r0 * a * a / denom, (1.0 - r0) * (1.0 - r0) * a / denom};
}

double single_scattering_reflectance_matched(const FlatlandSlab& slab) {
    require_slab(slab);
    const PhaseSampler phase(slab);
    const double tau = slab.mu_s_per_um * slab.thickness_um;
    // Midpoint rule on [π/2, π]; the kernel vanishes like |cos θ| at π/2 and is smooth
    // elsewhere, p is piecewise linear: 20000 intervals leave < 1e-7 relative.
    constexpr int kIntervals = 20000;
    const double step = 0.5 * kPi / kIntervals;
    double sum = 0.0;
    for (int i = 0; i < kIntervals; ++i) {
        const double theta = 0.5 * kPi + (i + 0.5) * step;
        const double inv_c = 1.0 / std::abs(std::cos(theta));
        const double kernel = tau > 0.0 ? -std::expm1(-tau * (1.0 + inv_c)) / (1.0 + inv_c) : 0.0;
        sum += phase.density(theta) * kernel;
    }
    return 2.0 * sum * step;
}

}  // namespace plumage::sim::wave
