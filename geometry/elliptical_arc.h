// An arc of the ellipse x²/A² + z²/B² = 1 in the x–z plane, parameterised by the
// direction of its outward normal (Huang et al. 2022, Fig. 7b): the normal at azimuth
// φ is n(φ) = (sin φ, 0, cos φ), measured from +z towards +x. Parameterising by the
// normal, not by the polar angle, makes the normal distribution a change of variable:
// the arc length per unit normal angle is the radius of curvature ρ(φ).
//
//   point     E(φ) = (A² sin φ, 0, B² cos φ) / sqrt(A² sin² φ + B² cos² φ)
//   curvature ρ(φ) = A² B² / (A² sin² φ + B² cos² φ)^{3/2}
//
// With A = 1, B = b this is Huang's Eq. 5: D_φ(φ) = ρ(φ) / H.
#pragma once

#include <functional>
#include <vector>

#include <Eigen/Core>

namespace plumage::geometry {

class EllipticalArc {
public:
    // Semi-axes A (along x) and B (along z), both > 0; normal azimuths φ0 < φ1 with
    // φ1 − φ0 <= 2π. Throws InputError naming the offending value.
    EllipticalArc(double semi_axis_x, double semi_axis_z, double phi0, double phi1);

    Eigen::Vector2d point(double phi) const;    // (x, z)
    Eigen::Vector2d normal(double phi) const;   // (sin φ, cos φ)
    Eigen::Vector2d tangent(double phi) const;  // dE/dφ / |dE/dφ| = (cos φ, −sin φ)
    double radius_of_curvature(double phi) const;
    // Arc length from φ0 to φ (numerical quadrature of ρ).
    double arc_length(double phi) const;

    // Width of the arc's shadow on a line perpendicular to the in-plane direction at
    // azimuth psi (light travelling along −(sin ψ, cos ψ)): the extent of the arc's
    // projection onto (cos ψ, −sin ψ). Extremes are at the endpoints or where the
    // normal is perpendicular to the viewing direction.
    double projected_width(double psi) const;

    double semi_axis_x() const { return a_; }
    double semi_axis_z() const { return b_; }
    double phi0() const { return phi0_; }
    double phi1() const { return phi1_; }

private:
    double a_, b_, phi0_, phi1_;
};

// Normal azimuths from φ0 to φ1 (both included) such that every step Δ meets
// step_bound(ρ) for the smallest radius of curvature radius(φ) along it; returns the
// largest chord error made, ρ(1 − cos(Δ/2)), through chord_error.
std::vector<double> sample_normal_azimuths(double phi0, double phi1,
                                           const std::function<double(double)>& radius,
                                           const std::function<double(double)>& step_bound,
                                           double* chord_error);

}  // namespace plumage::geometry
