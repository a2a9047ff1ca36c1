// Power spectra: Parseval normalisation, agreement with geometry::measure_power_spectrum,
// the voxelised sphere's (and disk's) form factor and its convergence with resolution, and
// the isotropy measure.
#include "sim/wave/volume/power_spectrum.h"
#include "common/constants.h"

#include <omp.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <complex>
#include <cstdio>
#include <numbers>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "tests/sim/wave/random_field.h"

#include "common/error.h"
#include "geometry/spongy_volume.h"
#include "sim/wave/volume/index_field.h"

namespace plumage::sim::wave {
namespace {

using fields::random_indicator;
using fields::real_space_variance;

TEST(WavePowerSpectrum, ParsevalIn3DAnd2D) {
    for (int n : {32, 33}) {  // even and odd N (the r2c mirror rule differs)
        const auto v3 = random_indicator(static_cast<std::size_t>(n) * n * n, 0.4, 5);
        const PowerSpectrum s3 = PowerSpectrum::measure_3d(v3, n, 0.02);
        EXPECT_NEAR(s3.variance() / real_space_variance(v3), 1.0, 1e-12) << "N = " << n;
        const auto v2 = random_indicator(static_cast<std::size_t>(n) * n, 0.6, 6);
        const PowerSpectrum s2 = PowerSpectrum::measure_2d(v2, n, 0.02);
        EXPECT_NEAR(s2.variance() / real_space_variance(v2), 1.0, 1e-12) << "N = " << n;
        // And for an indicator, Var = f (1 − f).
        const double f = s3.filling_fraction();
        EXPECT_NEAR(s3.variance(), f * (1.0 - f), 1e-12);
    }
}

// |DFT|² of the mean-subtracted field from the DFT's definition, term by term, at the
// half-complex modes in the spectrum's order, times h^d / N^d (the header's normalisation).
std::vector<double> power_by_definition(const std::vector<double>& v, std::array<int, 3> shape,
                                        int dimension, double h) {
    const auto [n0, n1, n2] = shape;
    const int half = n2 / 2 + 1;
    double mean = 0.0;
    for (double x : v) mean += x;
    mean /= static_cast<double>(v.size());
    std::vector<double> power;
    for (int k0 = 0; k0 < n0; ++k0)
        for (int k1 = 0; k1 < n1; ++k1)
            for (int k2 = 0; k2 < half; ++k2) {
                std::complex<double> sum = 0.0;
                for (int i0 = 0; i0 < n0; ++i0)
                    for (int i1 = 0; i1 < n1; ++i1)
                        for (int i2 = 0; i2 < n2; ++i2) {
                            const double phase = -kTwoPi * (static_cast<double>(k0 * i0) / n0 +
                                                            static_cast<double>(k1 * i1) / n1 +
                                                            static_cast<double>(k2 * i2) / n2);
                            const double x = v[(static_cast<std::size_t>(i0) * n1 + i1) * n2 + i2];
                            sum += (x - mean) * std::polar(1.0, phase);
                        }
                power.push_back(std::pow(h, dimension) * std::norm(sum) /
                                static_cast<double>(v.size()));
            }
    power[0] = 0.0;
    return power;
}

// The spectrum is FFTW's one-dimensional transforms along each axis in turn, dealt out in blocks
// (power_spectrum.cpp): against the DFT's definition on a cube of odd and one of even side
// (blocks and remainders along every axis) and on a 2D rectangle. Parseval's check cannot see an
// axis transformed twice or not at all; this can.
TEST(WavePowerSpectrum, MatchesTheDefinitionOfTheDft) {
    auto expect_equal = [](const std::vector<double>& measured, const std::vector<double>& exact,
                           const char* what) {
        ASSERT_EQ(measured.size(), exact.size()) << what;
        double largest = 0.0, worst = 0.0;
        for (std::size_t p = 0; p < exact.size(); ++p) {
            largest = std::max(largest, exact[p]);
            worst = std::max(worst, std::abs(measured[p] - exact[p]));
        }
        EXPECT_LT(worst, 1e-12 * largest) << what;  // round-off of O(N³) sums
    };
    for (int n : {5, 18}) {
        const auto v = random_indicator(static_cast<std::size_t>(n) * n * n, 0.4, 11);
        expect_equal(PowerSpectrum::measure_3d(v, n, 0.02).half_complex(),
                     power_by_definition(v, {n, n, n}, 3, 0.02), n == 5 ? "5³" : "18³");
    }
    const auto v = random_indicator(21 * 6, 0.3, 12);
    expect_equal(PowerSpectrum::measure_2d(v, 21, 6, 0.05).half_complex(),
                 power_by_definition(v, {1, 6, 21}, 2, 0.05), "21 × 6");
}

// The records must not depend on the thread count: neither may the spectrum, nor its radial
// average (FFTW's own threaded plans would not promise that; power_spectrum.cpp).
TEST(WavePowerSpectrum, IsTheSameOnAnyNumberOfThreads) {
    const auto v3 = random_indicator(40 * 40 * 40, 0.5, 13);
    const auto v2 = random_indicator(70 * 33, 0.5, 14);
    const int threads = omp_get_max_threads();
    omp_set_num_threads(1);
    const PowerSpectrum a3 = PowerSpectrum::measure_3d(v3, 40, 0.02);
    const PowerSpectrum a2 = PowerSpectrum::measure_2d(v2, 70, 33, 0.02);
    omp_set_num_threads(3);
    const PowerSpectrum b3 = PowerSpectrum::measure_3d(v3, 40, 0.02);
    const PowerSpectrum b2 = PowerSpectrum::measure_2d(v2, 70, 33, 0.02);
    omp_set_num_threads(threads);
    EXPECT_EQ(a3.half_complex(), b3.half_complex());
    EXPECT_EQ(a3.radial().power, b3.radial().power);
    EXPECT_EQ(a2.half_complex(), b2.half_complex());
    EXPECT_EQ(a2.radial().power, b2.radial().power);
}

TEST(WavePowerSpectrum, MatchesTheGeometrySpectrumOfAChannelVolume) {
    geometry::ChannelVolumeParams p;
    p.length_scale_um = 0.2;
    p.keratin_fraction = 0.5;
    p.box_um = 1.28;
    p.voxel_um = 0.02;
    const geometry::SpongyVolume v = geometry::make_channel_volume(p);
    const IndicatorField field = sample_indicator(*v.level_set);
    EXPECT_EQ(field.voxels_per_side, 64);
    EXPECT_DOUBLE_EQ(field.filling_fraction(), v.keratin_fraction);
    const PowerSpectrum s = PowerSpectrum::measure_3d(field.as_doubles(), 64, 0.02);
    const RadialSpectrum r = s.radial();
    ASSERT_EQ(r.power.size(), v.spectrum.power_um3.size());
    for (std::size_t i = 0; i < r.power.size(); ++i) {
        // Two FFT libraries (FFTW, Eigen's kissfft): agreement to round-off.
        EXPECT_NEAR(r.power[i], v.spectrum.power_um3[i], 1e-10 * v.spectrum.power_um3[i] + 1e-20);
        EXPECT_NEAR(r.q_per_um[i], v.spectrum.wavenumber_per_um[i], 1e-12 * r.q_per_um[i]);
        EXPECT_EQ(r.modes[i], v.spectrum.modes[i]);
    }
    EXPECT_NEAR(r.peak_q_per_um, v.spectrum.peak_wavenumber_per_um, 1e-9);
    // A channel volume is isotropic: the second-moment eigenvalues on the peak shell
    // (~1700 modes there, exponential per-mode power) stay within ~15 % of each other.
    std::printf(
        "channel volume: peak q %.3f 1/um, isotropy eigenvalue ratio %.3f on %zu "
        "modes\n",
        r.peak_q_per_um, r.isotropy_eigenvalue_ratio, r.modes[r.peak_shell]);
    EXPECT_LT(r.isotropy_eigenvalue_ratio, 1.15);
}

TEST(WavePowerSpectrum, LayeredFieldIsAnisotropic) {
    // Layers normal to z (a Bragg stack): all power on the ±z axis of the peak shell.
    const int n = 32;
    std::vector<double> v(static_cast<std::size_t>(n) * n * n);
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j)
            for (int k = 0; k < n; ++k)
                v[(static_cast<std::size_t>(i) * n + j) * n + k] = (k / 4) % 2 == 0 ? 1.0 : 0.0;
    const RadialSpectrum r = PowerSpectrum::measure_3d(v, n, 0.02).radial();
    std::printf("layered field: isotropy eigenvalue ratio %.3g\n", r.isotropy_eigenvalue_ratio);
    EXPECT_GT(r.isotropy_eigenvalue_ratio, 1e6);
}

// Largest deviation of S(q) L³ / V² from the form factor F(qR)² over the modes with
// qR <= 4 (before F's first zero at 4.49, where F² >= 0.02), for a sphere of radius R =
// `radius_voxels` voxels in a box of side 4R.
double sphere_form_factor_error(int radius_voxels) {
    const int n = 4 * radius_voxels;
    const double h = 0.01;
    const double radius = radius_voxels * h;
    // Centre off the lattice's symmetry points so that the error is generic.
    const double cx = 0.5 * n * h + 0.37 * h, cy = 0.5 * n * h + 0.21 * h, cz = 0.5 * n * h;
    std::vector<double> v(static_cast<std::size_t>(n) * n * n);
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j)
            for (int k = 0; k < n; ++k) {
                const double x = (i + 0.5) * h - cx, y = (j + 0.5) * h - cy, z = (k + 0.5) * h - cz;
                v[(static_cast<std::size_t>(i) * n + j) * n + k] =
                    x * x + y * y + z * z < radius * radius ? 1.0 : 0.0;
            }
    const PowerSpectrum s = PowerSpectrum::measure_3d(v, n, h);
    const double box = n * h, dq = 2.0 * kPi / box;
    const double volume = 4.0 / 3.0 * kPi * radius * radius * radius;
    const int half = n / 2 + 1;
    double worst = 0.0;
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j)
            for (int k = 0; k < half; ++k) {
                const int mi = 2 * i <= n ? i : i - n, mj = 2 * j <= n ? j : j - n;
                const double u = dq * radius * std::sqrt(double(mi * mi + mj * mj + k * k));
                if (u == 0.0 || u > 4.0) continue;
                const double f = 3.0 * (std::sin(u) - u * std::cos(u)) / (u * u * u);
                const double measured = s.at((static_cast<std::size_t>(i) * n + j) * half + k) *
                                        std::pow(box, 3) / (volume * volume);
                worst = std::max(worst, std::abs(measured - f * f));
            }
    return worst;
}

