#include "sim/optics/multilayer.h"

#include <array>
#include <cmath>
#include <numbers>
#include <optional>

#include <fmt/format.h>

#include "common/error.h"
#include "sim/optics/thin_film.h"

namespace plumage::optics {
namespace {

// The stack as a list of media 0..N+1 (ambient, layers, substrate), each with its
// index, normal wavevector q and phase thickness δ = k0 q d (zero for the half-spaces).
class Media {
public:
    Media(const StackIndices& stack, double lambda_nm, double cos_theta_i) : stack_(stack) {
        require_lossless_incidence(Complex(stack.ambient), "multilayer (ambient medium)");
        require_passive_medium(stack.substrate, "multilayer (substrate)");
        require_cos_theta(cos_theta_i);
        require_wavelength(lambda_nm);
        for (std::size_t j = 0; j < stack.layers.size(); ++j) {
            const std::string what = fmt::format("multilayer (layer {})", j + 1);
            require_passive_medium(stack.layers[j].n, what.c_str());
            require_thickness(stack.layers[j].thickness_um);
        }
        grazing_ = cos_theta_i == 0.0;
        const double k0 = 2.0 * std::numbers::pi / lambda_nm;
        q_.resize(count());
        delta_.assign(count(), Complex(0.0));
        q_.front() = Complex(stack.ambient * cos_theta_i);
        for (std::size_t j = 1; j < count(); ++j)
            q_[j] = normal_wavevector(n(j), stack.ambient, cos_theta_i);
        for (std::size_t j = 1; j + 1 < count(); ++j) {
            delta_[j] = k0 * 1000.0 * stack.layers[j - 1].thickness_um * q_[j];
        }
    }

