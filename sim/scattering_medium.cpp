#include "sim/scattering_medium.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <numeric>

#include <fmt/format.h>

#include "common/constants.h"
#include "common/error.h"
#include "sim/scatterer/scatterer.h"  // orthonormal_frame

namespace plumage::sim {
namespace {

// The boundary index of a scattering medium: n_eff(λ) interpolated linearly between the
// tables, as the medium does (its own copy of the nodes, so it may outlive the medium).
class EffectiveIndexMaterial final : public optics::Material {
public:
    EffectiveIndexMaterial(std::string name, std::vector<double> lambda_nm, std::vector<double> n)
        : name_(std::move(name)), lambda_nm_(std::move(lambda_nm)), n_(std::move(n)) {}
    std::complex<double> index(double lambda_nm) const override {
        if (!(lambda_nm >= lambda_nm_.front() && lambda_nm <= lambda_nm_.back())) {
            throw InputError(fmt::format("{}: wavelength {} nm is outside {} … {} nm", name_,
                                         lambda_nm, lambda_nm_.front(), lambda_nm_.back()));
        }
        auto it = std::lower_bound(lambda_nm_.begin(), lambda_nm_.end(), lambda_nm);
        const auto hi = static_cast<std::size_t>(it - lambda_nm_.begin());
        if (lambda_nm_[hi] == lambda_nm) return {n_[hi], 0.0};
        const double t = (lambda_nm - lambda_nm_[hi - 1]) / (lambda_nm_[hi] - lambda_nm_[hi - 1]);
        return {(1.0 - t) * n_[hi - 1] + t * n_[hi], 0.0};
    }
    const std::string& name() const override { return name_; }

private:
    std::string name_;
    std::vector<double> lambda_nm_, n_;
};

}  // namespace

TabulatedPhaseFunction::TabulatedPhaseFunction(const std::vector<double>& cos_theta,
                                               const std::vector<double>& phase_per_sr,
                                               const std::string& where) {
    const std::size_t n = cos_theta.size();
    if (n < 2 || phase_per_sr.size() != n) {
        throw InputError(fmt::format(
            "{}: phase table with {} cos theta nodes and {} values: expected >= 2 of each, "
            "equally many",
            where, n, phase_per_sr.size()));
    }
    mu_ = cos_theta;
    p_ = phase_per_sr;
    if (mu_.front() > mu_.back()) {
        std::reverse(mu_.begin(), mu_.end());
        std::reverse(p_.begin(), p_.end());
    }
    constexpr double kEnd = 1e-9;
    if (!(std::abs(mu_.front() + 1.0) <= kEnd) || !(std::abs(mu_.back() - 1.0) <= kEnd)) {
        throw InputError(fmt::format(
            "{}: phase table spans cos theta = {} … {}: expected the whole range −1 … 1", where,
            mu_.front(), mu_.back()));
    }
    mu_.front() = -1.0;
    mu_.back() = 1.0;
    for (std::size_t i = 0; i < n; ++i) {
        if (!std::isfinite(p_[i]) || p_[i] < 0.0) {
            throw InputError(
                fmt::format("{}: phase value {} at cos theta = {}: expected finite "
                            "and >= 0 (1/sr)",
                            where, p_[i], mu_[i]));
        }
        if (i > 0 && !(mu_[i] > mu_[i - 1])) {
            throw InputError(
                fmt::format("{}: phase table cos theta nodes {} and {} are not strictly monotone",
                            where, mu_[i - 1], mu_[i]));
        }
    }
    cdf_.assign(n, 0.0);
    for (std::size_t i = 0; i + 1 < n; ++i) {
        cdf_[i + 1] = cdf_[i] + kTwoPi * 0.5 * (mu_[i + 1] - mu_[i]) * (p_[i] + p_[i + 1]);
    }
    table_integral_ = cdf_.back();
    if (!(table_integral_ > 0.0) || !std::isfinite(table_integral_)) {
        throw InputError(
            fmt::format("{}: phase table integrates to {}: expected a positive, finite value",
                        where, table_integral_));
    }
    for (double& p : p_) p /= table_integral_;
    for (double& c : cdf_) c = std::min(1.0, c / table_integral_);
    cdf_.back() = 1.0;
    // g = 2π ∫ μ p dμ: Simpson per segment, exact for the quadratic μ p(μ).
    double g = 0.0;
    for (std::size_t i = 0; i + 1 < n; ++i) {
        const double h = mu_[i + 1] - mu_[i];
        const double mm = 0.5 * (mu_[i] + mu_[i + 1]), pm = 0.5 * (p_[i] + p_[i + 1]);
        g += h / 6.0 * (mu_[i] * p_[i] + 4.0 * mm * pm + mu_[i + 1] * p_[i + 1]);
    }
    g_ = kTwoPi * g;
}

double TabulatedPhaseFunction::eval(double cos_theta) const {
    const double mu = std::clamp(cos_theta, -1.0, 1.0);
    auto it = std::upper_bound(mu_.begin(), mu_.end(), mu);
    std::size_t i = it == mu_.begin() ? 0 : static_cast<std::size_t>(it - mu_.begin()) - 1;
    i = std::min(i, mu_.size() - 2);
    const double x = (mu - mu_[i]) / (mu_[i + 1] - mu_[i]);
    return p_[i] + x * (p_[i + 1] - p_[i]);
}

double TabulatedPhaseFunction::cdf(double cos_theta) const {
    const double mu = std::clamp(cos_theta, -1.0, 1.0);
    auto it = std::upper_bound(mu_.begin(), mu_.end(), mu);
    std::size_t i = it == mu_.begin() ? 0 : static_cast<std::size_t>(it - mu_.begin()) - 1;
    i = std::min(i, mu_.size() - 2);
    const double x = mu - mu_[i];
    const double b = (p_[i + 1] - p_[i]) / (mu_[i + 1] - mu_[i]);
    return std::min(1.0, cdf_[i] + kTwoPi * (p_[i] * x + 0.5 * b * x * x));
}

double TabulatedPhaseFunction::sample_cos_theta(double u) const {
    // Segment i with cdf_[i] <= u < cdf_[i+1] (segments of zero mass are never chosen).
    auto it = std::upper_bound(cdf_.begin(), cdf_.end(), u);
    std::size_t i = it == cdf_.begin() ? 0 : static_cast<std::size_t>(it - cdf_.begin()) - 1;
    i = std::min(i, mu_.size() - 2);
    const double h = mu_[i + 1] - mu_[i];
    const double a = p_[i];
    const double b = (p_[i + 1] - p_[i]) / h;
    // 2π (a x + b x²/2) = r: x = 2 r' / (a + √(a² + 2 b r')), r' = r / 2π (stable for both
    // signs of b; the discriminant is >= p(x)² >= 0 up to round-off).
    const double r = std::max(0.0, u - cdf_[i]) / kTwoPi;
    const double disc = std::max(0.0, a * a + 2.0 * b * r);
    const double denominator = a + std::sqrt(disc);
    const double x = denominator > 0.0 ? 2.0 * r / denominator : 0.0;
    return std::clamp(mu_[i] + std::clamp(x, 0.0, h), -1.0, 1.0);
}

ScatteringMedium::ScatteringMedium(std::vector<MediumTable> tables, AbsorptionSampling absorption,
                                   std::string name)
    : name_(std::move(name)), absorption_(absorption) {
    if (tables.empty()) {
        throw InputError(
            fmt::format("{}: no scattering tables: expected at least one wavelength", name_));
    }
    for (std::size_t i = 0; i < tables.size(); ++i) {
        if (!std::isfinite(tables[i].lambda_nm) || !(tables[i].lambda_nm > 0.0)) {
            throw InputError(fmt::format("{}: table {}: wavelength {} nm: expected finite and > 0",
                                         name_, i, tables[i].lambda_nm));
        }
    }
    std::sort(tables.begin(), tables.end(),
              [](const MediumTable& a, const MediumTable& b) { return a.lambda_nm < b.lambda_nm; });
    for (std::size_t i = 0; i < tables.size(); ++i) {
        const MediumTable& t = tables[i];
        const std::string where = fmt::format("{}: table at {} nm", name_, t.lambda_nm);
        if (i > 0 && t.lambda_nm == tables[i - 1].lambda_nm) {
            throw InputError(fmt::format("{}: two tables at the same wavelength", where));
        }
        if (!std::isfinite(t.n_eff) || !(t.n_eff > 0.0)) {
            throw InputError(
                fmt::format("{}: n_eff = {}: expected finite and > 0", where, t.n_eff));
        }
        if (!std::isfinite(t.mu_s_per_um) || t.mu_s_per_um < 0.0) {
            throw InputError(
                fmt::format("{}: mu_s = {} 1/um: expected finite and >= 0", where, t.mu_s_per_um));
        }
        if (!std::isfinite(t.mu_a_per_um) || t.mu_a_per_um < 0.0) {
            throw InputError(
                fmt::format("{}: mu_a = {} 1/um: expected finite and >= 0", where, t.mu_a_per_um));
        }
        TabulatedPhaseFunction phase(t.cos_theta, t.phase_per_sr, where);
        if (t.mu_s_per_um > 0.0 &&
            std::abs(phase.table_integral() - 1.0) > kPhaseNormalisationTolerance) {
            throw InputError(fmt::format(
                "{}: the phase table's linear interpolant integrates to {:.4f}: expected 1 ± {} "
                "(the table is too coarse for its phase function: use more cos theta nodes)",
                where, phase.table_integral(), kPhaseNormalisationTolerance));
        }
        lambda_.push_back(t.lambda_nm);
        n_eff_.push_back(t.n_eff);
        mu_s_.push_back(t.mu_s_per_um);
        mu_a_.push_back(t.mu_a_per_um);
        phase_.push_back(std::move(phase));
    }
    material_ = std::make_shared<EffectiveIndexMaterial>("n_eff(" + name_ + ")", lambda_, n_eff_);
}

ScatteringMedium::Bracket ScatteringMedium::bracket(double lambda_nm) const {
    if (!(lambda_nm >= lambda_.front() && lambda_nm <= lambda_.back())) {
        throw InputError(fmt::format(
            "{}: wavelength {} nm is outside its tables' range {} … {} nm: compute the medium "
            "at wavelengths covering the study's",
            name_, lambda_nm, lambda_.front(), lambda_.back()));
    }
    auto it = std::lower_bound(lambda_.begin(), lambda_.end(), lambda_nm);
    const auto hi = static_cast<std::size_t>(it - lambda_.begin());
    if (lambda_[hi] == lambda_nm) return {hi, hi, 0.0};
    const std::size_t lo = hi - 1;
    return {lo, hi, (lambda_nm - lambda_[lo]) / (lambda_[hi] - lambda_[lo])};
}

double ScatteringMedium::scattering_coefficient_per_um(double lambda_nm) const {
    const Bracket b = bracket(lambda_nm);
    return (1.0 - b.t) * mu_s_[b.lo] + b.t * mu_s_[b.hi];
}

double ScatteringMedium::absorption_coefficient_per_um(double lambda_nm) const {
    const Bracket b = bracket(lambda_nm);
    return (1.0 - b.t) * mu_a_[b.lo] + b.t * mu_a_[b.hi];
}

double ScatteringMedium::effective_index(double lambda_nm) const {
    const Bracket b = bracket(lambda_nm);
    return (1.0 - b.t) * n_eff_[b.lo] + b.t * n_eff_[b.hi];
}

double ScatteringMedium::phase(double cos_theta, double lambda_nm) const {
    const Bracket b = bracket(lambda_nm);
    const double wlo = (1.0 - b.t) * mu_s_[b.lo], whi = b.t * mu_s_[b.hi];
    if (b.lo == b.hi || !(wlo + whi > 0.0)) return phase_[b.lo].eval(cos_theta);
    return (wlo * phase_[b.lo].eval(cos_theta) + whi * phase_[b.hi].eval(cos_theta)) / (wlo + whi);
}

double ScatteringMedium::mean_cosine(double lambda_nm) const {
    const Bracket b = bracket(lambda_nm);
    const double wlo = (1.0 - b.t) * mu_s_[b.lo], whi = b.t * mu_s_[b.hi];
    if (b.lo == b.hi || !(wlo + whi > 0.0)) return phase_[b.lo].mean_cosine();
    return (wlo * phase_[b.lo].mean_cosine() + whi * phase_[b.hi].mean_cosine()) / (wlo + whi);
}

bool ScatteringMedium::active(double lambda_nm) const {
    const Bracket b = bracket(lambda_nm);
    return (1.0 - b.t) * (mu_s_[b.lo] + mu_a_[b.lo]) + b.t * (mu_s_[b.hi] + mu_a_[b.hi]) > 0.0;
}

MediumFlight ScatteringMedium::fly(double segment_um, double lambda_nm, Rng& rng) const {
    PLUMAGE_CHECK(std::isfinite(segment_um) && segment_um >= 0.0,
                  fmt::format("segment length {} um", segment_um));
    const Bracket b = bracket(lambda_nm);
    const double mu_s = (1.0 - b.t) * mu_s_[b.lo] + b.t * mu_s_[b.hi];
    const double mu_a = (1.0 - b.t) * mu_a_[b.lo] + b.t * mu_a_[b.hi];
    const double mu_t = mu_s + mu_a;
    if (!(mu_t > 0.0)) return {false, segment_um, 1.0};
    if (!(mu_s > 0.0)) {
        // Absorbs only: Beer–Lambert (no collision to sample).
        if (absorption_ == AbsorptionSampling::weighted) {
            return {false, segment_um, std::exp(-mu_a * segment_um)};
        }
    }
    // 1 − u ∈ (0, 1]: the distance is finite.
    const double distance = -std::log1p(-rng.uniform()) / mu_t;
    if (!(distance < segment_um)) return {false, segment_um, 1.0};
    if (absorption_ == AbsorptionSampling::weighted) return {true, distance, mu_s / mu_t};
    if (rng.uniform() * mu_t < mu_a) return {false, distance, 0.0};  // absorbed
    return {true, distance, 1.0};
}

MediumScatter ScatteringMedium::scatter(const Vec3d& direction, double lambda_nm, Rng& rng) const {
    const Bracket b = bracket(lambda_nm);
    const double wlo = (1.0 - b.t) * mu_s_[b.lo], whi = b.t * mu_s_[b.hi];
    PLUMAGE_CHECK(wlo + whi > 0.0,
                  fmt::format("{} asked to scatter at {} nm where mu_s = 0", name_, lambda_nm));
    const double choose = rng.uniform();
    const TabulatedPhaseFunction& phase = choose * (wlo + whi) < wlo ? phase_[b.lo] : phase_[b.hi];
    const double mu = phase.sample_cos_theta(rng.uniform());
    const double phi = kTwoPi * rng.uniform();
    const double sin_theta = std::sqrt(std::max(0.0, 1.0 - mu * mu));
    Vec3d e1, e2;
    orthonormal_frame(direction, e1, e2);
    const Vec3d out = mu * direction + sin_theta * (std::cos(phi) * e1 + std::sin(phi) * e2);
    return {out.normalized(), 1.0};
}

}  // namespace plumage::sim