TEST(WavePowerSpectrum, VoxelisedSphereGivesTheFormFactor) {
    // The error of a voxelised sphere at qR <= 4 is dominated by its volume: the number of
    // lattice points in a ball misses 4πR³/3 by O(R) (the lattice-point problem), a relative
    // O((h/R)²); the staircase of the surface largely averages out at these q. Measured:
    // 0.4–0.6 (h/R)² at R = 6, 12, 24 voxels; bound 1.5 (h/R)², and the error must fall.
    double previous = 1.0;
    for (int radius_voxels : {6, 12, 24}) {
        const double error = sphere_form_factor_error(radius_voxels);
        std::printf("sphere form factor: R = %d voxels, max |S L^3/V^2 - F^2| = %.3e\n",
                    radius_voxels, error);
        const double h_over_r = 1.0 / radius_voxels;
        EXPECT_LT(error, 1.5 * h_over_r * h_over_r) << "R = " << radius_voxels << " voxels";
        EXPECT_LT(error, previous) << "R = " << radius_voxels << " voxels";
        previous = error;
    }
}

TEST(WavePowerSpectrum, VoxelisedDiskGivesTheFormFactorIn2D) {
    // 2D analogue: a disk of radius R, F(u) = 2 J1(u)/u, in a square of side 4R. The
    // lattice-point count of a disk misses πR² by O(R^{1/2}) (Gauss's circle problem), a
    // relative O((h/R)^{3/2}). Measured 0.19–0.25 (h/R)^{3/2}; bound 0.5 (h/R)^{3/2}.
    double previous = 1.0;
    for (int radius_pixels : {8, 16, 32}) {
        const int n = 4 * radius_pixels;
        const double h = 0.01, radius = radius_pixels * h;
        const double cx = 0.5 * n * h + 0.37 * h, cy = 0.5 * n * h + 0.21 * h;
        std::vector<double> v(static_cast<std::size_t>(n) * n);
        for (int j = 0; j < n; ++j)
            for (int k = 0; k < n; ++k) {
                const double y = (j + 0.5) * h - cx, z = (k + 0.5) * h - cy;
                v[static_cast<std::size_t>(j) * n + k] =
                    y * y + z * z < radius * radius ? 1.0 : 0.0;
            }
        const PowerSpectrum s = PowerSpectrum::measure_2d(v, n, h);
        const double box = n * h, dq = 2.0 * kPi / box, area = kPi * radius * radius;
        const int half = n / 2 + 1;
        double worst = 0.0;
        for (int j = 0; j < n; ++j)
            for (int k = 0; k < half; ++k) {
                const int mj = 2 * j <= n ? j : j - n;
                const double u = dq * radius * std::sqrt(double(mj * mj + k * k));
                if (u == 0.0 || u > 3.5) continue;  // first zero of J1 at 3.83
                const double f = 2.0 * std::cyl_bessel_j(1.0, u) / u;
                const double measured =
                    s.at(static_cast<std::size_t>(j) * half + k) * box * box / (area * area);
                worst = std::max(worst, std::abs(measured - f * f));
            }
        std::printf("disk form factor: R = %d pixels, max error %.3e\n", radius_pixels, worst);
        EXPECT_LT(worst, 0.5 * std::pow(1.0 / radius_pixels, 1.5));
        EXPECT_LT(worst, previous);
        previous = worst;
    }
}

TEST(WavePowerSpectrum, RefusesBadGrids) {
    EXPECT_THROW(PowerSpectrum::measure_3d(std::vector<double>(10), 4, 0.02), InputError);
    EXPECT_THROW(PowerSpectrum::measure_3d(std::vector<double>(27), 3, 0.02), InputError);
    EXPECT_THROW(PowerSpectrum::measure_2d(std::vector<double>(16), 4, 0.0), InputError);
}

}  // namespace
}  // namespace plumage::sim::wave
