// Gauss–Legendre quadrature, the suite's one rule for it: ∫₋₁¹ f(x) dx ≈ Σ w_i f(x_i), exact for
// polynomials of degree 2n − 1. gauss_legendre(n) computes any n; the 8- and 16-node tables are
// the same rule written out to 16 digits for the Huang model's inner cubatures, where the nodes
// must be compile-time constants (a test checks them against gauss_legendre(8) and (16)).
//
// Users: the first-Born medium's integral over the scattering angle (512 nodes), the goniometer's
// cone cubature (in the disc's area fraction), the Huang fit's illumination nodes, the scattering
// slab's composite rule and the Huang model's cubatures (the tables).
#pragma once

#include <array>
#include <vector>

namespace plumage {

// Nodes in decreasing order (x_0 closest to +1), weights summing to 2.
struct GaussLegendreRule {
    std::vector<double> nodes, weights;
};

// The n-node rule on [−1, 1] by Newton's method on P_n from x = cos(π (i + 3/4) / (n + 1/2)),
// converged to |Δx| < 1e-15: nodes to 1e-15, weights to 1e-13 relative (P_n'(x) by the
// recurrence cancels near x = ±1; far below any cubature error the suite states). Throws
// InputError for n outside [1, 4096].
GaussLegendreRule gauss_legendre(int n);

inline constexpr std::array<double, 8> kGl8Nodes = {
    -0.9602898564975363, -0.7966664774136267, -0.5255324099163290, -0.1834346424956498,
    0.1834346424956498,  0.5255324099163290,  0.7966664774136267,  0.9602898564975363};
inline constexpr std::array<double, 8> kGl8Weights = {
    0.1012285362903763, 0.2223810344533745, 0.3137066458778873, 0.3626837833783620,
    0.3626837833783620, 0.3137066458778873, 0.2223810344533745, 0.1012285362903763};
inline constexpr std::array<double, 16> kGl16Nodes = {
    -0.9894009349916499, -0.9445750230732326, -0.8656312023878318, -0.7554044083550030,
    -0.6178762444026438, -0.4580167776572274, -0.2816035507792589, -0.0950125098376374,
    0.0950125098376374,  0.2816035507792589,  0.4580167776572274,  0.6178762444026438,
    0.7554044083550030,  0.8656312023878318,  0.9445750230732326,  0.9894009349916499};
inline constexpr std::array<double, 16> kGl16Weights = {
    0.0271524594117541, 0.0622535239386479, 0.0951585116824928, 0.1246289712555339,
    0.1495959888165767, 0.1691565193950025, 0.1826034150449236, 0.1894506104550685,
    0.1894506104550685, 0.1826034150449236, 0.1691565193950025, 0.1495959888165767,
    0.1246289712555339, 0.0951585116824928, 0.0622535239386479, 0.0271524594117541};

}  // namespace plumage