    std::size_t count() const { return stack_.layers.size() + 2; }
    Complex n(std::size_t j) const {
        if (j == 0) return Complex(stack_.ambient);
        if (j == count() - 1) return stack_.substrate;
        return stack_.layers[j - 1].n;
    }
    Complex q(std::size_t j) const { return q_[j]; }
    Complex delta(std::size_t j) const { return delta_[j]; }
    bool incoherent(std::size_t j) const {
        return j > 0 && j + 1 < count() && stack_.layers[j - 1].coherence == Coherence::incoherent;
    }
    FresnelAmplitudes interface(std::size_t from, std::size_t to, Polarisation pol) const {
        return fresnel_amplitudes(n(from), q(from), n(to), q(to), pol);
    }
    double flux_factor(std::size_t from, std::size_t to, Polarisation pol) const {
        return transmittance_factor(n(from), q(from), n(to), q(to), pol);
    }
    // At exactly grazing incidence (q_0 = 0) the matrix products become 0/0, but the
    // answer is simple: nothing enters the first medium of positive thickness that
    // differs from the ambient one (r = −1, t = 0); if there is none, the stack is
    // optically absent (r = 0, t = 1). Zero-thickness layers are no layers.
    std::optional<StackAmplitudes> grazing_amplitudes() const {
        if (!grazing_) return std::nullopt;
        for (std::size_t j = 1; j < count(); ++j) {
            const bool present = j + 1 == count() || stack_.layers[j - 1].thickness_um > 0.0;
            if (present && n(j) != n(0)) return StackAmplitudes{Complex(-1.0), Complex(0.0)};
        }
        return StackAmplitudes{Complex(0.0), Complex(1.0)};
    }

private:
    const StackIndices& stack_;
    bool grazing_ = false;
    std::vector<Complex> q_;
    std::vector<Complex> delta_;
};

// Transfer-matrix product over the coherent run of media first → last (either
// direction), with the bounded factorisation described in multilayer.h.
StackAmplitudes coherent_run(const Media& m, std::size_t first, std::size_t last,
                             Polarisation pol) {
    using Matrix = std::array<Complex, 4>;  // row-major 2×2
    Matrix product{Complex(1.0), Complex(0.0), Complex(0.0), Complex(1.0)};
    Complex transmission_product(1.0);
    Complex phase_sum(0.0);
    const int step = last > first ? 1 : -1;
    for (std::size_t j = first; j != last;
         j = static_cast<std::size_t>(static_cast<long>(j) + step)) {
        if (j != first) {
            // Layer j: diag(1, e^{2iδ}) applied on the right scales the second column.
            const Complex e2 = std::exp(Complex(0.0, 2.0) * m.delta(j));
            product[1] *= e2;
            product[3] *= e2;
            phase_sum += m.delta(j);
        }
        const std::size_t next = static_cast<std::size_t>(static_cast<long>(j) + step);
        const FresnelAmplitudes f = m.interface(j, next, pol);
        // Right-multiply by [[1, r], [r, 1]].
        const Matrix p = product;
        product = {p[0] + p[1] * f.r, p[0] * f.r + p[1], p[2] + p[3] * f.r, p[2] * f.r + p[3]};
        transmission_product *= f.t;
    }
    return {product[2] / product[0],
            transmission_product * std::exp(Complex(0.0, 1.0) * phase_sum) / product[0]};
}

struct RunIntensities {
    double reflectance, transmittance;
};

RunIntensities run_intensities(const Media& m, std::size_t first, std::size_t last,
                               Polarisation pol) {
    const StackAmplitudes a = coherent_run(m, first, last, pol);
    return {std::norm(a.r), std::norm(a.t) * m.flux_factor(first, last, pol)};
}

// Forward and backward intensities of a partially reflecting element.
struct Element {
    double r_front, t_forward, r_back, t_backward;
};

Element element(const Media& m, std::size_t top, std::size_t bottom, Polarisation pol) {
    const RunIntensities forward = run_intensities(m, top, bottom, pol);
    const RunIntensities backward = run_intensities(m, bottom, top, pol);
    return {forward.reflectance, forward.transmittance, backward.reflectance,
            backward.transmittance};
}

// Element a, then a layer of single-pass power transmission p, then element b:
// the incoherent sum of all multiple reflections between them.
Element combine(const Element& a, double p, const Element& b) {
    const double p2 = p * p;
    const double denominator = 1.0 - a.r_back * b.r_front * p2;
    if (!(denominator > 0.0)) {
        // Both facing reflectances are 1 and the layer is lossless: light never leaves.
        return {a.r_front, 0.0, b.r_back, 0.0};
    }
    return {a.r_front + a.t_forward * a.t_backward * b.r_front * p2 / denominator,
            a.t_forward * b.t_forward * p / denominator,
            b.r_back + b.t_backward * b.t_forward * a.r_back * p2 / denominator,
            b.t_backward * a.t_backward * p / denominator};
}

StackIntensities finish(double reflectance, double transmittance) {
    PLUMAGE_CHECK(std::isfinite(reflectance) && std::isfinite(transmittance),
                  fmt::format("R = {}, T = {}", reflectance, transmittance));
    return {reflectance, transmittance, 1.0 - reflectance - transmittance};
}

}  // namespace

StackAmplitudes transfer_matrix_amplitudes(const StackIndices& stack, double lambda_nm,
                                           double cos_theta_i, Polarisation pol) {
    const Media m(stack, lambda_nm, cos_theta_i);
    for (std::size_t j = 1; j + 1 < m.count(); ++j) {
        if (m.incoherent(j)) {
            throw InputError(fmt::format(
                "multilayer: layer {} is flagged incoherent, so the stack has no amplitude; "
                "ask for intensities instead",
                j));
        }
    }
    if (const auto grazing = m.grazing_amplitudes()) return *grazing;
    return coherent_run(m, 0, m.count() - 1, pol);
}

StackIntensities transfer_matrix_intensities(const StackIndices& stack, double lambda_nm,
                                             double cos_theta_i, Polarisation pol) {
    const Media m(stack, lambda_nm, cos_theta_i);
    if (const auto grazing = m.grazing_amplitudes()) {
        const double r = std::norm(grazing->r);
        return {r, 1.0 - r, 0.0};
    }
    const std::size_t last = m.count() - 1;
    std::size_t run_start = 0;
    Element total{};
    bool have_total = false;
    double pending_attenuation = 1.0;
    for (std::size_t j = 1; j <= last; ++j) {
        if (j != last && !m.incoherent(j)) continue;
        const Element e = element(m, run_start, j, pol);
        total = have_total ? combine(total, pending_attenuation, e) : e;
        have_total = true;
        if (j != last) {
            // Single-pass power transmission |e^{iδ}|² of the incoherent layer.
            pending_attenuation = std::exp(-2.0 * m.delta(j).imag());
            run_start = j;
        }
    }
    return finish(total.r_front, total.t_forward);
}

StackIntensities transfer_matrix_intensities_unpolarised(const StackIndices& stack,
                                                         double lambda_nm, double cos_theta_i) {
    const StackIntensities s =
        transfer_matrix_intensities(stack, lambda_nm, cos_theta_i, Polarisation::s);
    const StackIntensities p =
        transfer_matrix_intensities(stack, lambda_nm, cos_theta_i, Polarisation::p);
    return {0.5 * (s.reflectance + p.reflectance), 0.5 * (s.transmittance + p.transmittance),
            0.5 * (s.absorptance + p.absorptance)};
}

std::vector<double> coherent_layer_absorption(const StackIndices& stack, double lambda_nm,
                                              double cos_theta_i, Polarisation pol) {
    const Media m(stack, lambda_nm, cos_theta_i);
    const std::size_t last = m.count() - 1;
    std::vector<double> absorption(stack.layers.size(), 0.0);
    for (std::size_t j = 1; j < last; ++j) {
        if (m.incoherent(j)) {
            throw InputError(fmt::format(
                "multilayer: layer {} is incoherent; per-layer absorption from fields needs "
                "an all-coherent stack",
                j));
        }
    }
    if (m.grazing_amplitudes()) return absorption;  // nothing propagates into any layer

    // Rouard's recursion (not the matrix product above): ρ_j = w / v just above the
    // interface j → j+1 and Γ_j = ρ_j e^{2iδ_j} the same ratio at the top of medium j,
    // from the bottom up (Γ = 0 in the substrate: nothing comes back from below).
    std::vector<Complex> gamma(m.count(), Complex(0.0));
    std::vector<Complex> rho(m.count(), Complex(0.0));
    std::vector<FresnelAmplitudes> interfaces(last);
    for (std::size_t j = last; j-- > 0;) {
        interfaces[j] = m.interface(j, j + 1, pol);
        rho[j] = (interfaces[j].r + gamma[j + 1]) / (1.0 + interfaces[j].r * gamma[j + 1]);
        gamma[j] = j == 0 ? rho[j] : rho[j] * std::exp(Complex(0.0, 2.0) * m.delta(j));
    }
    // Normal Poynting flux of the pair (v, w) in medium j, per unit incident flux.
    const double incident = m.q(0).real();
    auto flux = [&](std::size_t j, Complex v, Complex w) {
        const Complex nj = m.n(j);
        const Complex qj = m.q(j);
        if (pol == Polarisation::s) return (qj * std::conj(v + w) * (v - w)).real() / incident;
        return (nj * std::conj(qj / nj) * (v + w) * std::conj(v - w)).real() / incident;
    };
    // Forward amplitudes from the top down. Each step multiplies by e^{iδ} (modulus
    // <= 1) or a Fresnel ratio, so a thick absorbing layer underflows to zero field
    // instead of overflowing.
    Complex v_above(1.0);  // forward amplitude just above interface j-1 → j
    for (std::size_t j = 1; j < last; ++j) {
        const FresnelAmplitudes& f = interfaces[j - 1];
        const Complex v_top = v_above * f.t / (1.0 + f.r * gamma[j]);
        v_above = v_top * std::exp(Complex(0.0, 1.0) * m.delta(j));
        absorption[j - 1] = flux(j, v_top, gamma[j] * v_top) - flux(j, v_above, rho[j] * v_above);
    }
    return absorption;
}

}  // namespace plumage::optics
