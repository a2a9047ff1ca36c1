#include "sim/optics/material.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "common/error.h"
#include "common/require.h"
#include "sim/optics/spectrum.h"
#include "sim/optics/thin_film.h"

namespace plumage::optics {

CauchyMaterial::CauchyMaterial(std::string name, double a, double b_nm2, double k_amplitude,
                               double k_decay_nm)
    : name_(std::move(name)),
      a_(a),
      b_nm2_(b_nm2),
      k_amplitude_(k_amplitude),
      k_decay_nm_(k_decay_nm) {
    const std::string what = fmt::format("material '{}'", name_);
    require(std::isfinite(a) && a > 0.0, what, "A", a, "a finite value > 0");
    require(std::isfinite(b_nm2) && b_nm2 >= 0.0, what, "B (nm^2)", b_nm2, "a finite value >= 0");
    require(std::isfinite(k_amplitude) && k_amplitude >= 0.0, what, "C (k amplitude)", k_amplitude,
            "a finite value >= 0");
    require(std::isfinite(k_decay_nm) && k_decay_nm > 0.0, what, "D (k decay, nm)", k_decay_nm,
            "a finite value > 0");
}

std::complex<double> CauchyMaterial::index(double lambda_nm) const {
    require_wavelength(lambda_nm);
    const double n = a_ + b_nm2_ / (lambda_nm * lambda_nm);
    const double k = k_amplitude_ == 0.0 ? 0.0 : k_amplitude_ * std::exp(-lambda_nm / k_decay_nm_);
    return {n, k};
}

ConstantMaterial::ConstantMaterial(std::string name, std::complex<double> n)
    : name_(std::move(name)), n_(n) {
    if (!std::isfinite(n.real()) || !std::isfinite(n.imag()) || !(n.real() > 0.0) ||
        n.imag() < 0.0) {
        throw InputError(fmt::format("material '{}': n = {} + {}i: expected n > 0 and k >= 0",
                                     name_, n.real(), n.imag()));
    }
}

std::complex<double> ConstantMaterial::index(double lambda_nm) const {
    require_wavelength(lambda_nm);
    return n_;
}

TabulatedMaterial::TabulatedMaterial(std::string name, std::vector<double> lambda_nm,
                                     std::vector<double> n, std::vector<double> k)
    : name_(std::move(name)), lambda_nm_(std::move(lambda_nm)), n_(std::move(n)), k_(std::move(k)) {
    if (n_.size() != lambda_nm_.size() || k_.size() != lambda_nm_.size()) {
        throw InputError(fmt::format(
            "material '{}': table columns have {} wavelengths, {} n and {} k values: expected "
            "equal lengths",
            name_, lambda_nm_.size(), n_.size(), k_.size()));
    }
    try {
        WavelengthGrid check(lambda_nm_);
    } catch (const InputError& e) {
        throw InputError(fmt::format("material '{}': {}", name_, e.what()));
    }
    for (std::size_t i = 0; i < n_.size(); ++i) {
        if (!std::isfinite(n_[i]) || !(n_[i] > 0.0) || !std::isfinite(k_[i]) || k_[i] < 0.0) {
            throw InputError(fmt::format(
                "material '{}': row {} ({} nm) has n = {}, k = {}: expected n > 0 and k >= 0",
                name_, i, lambda_nm_[i], n_[i], k_[i]));
        }
    }
}

std::complex<double> TabulatedMaterial::index(double lambda_nm) const {
    require_wavelength(lambda_nm);
    if (lambda_nm < lambda_nm_.front() || lambda_nm > lambda_nm_.back()) {
        throw InputError(fmt::format("material '{}': {} nm is outside its table ({}..{} nm)", name_,
                                     lambda_nm, lambda_nm_.front(), lambda_nm_.back()));
    }
    const auto upper = std::upper_bound(lambda_nm_.begin(), lambda_nm_.end(), lambda_nm);
    if (upper == lambda_nm_.end()) return {n_.back(), k_.back()};
    const std::size_t i = static_cast<std::size_t>(upper - lambda_nm_.begin()) - 1;
    const double f = (lambda_nm - lambda_nm_[i]) / (lambda_nm_[i + 1] - lambda_nm_[i]);
    return {(1.0 - f) * n_[i] + f * n_[i + 1], (1.0 - f) * k_[i] + f * k_[i + 1]};
}

std::shared_ptr<const Material> keratin() {
    static const auto material = std::make_shared<const CauchyMaterial>("keratin", 1.532, 5890.0);
    return material;
}

std::shared_ptr<const Material> melanin() {
    static const auto material =
        std::make_shared<const CauchyMaterial>("melanin", 1.648, 23700.0, 0.56, 270.0);
    return material;
}

std::shared_ptr<const Material> air() {
    static const auto material = std::make_shared<const ConstantMaterial>("air", 1.0);
    return material;
}

}  // namespace plumage::optics
