// Structure factors: the Percus–Yevick closed form against its defining integral and its
// limits, and the measured S(q) of generated sphere packings against PY.
#include "sim/wave/structure_factor.h"
#include "common/constants.h"

#include <cmath>
#include <cstdio>
#include <numbers>
#include <vector>

#include <gtest/gtest.h>

#include "common/error.h"
#include "geometry/spongy_volume.h"

namespace plumage::sim::wave {
namespace {

// 1 − n ĉ(q) by composite Simpson on the Wertheim–Thiele c(r) (header of
// structure_factor.h): an independent route to the closed form.
double py_by_quadrature(double big_q, double phi) {
    const double alpha = std::pow(1.0 + 2.0 * phi, 2) / std::pow(1.0 - phi, 4);
    const double beta = -6.0 * phi * std::pow(1.0 + 0.5 * phi, 2) / std::pow(1.0 - phi, 4);
    const double gamma = 0.5 * phi * alpha;
    const int intervals = 20000;
    double sum = 0.0;
    for (int i = 0; i <= intervals; ++i) {
        const double x = static_cast<double>(i) / intervals;
        const double w = (i == 0 || i == intervals) ? 1.0 : (i % 2 ? 4.0 : 2.0);
        const double c = -alpha - beta * x - gamma * x * x * x;
        const double sinc = big_q * x == 0.0 ? 1.0 : std::sin(big_q * x) / (big_q * x);
        sum += w * x * x * c * sinc;
    }
    const double integral = sum / (3.0 * intervals);
    return 1.0 / (1.0 - 24.0 * phi * integral);
}

TEST(PercusYevick, ClosedFormMatchesTheDirectCorrelationIntegral) {
    for (double phi : {0.1, 0.3, 0.5}) {
        for (double big_q : {0.05, 0.5, 0.99, 1.01, 3.0, 7.0, 12.0, 30.0}) {
            // Simpson with 2·10⁴ intervals: error ~ (Q h)⁴ ≲ 1e-10 at Q = 30.
            EXPECT_NEAR(percus_yevick_structure_factor(big_q, 1.0, phi),
                        py_by_quadrature(big_q, phi), 1e-9)
                << "phi = " << phi << " q sigma = " << big_q;
        }
    }
}

TEST(PercusYevick, CompressibilityLimit) {
    for (double phi : {0.05, 0.2, 0.3, 0.5, 0.6}) {
        const double expected = std::pow(1.0 - phi, 4) / std::pow(1.0 + 2.0 * phi, 2);
        EXPECT_NEAR(percus_yevick_structure_factor(0.0, 0.2, phi), expected, 1e-13 * expected);
        // Continuous into q > 0 (S is even in q: S(q) − S(0) = O(q²)).
        EXPECT_NEAR(percus_yevick_structure_factor(1e-4, 0.2, phi), expected, 1e-9);
    }
}

TEST(PercusYevick, TendsToOneAtLargeQ) {
    // n ĉ falls like 24 φ (α + |β| + γ) / (qσ)²: the bound on |S − 1| at large qσ.
    for (double phi : {0.1, 0.3, 0.5}) {
        const double alpha = std::pow(1.0 + 2.0 * phi, 2) / std::pow(1.0 - phi, 4);
        const double beta = 6.0 * phi * std::pow(1.0 + 0.5 * phi, 2) / std::pow(1.0 - phi, 4);
        const double amplitude = 24.0 * phi * (alpha + beta + 0.5 * phi * alpha);
        for (double big_q : {100.0, 300.0, 1000.0}) {
            const double s = percus_yevick_structure_factor(big_q, 1.0, phi);
            EXPECT_LT(std::abs(s - 1.0), 1.1 * amplitude / (big_q * big_q))
                << "phi = " << phi << " q sigma = " << big_q;
        }
    }
}

TEST(PercusYevick, FirstPeakNearTwoPiOverSpacing) {
    // Known PY first-peak positions: q σ ≈ 6.5 at φ = 0.3 (grows towards ~7.0 at 0.5).
    const double peak03 = percus_yevick_first_peak(1.0, 0.3);
    const double peak05 = percus_yevick_first_peak(1.0, 0.5);
    EXPECT_GT(peak03, 6.0);
    EXPECT_LT(peak03, 7.0);
    EXPECT_GT(peak05, peak03);
    EXPECT_LT(peak05, 7.5);
    EXPECT_THROW(percus_yevick_structure_factor(1.0, 1.0, 0.7), InputError);
    EXPECT_THROW(percus_yevick_structure_factor(1.0, -1.0, 0.3), InputError);
}

struct PackingResult {
    double phi_hard_sphere;
    double measured_peak;
    double py_peak;
    double air_fraction;
};

// Averages S(q) over `seeds` generated packings and compares its first peak with PY at
// the packings' hard-core fraction φ_hs = N π s³ / (6 L³) (s the minimum separation).
PackingResult compare_packing(double keratin_fraction, double min_separation, int seeds) {
    geometry::SphereVolumeParams p;
    p.sphere_radius_um = 0.05;
    p.min_separation_diameters = min_separation;
    p.keratin_fraction = keratin_fraction;
    p.box_um = 1.5;
    p.voxel_um = 0.02;
    const double sigma = 2.0 * p.sphere_radius_um * min_separation;
    MeasuredStructureFactor mean;
    double phi_sum = 0.0, air_sum = 0.0;
    for (int s = 0; s < seeds; ++s) {
        p.seed = 11;
        p.item = static_cast<std::uint64_t>(s);
        const geometry::SpongyVolume v = geometry::make_sphere_volume(p);
        const auto count = static_cast<double>(v.air_sphere_centres_um.size());
        phi_sum += count * kPi * sigma * sigma * sigma / (6.0 * std::pow(v.box_um, 3));
        air_sum += 1.0 - v.keratin_fraction;
        const MeasuredStructureFactor one =
            measure_structure_factor(v.air_sphere_centres_um, v.box_um, 12.0 / sigma);
        if (s == 0) {
            mean = one;
        } else {
            for (std::size_t i = 0; i < one.s.size(); ++i) mean.s[i] += one.s[i];
        }
    }
    for (double& value : mean.s) value /= seeds;
    PackingResult r;
    r.phi_hard_sphere = phi_sum / seeds;
    r.air_fraction = air_sum / seeds;
    r.py_peak = percus_yevick_first_peak(sigma, r.phi_hard_sphere);
    r.measured_peak = structure_factor_peak(mean, 0.5 * r.py_peak, 1.5 * r.py_peak);
    std::printf(
        "packing: air fraction %.4f, min separation %.2f diameters, phi_hs %.4f: "
        "S(q) peak %.3f 1/um, PY %.3f 1/um (%+.2f %%)\n",
        r.air_fraction, min_separation, r.phi_hard_sphere, r.measured_peak, r.py_peak,
        100.0 * (r.measured_peak / r.py_peak - 1.0));
    return r;
}

TEST(WaveStructureFactor, MeasuredTendsToOneAndIsPositive) {
    geometry::SphereVolumeParams p;
    p.sphere_radius_um = 0.05;
    p.min_separation_diameters = 1.0;
    p.keratin_fraction = 0.8;
    p.box_um = 1.0;
    p.voxel_um = 0.02;
    const geometry::SpongyVolume v = geometry::make_sphere_volume(p);
    const MeasuredStructureFactor s =
        measure_structure_factor(v.air_sphere_centres_um, v.box_um, 40.0 / 0.1);
    // Beyond q σ = 25 the hard-core correlations have died out (PY: |S − 1| < 0.02);
    // the shell mean over M modes of |Σ e^{iq·r}|²/N fluctuates by ~1/√M.
    double mean = 0.0;
    int count = 0;
    for (std::size_t i = 0; i < s.s.size(); ++i) {
        EXPECT_GE(s.s[i], 0.0);
        if (s.q_per_um[i] * 0.1 > 25.0) {
            mean += s.s[i];
            ++count;
        }
    }
    ASSERT_GT(count, 5);
    EXPECT_NEAR(mean / count, 1.0, 0.03);
}

TEST(WaveStructureFactor, DisjointPackingAtPhi03FollowsPercusYevick) {
    // Disjoint spheres (separation = one diameter): air fraction 0.3 is φ_hs = 0.3.
    const PackingResult r = compare_packing(0.7, 1.0, 4);
    EXPECT_NEAR(r.phi_hard_sphere, 0.3, 0.02);
    EXPECT_NEAR(r.measured_peak / r.py_peak, 1.0, 0.03);
}

TEST(WaveStructureFactor, HighestDisjointPackingFollowsPercusYevick) {
    // Random sequential addition jams at φ ≈ 0.38 (geometry/spongy_volume.h), so disjoint
    // packings cannot reach φ = 0.5. In this box (1.5 µm, r = 0.05 µm, 20 nm voxels) the
    // default 2·10⁶ attempts stop at an air fraction of 0.355: 0.35 is the highest tested.
    const PackingResult r = compare_packing(0.65, 1.0, 3);
    EXPECT_NEAR(r.phi_hard_sphere, 0.35, 0.02);
    EXPECT_NEAR(r.measured_peak / r.py_peak, 1.0, 0.03);
}

TEST(WaveStructureFactor, OverlappingPackingAtAirFractionHalf) {
    // Air fraction 0.5 is reached with overlapping spheres (separation 0.8 diameters); the
    // centres are then hard spheres of diameter s = 0.8 · 2r at φ_hs = N π s³/(6L³).
    const PackingResult r = compare_packing(0.5, 0.8, 3);
    EXPECT_NEAR(r.measured_peak / r.py_peak, 1.0, 0.03);
}

TEST(WaveStructureFactor, RefusesBadInput) {
    const std::vector<Eigen::Vector3d> one = {Eigen::Vector3d(0.1, 0.1, 0.1)};
    EXPECT_THROW(measure_structure_factor(one, 1.0, 50.0), InputError);
    const std::vector<Eigen::Vector3d> outside = {Eigen::Vector3d(0.1, 0.1, 0.1),
                                                  Eigen::Vector3d(1.1, 0.1, 0.1)};
    EXPECT_THROW(measure_structure_factor(outside, 1.0, 50.0), InputError);
}

}  // namespace
}  // namespace plumage::sim::wave
