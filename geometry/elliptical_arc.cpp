#include "geometry/elliptical_arc.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <fmt/format.h>

#include "common/error.h"

namespace plumage::geometry {

EllipticalArc::EllipticalArc(double semi_axis_x, double semi_axis_z, double phi0, double phi1)
    : a_(semi_axis_x), b_(semi_axis_z), phi0_(phi0), phi1_(phi1) {
    if (!std::isfinite(a_) || !(a_ > 0.0) || !std::isfinite(b_) || !(b_ > 0.0)) {
        throw InputError(
            fmt::format("elliptical arc: semi-axes {} and {}: expected finite values > 0", a_, b_));
    }
    if (!std::isfinite(phi0_) || !std::isfinite(phi1_) || !(phi1_ > phi0_) ||
        phi1_ - phi0_ > 2.0 * std::numbers::pi + 1e-12) {
        throw InputError(fmt::format(
            "elliptical arc: normal azimuths phi0 = {}, phi1 = {} rad: expected phi0 < phi1 <= "
            "phi0 + 2 pi (a longer arc would cover the ellipse twice)",
            phi0_, phi1_));
    }
}

Eigen::Vector2d EllipticalArc::point(double phi) const {
    const double s = std::sin(phi), c = std::cos(phi);
    const double q = std::sqrt(a_ * a_ * s * s + b_ * b_ * c * c);
    return {a_ * a_ * s / q, b_ * b_ * c / q};
}

Eigen::Vector2d EllipticalArc::normal(double phi) const { return {std::sin(phi), std::cos(phi)}; }
Eigen::Vector2d EllipticalArc::tangent(double phi) const { return {std::cos(phi), -std::sin(phi)}; }

double EllipticalArc::radius_of_curvature(double phi) const {
    const double s = std::sin(phi), c = std::cos(phi);
    return a_ * a_ * b_ * b_ / std::pow(a_ * a_ * s * s + b_ * b_ * c * c, 1.5);
}

double EllipticalArc::arc_length(double phi) const {
    // Composite Simpson on ρ(φ); 2000 panels resolve b/a down to 1e-3.
    constexpr int kPanels = 2000;
    const double h = (phi - phi0_) / kPanels;
    double sum = radius_of_curvature(phi0_) + radius_of_curvature(phi);
    for (int i = 1; i < kPanels; ++i) {
        sum += (i % 2 == 1 ? 4.0 : 2.0) * radius_of_curvature(phi0_ + i * h);
    }
    return sum * h / 3.0;
}

double EllipticalArc::projected_width(double psi) const {
    const Eigen::Vector2d p(std::cos(psi), -std::sin(psi));
    double lo = std::min(point(phi0_).dot(p), point(phi1_).dot(p));
    double hi = std::max(point(phi0_).dot(p), point(phi1_).dot(p));
    // Interior extremes: normal parallel to ±p, i.e. φ = ψ ± π/2 (mod 2π).
    for (double candidate : {psi + 0.5 * std::numbers::pi, psi - 0.5 * std::numbers::pi}) {
        for (int k = -2; k <= 2; ++k) {
            const double phi = candidate + 2.0 * std::numbers::pi * k;
            if (phi > phi0_ && phi < phi1_) {
                const double v = point(phi).dot(p);
                lo = std::min(lo, v);
                hi = std::max(hi, v);
            }
        }
    }
    return hi - lo;
}

std::vector<double> sample_normal_azimuths(double phi0, double phi1,
                                           const std::function<double(double)>& radius,
                                           const std::function<double(double)>& step_bound,
                                           double* chord_error) {
    std::vector<double> phis = {phi0};
    double max_chord = 0.0;
    while (phis.back() < phi1) {
        const double phi = phis.back();
        double step = step_bound(radius(phi));
        // The radius changes along the step: shrink until the whole step meets the bound.
        for (int i = 0; i < 30; ++i) {
            const double rho = std::min(
                {radius(phi), radius(phi + 0.5 * step), radius(std::min(phi + step, phi1))});
            const double allowed = step_bound(rho);
            if (allowed >= step) break;
            step = allowed;
        }
        const double next = std::min(phi + step, phi1);
        const double rho = std::min({radius(phi), radius(0.5 * (phi + next)), radius(next)});
        max_chord = std::max(max_chord, rho * (1.0 - std::cos(0.5 * (next - phi))));
        phis.push_back(phi1 - next < 1e-12 ? phi1 : next);
    }
    if (chord_error != nullptr) *chord_error = max_chord;
    return phis;
}

}  // namespace plumage::geometry
