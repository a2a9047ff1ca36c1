// The strong-contrast medium (conventions and derivation in the header and docs/spongy_media.md).
//
// Parameter table:
//  | name                | unit  | valid range                                           |
//  |---------------------|-------|-------------------------------------------------------|
//  | lambda_nm           | nm    | finite, > 0, in the materials' range                  |
//  | q_cut_per_um        | µm⁻¹  | finite, > 0 (a voxel volume: its last shell's q)      |
//  | q_step_per_um       | µm⁻¹  | finite, in (0, q_cut] (nodes of the linear S̄)         |
//  | spectrum S̄(q)       | µm³   | finite, >= 0 on [0, q_cut]                            |
//  | filling fraction f  | 1     | (0, 1)                                                |
//  | table_points        | 1     | [2, 100000]                                           |
//  | host                | —     | keratin, air or bruggeman (self-consistent)           |
#include "sim/wave/volume/strong_contrast.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "common/constants.h"
#include "common/error.h"
#include "common/gauss_legendre.h"
#include "sim/wave/volume/effective_index.h"
#include "sim/wave/volume/index_field.h"

namespace plumage::sim::wave {
namespace {

// Composite 8-node Gauss–Legendre rule over [a, b] in `panels` panels. The dispersion
// integral's panels meet at s = Q (an even count over [0, 2Q]), so no node sits on the
// removable singularity.
template <class F>
double composite_gl8(F&& f, double a, double b, int panels) {
    const double width = (b - a) / panels;
    double sum = 0.0;
    for (int p = 0; p < panels; ++p) {
        const double mid = a + (p + 0.5) * width;
        for (std::size_t i = 0; i < kGl8Nodes.size(); ++i)
            sum += kGl8Weights[i] * f(mid + 0.5 * width * kGl8Nodes[i]);
    }
    return 0.5 * width * sum;
}

constexpr int kDispersionPanels = 64;

// ∫_a^x qⁿ (A + B q) dq.
double segment_moment(int n, double a, double x, double intercept, double slope) {
    const double n1 = n + 1.0, n2 = n + 2.0;
    return intercept * (std::pow(x, n1) - std::pow(a, n1)) / n1 +
           slope * (std::pow(x, n2) - std::pow(a, n2)) / n2;
}

}  // namespace

StrongContrastKernel StrongContrastKernel::sampled(const std::function<double(double)>& spectrum,
                                                   double q_cut_per_um, double q_step_per_um) {
    if (!(std::isfinite(q_cut_per_um) && q_cut_per_um > 0.0)) {
        throw InputError(fmt::format(
            "strong-contrast medium: q_cut = {} per um: expected a finite wavenumber > 0",
            q_cut_per_um));
    }
    if (!(std::isfinite(q_step_per_um) && q_step_per_um > 0.0 && q_step_per_um <= q_cut_per_um)) {
        throw InputError(fmt::format(
            "strong-contrast medium: q_step = {} per um: expected a step in (0, q_cut = {}]",
            q_step_per_um, q_cut_per_um));
    }
    const auto steps = static_cast<std::size_t>(std::ceil(q_cut_per_um / q_step_per_um));
    std::vector<double> q(steps + 1), s(steps + 1);
    for (std::size_t i = 0; i <= steps; ++i) {
        q[i] = q_cut_per_um * static_cast<double>(i) / static_cast<double>(steps);
        s[i] = spectrum(q[i]);
    }
    return StrongContrastKernel(std::move(q), std::move(s));
}

StrongContrastKernel StrongContrastKernel::of(const RadialSpectrum& radial) {
    std::vector<double> q{0.0}, s{radial.power.front()};
    q.insert(q.end(), radial.q_per_um.begin(), radial.q_per_um.end());
    s.insert(s.end(), radial.power.begin(), radial.power.end());
    return StrongContrastKernel(std::move(q), std::move(s));
}

StrongContrastKernel::StrongContrastKernel(std::vector<double> q_nodes_per_um,
                                           std::vector<double> spectrum_um3)
    : q_(std::move(q_nodes_per_um)), s_(std::move(spectrum_um3)) {
    PLUMAGE_CHECK(q_.size() >= 2 && q_.size() == s_.size() && q_.front() == 0.0,
                  "strong-contrast kernel: nodes from q = 0, one value each");
    for (std::size_t i = 0; i < q_.size(); ++i) {
        if (!(std::isfinite(s_[i]) && s_[i] >= 0.0)) {
            throw InputError(fmt::format(
                "strong-contrast medium: spectrum = {} um^3 at q = {} per um: expected a finite "
                "value >= 0",
                s_[i], q_[i]));
        }
        PLUMAGE_CHECK(i == 0 || q_[i] > q_[i - 1], "strong-contrast kernel: increasing nodes");
    }
    const std::size_t nodes = q_.size() - 1;
    m1_.assign(nodes + 1, 0.0);
    m3_.assign(nodes + 1, 0.0);
    m5_.assign(nodes + 1, 0.0);
    for (std::size_t i = 1; i <= nodes; ++i) {
        const double slope = (s_[i] - s_[i - 1]) / (q_[i] - q_[i - 1]);
        const double intercept = s_[i - 1] - slope * q_[i - 1];
        m1_[i] = m1_[i - 1] + segment_moment(1, q_[i - 1], q_[i], intercept, slope);
        m3_[i] = m3_[i - 1] + segment_moment(3, q_[i - 1], q_[i], intercept, slope);
        m5_[i] = m5_[i - 1] + segment_moment(5, q_[i - 1], q_[i], intercept, slope);
    }
    const double q_cut = q_.back();
    porod_ = s_.back() * std::pow(q_cut, 4);
    h_infinity_ = 3.0 / (8.0 * kPi) * (m1_.back() + 0.5 * porod_ / (q_cut * q_cut));
}

double StrongContrastKernel::moment(int n, double x) const {
    const std::vector<double>& m = n == 1 ? m1_ : n == 3 ? m3_ : m5_;
    const double q_cut = q_.back();
    if (x >= q_cut) {
        // Porod's tail, S̄ = porod_ q⁻⁴, in closed form.
        const double tail = n == 1   ? 0.5 * porod_ * (1.0 / (q_cut * q_cut) - 1.0 / (x * x))
                            : n == 3 ? porod_ * std::log(x / q_cut)
                                     : 0.5 * porod_ * (x * x - q_cut * q_cut);
        return m.back() + tail;
    }
    const auto i =
        static_cast<std::size_t>(std::upper_bound(q_.begin(), q_.end(), x) - q_.begin()) - 1;
    const double slope = (s_[i + 1] - s_[i]) / (q_[i + 1] - q_[i]);
    const double intercept = s_[i] - slope * q_[i];
    return m[i] + segment_moment(n, q_[i], x, intercept, slope);
}

// h(s) = (3/8π) ∫₀^{2s} q S̄ w dq with w = 1 − q²/(2s²) + q⁴/(8s⁴), by the three moments.
double StrongContrastKernel::h(double s) const {
    if (s <= 0.0) return 0.0;
    const double x = 2.0 * s, s2 = s * s;
    const double integral =
        moment(1, x) - moment(3, x) / (2.0 * s2) + moment(5, x) / (8.0 * s2 * s2);
    return 3.0 / (8.0 * kPi) * integral;
}

double StrongContrastKernel::im_a2(double q_per_um) const { return q_per_um * h(q_per_um); }

std::complex<double> StrongContrastKernel::a2(double q_per_um) const {
    if (!(std::isfinite(q_per_um) && q_per_um > 0.0)) {
        throw InputError(fmt::format(
            "strong-contrast medium: Q = {} per um: expected a finite wavenumber > 0", q_per_um));
    }
    const double q = q_per_um, hq = h(q);
    // [0, 2Q] directly; [2Q, ∞) with s = 2Q/t, t ∈ (0, 1].
    const double near = composite_gl8([&](double s) { return (h(s) - hq) / (s * s - q * q); }, 0.0,
                                      2.0 * q, kDispersionPanels);
    const double far =
        composite_gl8([&](double t) { return (h(2.0 * q / t) - hq) * 2.0 / (q * (4.0 - t * t)); },
                      0.0, 1.0, kDispersionPanels);
    return {2.0 * q * q / kPi * (near + far), q * hq};
}

std::complex<double> strong_contrast_permittivity(std::complex<double> eps_inclusion,
                                                  std::complex<double> eps_host,
                                                  double inclusion_fraction,
                                                  std::complex<double> a2) {
    const double phi = inclusion_fraction;
    const std::complex<double> beta = (eps_inclusion - eps_host) / (eps_inclusion + 2.0 * eps_host);
    return eps_host * (1.0 + 3.0 * beta * phi * phi / (phi * (1.0 - beta * phi) - beta * a2));
}

std::complex<double> self_consistent_strong_contrast_permittivity(
    std::complex<double> eps_a, std::complex<double> eps_b, double fraction_a,
    const std::function<std::complex<double>(std::complex<double>)>& a2_of_eps,
    std::complex<double> start) {
    const double phi_a = fraction_a, phi_b = 1.0 - fraction_a;
    const auto beta = [](std::complex<double> e_i, std::complex<double> e) {
        return (e_i - e) / (e_i + 2.0 * e);
    };
    const auto dbeta = [](std::complex<double> e_i, std::complex<double> e) {
        return -3.0 * e_i / ((e_i + 2.0 * e) * (e_i + 2.0 * e));
    };
    std::complex<double> eps = start;
    for (int outer = 0; outer < 100; ++outer) {
        const std::complex<double> a2 = a2_of_eps(eps);
        const std::complex<double> before = eps;
        // Newton on g(ε) = φ_a β_a + φ_b β_b + (β_a − β_b)² A₂ at fixed A₂.
        for (int i = 0; i < 100; ++i) {
            const std::complex<double> ba = beta(eps_a, eps), bb = beta(eps_b, eps);
            const std::complex<double> g = phi_a * ba + phi_b * bb + (ba - bb) * (ba - bb) * a2;
            const std::complex<double> dg =
                phi_a * dbeta(eps_a, eps) + phi_b * dbeta(eps_b, eps) +
                2.0 * (ba - bb) * (dbeta(eps_a, eps) - dbeta(eps_b, eps)) * a2;
            const std::complex<double> step = g / dg;
            eps -= step;
            if (std::abs(step) <= 1e-15 * std::abs(eps)) break;
        }
        if (std::abs(eps - before) <= 1e-13 * std::abs(eps)) return eps;
    }
    PLUMAGE_CHECK(false,
                  fmt::format("self-consistent strong contrast: no convergence from eps = {} "
                              "{:+}i (last {} {:+}i)",
                              start.real(), start.imag(), eps.real(), eps.imag()));
    return eps;
}

namespace {

// ε_e of the medium and of its A₂ = 0 background (Maxwell Garnett of the host, or Bruggeman).
struct StrongContrastEps {
    std::complex<double> effective, background;
};

StrongContrastEps strong_contrast_eps(const StrongContrastKernel& kernel,
                                      std::complex<double> eps_k, std::complex<double> eps_a,
                                      double f, double k0, StrongContrastHost host) {
    if (host == StrongContrastHost::bruggeman) {
        const std::complex<double> n_b = bruggeman_index(std::sqrt(eps_k), std::sqrt(eps_a), f);
        const auto a2_of_eps = [&](std::complex<double> e) {
            return kernel.a2(k0 * std::sqrt(e).real());
        };
        return {self_consistent_strong_contrast_permittivity(eps_k, eps_a, f, a2_of_eps, n_b * n_b),
                n_b * n_b};
    }
    const bool keratin_host = host == StrongContrastHost::keratin;
    const std::complex<double> eps_host = keratin_host ? eps_k : eps_a;
    const std::complex<double> eps_inclusion = keratin_host ? eps_a : eps_k;
    const double phi = keratin_host ? 1.0 - f : f;
    const std::complex<double> eps_mg =
        strong_contrast_permittivity(eps_inclusion, eps_host, phi, 0.0);
    return {strong_contrast_permittivity(eps_inclusion, eps_host, phi,
                                         kernel.a2(k0 * std::sqrt(eps_mg).real())),
            eps_mg};
}

}  // namespace

ScatteringTable strong_contrast_medium(const PowerSpectrum& spectrum,
                                       const optics::Material& keratin, const optics::Material& air,
                                       double lambda_nm, StrongContrastHost host,
                                       int table_points) {
    require_born_inputs(spectrum, keratin, air, lambda_nm);
    const RadialSpectrum radial = spectrum.radial();
    auto interpolate = [&radial](double q) { return radial.at(q); };
    const StrongContrastKernel kernel = StrongContrastKernel::of(radial);

    const std::complex<double> n_k = keratin.index(lambda_nm), n_a = air.index(lambda_nm);
    const double k0 = 2.0 * kPi / (lambda_nm * 1e-3);
    const StrongContrastEps eps =
        strong_contrast_eps(kernel, n_k * n_k, n_a * n_a, spectrum.filling_fraction(), k0, host);
    const std::complex<double> n_e = std::sqrt(eps.effective);
    const double mu_a = 2.0 * k0 * std::sqrt(eps.background).imag();
    const double mu_s = std::max(0.0, 2.0 * k0 * n_e.imag() - mu_a);

    // First Born's angular shape at the effective wavenumber, scaled to μ_s.
    ScatteringTable t = born_scattering(interpolate, 1.0, n_e.real(), lambda_nm, table_points);
    t.mu_s_per_um = mu_s;
    t.n_eff = {n_e.real(), mu_a / (2.0 * k0)};
    t.mu_a_per_um = mu_a;
    return t;
}

}  // namespace plumage::sim::wave
