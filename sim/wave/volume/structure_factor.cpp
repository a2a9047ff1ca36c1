// Percus–Yevick and measured structure factors (conventions in the header).
//
// Parameter table:
//  | name        | unit  | valid range                                               |
//  |-------------|-------|-----------------------------------------------------------|
//  | q_per_um    | µm⁻¹  | finite, >= 0                                              |
//  | sigma_um    | µm    | finite, > 0: hard-sphere diameter (min centre separation) |
//  | phi         | 1     | (0, 0.6]: hard-sphere volume fraction                     |
//  | centres_um  | µm    | in [0, L)³, at least 2                                    |
//  | box_um (L)  | µm    | finite, > 0                                               |
//  | q_max_per_um| µm⁻¹  | >= 2π/L (at least one shell)                              |
#include "sim/wave/volume/structure_factor.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <numbers>

#include <fmt/format.h>

#include "common/constants.h"
#include "common/error.h"

namespace plumage::sim::wave {
namespace {

void require_py(double sigma_um, double phi) {
    if (!(std::isfinite(sigma_um) && sigma_um > 0.0)) {
        throw InputError(
            fmt::format("Percus-Yevick: sigma_um = {}: expected a finite diameter > 0", sigma_um));
    }
    if (!(phi > 0.0 && phi <= 0.6)) {
        throw InputError(fmt::format(
            "Percus-Yevick: phi = {}: expected a hard-sphere volume fraction in (0, 0.6] (PY is "
            "unphysical beyond random close packing)",
            phi));
    }
}

// n ĉ(q) = 24 φ ∫_0^1 x² c(x) sin(Q x)/(Q x) dx, Q = q σ, closed form.
// Closed-form cancellation grows like ε/Q⁶ at small Q, so below Q = 1 the integral is
// taken by 16-point Gauss–Legendre (the integrand is a degree-5 polynomial times an entire
// function varying on the scale 1/Q > 1: exact to round-off).
double n_c_hat(double big_q, double phi) {
    const double one_minus = 1.0 - phi;
    const double alpha = (1.0 + 2.0 * phi) * (1.0 + 2.0 * phi) / std::pow(one_minus, 4);
    const double beta = -6.0 * phi * (1.0 + 0.5 * phi) * (1.0 + 0.5 * phi) / std::pow(one_minus, 4);
    const double gamma = 0.5 * phi * alpha;
    if (big_q < 1.0) {
        static constexpr double kNodes[8] = {
            0.0950125098376374, 0.2816035507792589, 0.4580167776572274, 0.6178762444026438,
            0.7554044083550030, 0.8656312023878318, 0.9445750230732326, 0.9894009349916499};
        static constexpr double kWeights[8] = {
            0.1894506104550685, 0.1826034150449236, 0.1691565193950025, 0.1495959888165767,
            0.1246289712555339, 0.0951585116824928, 0.0622535239386479, 0.0271524594117541};
        double sum = 0.0;
        for (int i = 0; i < 8; ++i) {
            for (double sign : {-1.0, 1.0}) {
                const double x = 0.5 * (1.0 + sign * kNodes[i]);
                const double c = -alpha - beta * x - gamma * x * x * x;
                const double qx = big_q * x;
                const double sinc = qx < 1e-8 ? 1.0 - qx * qx / 6.0 : std::sin(qx) / qx;
                sum += 0.5 * kWeights[i] * x * x * c * sinc;
            }
        }
        return 24.0 * phi * sum;
    }
    const double q = big_q, s = std::sin(q), c = std::cos(q);
    const double q2 = q * q, q3 = q2 * q, q4 = q2 * q2;
    // ∫_0^1 x² sin(Qx)/(Qx) x^p dx for p = 0, 1, 3, times Q⁶.
    const double i0 = q3 * (s - q * c);
    const double i1 = q2 * (2.0 * q * s - (q2 - 2.0) * c - 2.0);
    const double i3 = (4.0 * q3 - 24.0 * q) * s - (q4 - 12.0 * q2 + 24.0) * c + 24.0;
    return 24.0 * phi * (-alpha * i0 - beta * i1 - gamma * i3) / (q3 * q3);
}

}  // namespace

double percus_yevick_structure_factor(double q_per_um, double sigma_um, double phi) {
    require_py(sigma_um, phi);
    if (!(std::isfinite(q_per_um) && q_per_um >= 0.0)) {
        throw InputError(
            fmt::format("Percus-Yevick: q = {} 1/um: expected a finite q >= 0", q_per_um));
    }
    const double s = 1.0 / (1.0 - n_c_hat(q_per_um * sigma_um, phi));
    PLUMAGE_CHECK(std::isfinite(s) && s > 0.0, fmt::format("PY S(q) = {}", s));
    return s;
}

double percus_yevick_first_peak(double sigma_um, double phi) {
    require_py(sigma_um, phi);
    auto s = [&](double big_q) { return 1.0 / (1.0 - n_c_hat(big_q, phi)); };
    // Scan Q σ on (2, 4π) (the first peak lies near 2π·1.0–1.2 for any φ), then refine.
    const int steps = 400;
    double best_q = 2.0, best_s = s(2.0);
    const double dq = (4.0 * kPi - 2.0) / steps;
    for (int i = 1; i <= steps; ++i) {
        const double q = 2.0 + i * dq;
        if (const double v = s(q); v > best_s) {
            best_s = v;
            best_q = q;
        }
    }
    double lo = best_q - dq, hi = best_q + dq;
    const double golden = 0.5 * (std::sqrt(5.0) - 1.0);
    for (int it = 0; it < 100 && hi - lo > 1e-12; ++it) {
        const double a = hi - golden * (hi - lo), b = lo + golden * (hi - lo);
        if (s(a) > s(b)) {
            hi = b;
        } else {
            lo = a;
        }
    }
    return 0.5 * (lo + hi) / sigma_um;
}

MeasuredStructureFactor measure_structure_factor(const std::vector<Eigen::Vector3d>& centres_um,
                                                 double box_um, double q_max_per_um) {
    if (!(std::isfinite(box_um) && box_um > 0.0)) {
        throw InputError(
            fmt::format("structure factor: box_um = {}: expected a finite box side > 0", box_um));
    }
    if (centres_um.size() < 2) {
        throw InputError(
            fmt::format("structure factor: {} centres: expected at least 2", centres_um.size()));
    }
    for (const auto& c : centres_um) {
        for (int a = 0; a < 3; ++a) {
            if (!(c[a] >= 0.0 && c[a] < box_um)) {
                throw InputError(fmt::format(
                    "structure factor: centre ({}, {}, {}) um: expected it inside [0, {})^3", c[0],
                    c[1], c[2], box_um));
            }
        }
    }
    const double dq = 2.0 * kPi / box_um;
    const int shells = static_cast<int>(std::floor(q_max_per_um / dq + 0.5)) - 1;
    if (!(std::isfinite(q_max_per_um) && shells >= 1)) {
        throw InputError(fmt::format(
            "structure factor: q_max = {} 1/um: expected at least the second shell, >= {} 1/um",
            q_max_per_um, 1.5 * dq));
    }
    const int m_max = shells;  // |m| <= j_max + ½ needs |m_a| <= j_max
    const double n = static_cast<double>(centres_um.size());
    std::vector<double> power(shells + 1, 0.0), q_sum(shells + 1, 0.0);
    std::vector<std::size_t> modes(shells + 1, 0);

    // Per centre and axis, e^{−i Δq x m} for m = 0 … m_max by repeated multiplication
    // (exact to round-off over a few dozen steps), so the mode sum costs one complex
    // product per centre and mode.
    const std::size_t stride = static_cast<std::size_t>(m_max) + 1;
    std::vector<std::complex<double>> phase(centres_um.size() * 3 * stride);
    for (std::size_t p = 0; p < centres_um.size(); ++p) {
        for (int a = 0; a < 3; ++a) {
            const std::complex<double> step = std::polar(1.0, -dq * centres_um[p][a]);
            std::complex<double> value(1.0, 0.0);
            for (int m = 0; m <= m_max; ++m) {
                phase[(p * 3 + a) * stride + m] = value;
                value =
                    m % 16 == 15 ? std::polar(1.0, -dq * centres_um[p][a] * (m + 1)) : value * step;
            }
        }
    }
    auto factor = [&](std::size_t p, int axis, int m) {
        const std::complex<double> v = phase[(p * 3 + axis) * stride + std::abs(m)];
        return m >= 0 ? v : std::conj(v);
    };
    // Half space (Hermitian symmetry: S(−q) = S(q)): m_z > 0, or m_z = 0 and m_y > 0, or
    // m_z = m_y = 0 and m_x > 0; each mode counts twice.
    for (int mx = -m_max; mx <= m_max; ++mx) {
        for (int my = -m_max; my <= m_max; ++my) {
            for (int mz = 0; mz <= m_max; ++mz) {
                if (mz == 0 && (my < 0 || (my == 0 && mx <= 0))) continue;
                const double radius = std::sqrt(double(mx * mx + my * my + mz * mz));
                const auto shell = static_cast<int>(std::floor(radius + 0.5));
                if (shell < 1 || shell > shells) continue;
                std::complex<double> sum(0.0, 0.0);
                for (std::size_t p = 0; p < centres_um.size(); ++p) {
                    sum += factor(p, 0, mx) * factor(p, 1, my) * factor(p, 2, mz);
                }
                power[shell] += 2.0 * std::norm(sum) / n;
                q_sum[shell] += 2.0 * radius * dq;
                modes[shell] += 2;
            }
        }
    }
    MeasuredStructureFactor out;
    out.shell_width_per_um = dq;
    for (int j = 1; j <= shells; ++j) {
        PLUMAGE_CHECK(modes[j] > 0, "every shell holds reciprocal-lattice vectors");
        out.q_per_um.push_back(q_sum[j] / static_cast<double>(modes[j]));
        out.s.push_back(power[j] / static_cast<double>(modes[j]));
        out.modes.push_back(modes[j]);
    }
    return out;
}

double structure_factor_peak(const MeasuredStructureFactor& s, double q_min_per_um,
                             double q_max_per_um) {
    std::size_t best = s.s.size();
    for (std::size_t i = 0; i < s.s.size(); ++i) {
        if (s.q_per_um[i] < q_min_per_um || s.q_per_um[i] > q_max_per_um) continue;
        if (best == s.s.size() || s.s[i] > s.s[best]) best = i;
    }
    if (best == s.s.size()) {
        throw InputError(fmt::format("structure factor peak: no shell in [{}, {}] 1/um",
                                     q_min_per_um, q_max_per_um));
    }
    if (best == 0 || best + 1 == s.s.size()) return s.q_per_um[best];
    const double x0 = s.q_per_um[best - 1], x1 = s.q_per_um[best], x2 = s.q_per_um[best + 1];
    const double y0 = s.s[best - 1], y1 = s.s[best], y2 = s.s[best + 1];
    const double denominator = (x0 - x1) * (x0 - x2) * (x1 - x2);
    const double a = (x2 * (y1 - y0) + x1 * (y0 - y2) + x0 * (y2 - y1)) / denominator;
    const double b =
        (x2 * x2 * (y0 - y1) + x1 * x1 * (y2 - y0) + x0 * x0 * (y1 - y2)) / denominator;
    if (!(a < 0.0)) return x1;
    return -b / (2.0 * a);
}

}  // namespace plumage::sim::wave
