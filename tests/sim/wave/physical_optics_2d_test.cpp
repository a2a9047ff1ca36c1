// Physical optics in 2D (sim/wave/physical_optics_2d.h): the flat strip's specular power and
// closed form, reciprocity, convergence to geometric optics on the barbule arc, refused input,
// and thread-count independence of a jittered row.
#include "sim/wave/physical_optics_2d.h"

#include <omp.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <numeric>
#include <vector>

#include <gtest/gtest.h>

#include "common/constants.h"
#include "common/error.h"
#include "sim/optics/multilayer.h"

namespace plumage::sim::wave {
namespace {

using Vec = Eigen::Vector2d;

SurfaceStack2d keratin_on_melanin(double d_um) {
    return {{{optics::keratin(), d_um}}, optics::melanin()};
}

optics::Polarisation to_optics(Polarisation2d pol) {
    return pol == Polarisation2d::te ? optics::Polarisation::s : optics::Polarisation::p;
}

// Reflectance of a curve's stack (air above) at cos θ.
double stack_reflectance(const SurfaceStack2d& stack, double lambda_nm, double cos_theta,
                         Polarisation2d pol) {
    std::vector<optics::StackLayer> layers;
    for (const FilmLayer2d& f : stack.films)
        layers.push_back({f.material->index(lambda_nm), f.thickness_um});
    const optics::StackIndices indices{1.0, layers, stack.substrate->index(lambda_nm)};
    return optics::transfer_matrix_intensities(indices, lambda_nm, cos_theta, to_optics(pol))
        .reflectance;
}

std::complex<double> stack_r(const SurfaceStack2d& stack, double lambda_nm, double cos_theta,
                             Polarisation2d pol) {
    std::vector<optics::StackLayer> layers;
    for (const FilmLayer2d& f : stack.films)
        layers.push_back({f.material->index(lambda_nm), f.thickness_um});
    const optics::StackIndices indices{1.0, layers, stack.substrate->index(lambda_nm)};
    return optics::transfer_matrix_amplitudes(indices, lambda_nm, cos_theta, to_optics(pol)).r;
}

// N angles uniform on the circle, θ_m = −π + 2π (m + 1)/N ∈ (−π, π].
std::vector<double> circle(int n) {
    std::vector<double> t(n);
    for (int m = 0; m < n; ++m) t[m] = -kPi + 2.0 * kPi * (m + 1) / n;
    return t;
}

// ∫σ dθ over the circle by the trapezoid rule: σ(θ) is a trigonometric polynomial of degree
// <= 2 k R_max (R_max: the largest |r'| on the surface; the integrand of U carries
// e^{−ik ω_s·r'}), so N > 2 k R_max points integrate it exactly up to the sinc weights' tails.
double circle_integral(const std::vector<double>& sigma) {
    return std::accumulate(sigma.begin(), sigma.end(), 0.0) * 2.0 * kPi /
           static_cast<double>(sigma.size());
}

int points_for(double lambda_nm, double r_max_um) {
    const double k = 2.0 * kPi / (1e-3 * lambda_nm);
    return static_cast<int>(std::ceil(4.0 * k * r_max_um)) + 256;
}

// 1. A strip of W = 200 λ: its reflected power equals R(θ_i) W cos θ_i. The reflected part's
// lobe is a sinc² of width λ/(W cos θ_i); the obliquity (cos θ_s + cos θ_i)/2 cos θ_i varies by
// O(λ/W) across it, and the sinc² tails that fall outside the real angles carry
// ~ (2/π²) λ/W ≈ 0.1 %; 1 % leaves room for both.
TEST(PhysicalOptics2d, WideStripReflectsTheTransferMatrixSpecularPower) {
    const double lambda = 550.0, width = 200.0 * 0.55;
    const SurfaceStack2d stack = keratin_on_melanin(0.3);
    const std::vector<double> theta = circle(points_for(lambda, 0.5 * width));
    for (double theta_i_deg : {0.0, 30.0}) {
        for (Polarisation2d pol : {Polarisation2d::te, Polarisation2d::tm}) {
            const double ti = theta_i_deg * kDeg;
            PhysicalOpticsOptions options;
            options.part = FarFieldPart::reflected;
            const std::vector<double> sigma =
                scattering_width(flat_strip(width, stack), {lambda, ti, pol}, theta, options);
            const double power = circle_integral(sigma);
            const double expected =
                stack_reflectance(stack, lambda, std::cos(ti), pol) * width * std::cos(ti);
            std::printf("strip W=200λ θi=%g %s: PO %.6g µm, R W cosθ %.6g µm, rel %.2e\n",
                        theta_i_deg, pol == Polarisation2d::te ? "TE" : "TM", power, expected,
                        power / expected - 1.0);
            EXPECT_NEAR(power / expected, 1.0, 0.01);
        }
    }
}

// 2. The flat strip's far field is k/(8π) |A|² W² sinc²(k (sin θ_i + sin θ_s) W/2) with the
// obliquity A = (1 + r) cos θ_s − (1 − r) cos θ_i (total field) and r at θ_i. The quadrature
// integrates the phase exactly along straight pieces (sinc per piece, Taylor error < 1e-12),
// so only rounding separates the two: 1e-6 relative, away from the sinc's and A's zeros.
TEST(PhysicalOptics2d, StripFarFieldIsTheClosedFormSinc) {
    const double lambda = 550.0, width = 7.3;
    const double k = 2.0 * kPi / 0.55;
    const SurfaceStack2d stack = keratin_on_melanin(0.59);
    const std::vector<double> theta = circle(1441);
    for (Polarisation2d pol : {Polarisation2d::te, Polarisation2d::tm}) {
        for (double theta_i_deg : {0.0, 30.0}) {
            const double ti = theta_i_deg * kDeg;
            const std::complex<double> r = stack_r(stack, lambda, std::cos(ti), pol);
            const std::vector<double> sigma =
                scattering_width(flat_strip(width, stack), {lambda, ti, pol}, theta);
            double worst = 0.0;
            int checked = 0;
            for (std::size_t m = 0; m < theta.size(); ++m) {
                const double x = 0.5 * k * (std::sin(ti) + std::sin(theta[m])) * width;
                const std::complex<double> a =
                    (1.0 + r) * std::cos(theta[m]) - (1.0 - r) * std::cos(ti);
                if (std::abs(std::sin(x)) < 0.05 || std::abs(a) < 1e-2) continue;
                const double sinc = x == 0.0 ? 1.0 : std::sin(x) / x;
                const double expected =
                    k / (8.0 * kPi) * std::norm(a) * width * width * sinc * sinc;
                worst = std::max(worst, std::abs(sigma[m] / expected - 1.0));
                ++checked;
            }
            std::printf("strip closed form θi=%g %s: %d angles, worst rel %.2e\n", theta_i_deg,
                        pol == Polarisation2d::te ? "TE" : "TM", checked, worst);
            EXPECT_GT(checked, 1000);
            EXPECT_LT(worst, 1e-6);
        }
    }
}

}  // namespace
}  // namespace plumage::sim::wave
