// Structure factors: the Percus–Yevick closed form against its defining integral and its
// limits, and the measured S(q) of generated sphere packings against PY.
#include "sim/wave/volume/structure_factor.h"
#include "common/constants.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <vector>

#include <gtest/gtest.h>

#include "common/error.h"
#include "geometry/hard_sphere_packing.h"
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

// ---------------------------------------------------------------------------------------
// Hard-sphere packings by Monte Carlo compression (geometry/hard_sphere_packing.h): true
// hard spheres at φ = 0.5, beyond the φ ≈ 0.38 where random sequential addition jams.

struct HardSphereResult {
    double measured_peak = 0.0;
    double py_peak = 0.0;
    double seconds_per_packing = 0.0;
};

// Averages S(q) over `seeds` packings of `count` spheres of diameter σ = 0.1 µm at φ and
// compares its first peak with PY at the same φ (as compare_packing). Checks every
// packing: no overlap, the fraction reached, a live (not jammed) equilibration.
HardSphereResult compare_hard_spheres(double phi, std::int64_t count, int seeds) {
    const double sigma = 0.1;
    geometry::HardSpherePackingParams p;
    p.count = count;
    p.volume_fraction = phi;
    p.box_um = sigma * std::cbrt(static_cast<double>(count) * kPi / (6.0 * phi));
    p.equilibration_sweeps = 300;
    MeasuredStructureFactor mean;
    double seconds = 0.0;
    for (int s = 0; s < seeds; ++s) {
        p.seed = 7;
        p.item = static_cast<std::uint64_t>(s);
        const auto start = std::chrono::steady_clock::now();
        const geometry::HardSpherePacking packing = geometry::make_hard_sphere_packing(p);
        seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        EXPECT_EQ(packing.centres_um.size(), static_cast<std::size_t>(count));
        EXPECT_NEAR(packing.diameter_um, sigma, 1e-12 * sigma);
        EXPECT_NEAR(packing.volume_fraction, phi, 1e-12);
        // Independent all-pairs check of the hard core (nearest periodic image).
        double min_d2 = std::numeric_limits<double>::infinity();
        for (std::size_t i = 0; i < packing.centres_um.size(); ++i) {
            for (std::size_t j = i + 1; j < packing.centres_um.size(); ++j) {
                Eigen::Vector3d d = packing.centres_um[i] - packing.centres_um[j];
                for (int a = 0; a < 3; ++a) d[a] -= p.box_um * std::round(d[a] / p.box_um);
                min_d2 = std::min(min_d2, d.squaredNorm());
            }
        }
        EXPECT_GE(std::sqrt(min_d2), packing.diameter_um * (1.0 - 1e-12));
        // A fluid keeps moving: a jammed packing would accept (almost) nothing.
        EXPECT_GT(packing.acceptance_ratio, 0.2);
        std::printf(
            "hard spheres phi %.2f, N %lld, item %d: %lld compression + %lld equilibration "
            "sweeps, acceptance %.3f, step %.4f sigma, min distance %.6f sigma, %.2f s\n",
            phi, static_cast<long long>(count), s,
            static_cast<long long>(packing.compression_sweeps),
            static_cast<long long>(packing.equilibration_sweeps), packing.acceptance_ratio,
            packing.step_um / sigma, std::sqrt(min_d2) / sigma,
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
        const MeasuredStructureFactor one =
            measure_structure_factor(packing.centres_um, p.box_um, 12.0 / sigma);
        if (s == 0) {
            mean = one;
        } else {
            for (std::size_t i = 0; i < one.s.size(); ++i) mean.s[i] += one.s[i];
        }
    }
    for (double& value : mean.s) value /= seeds;
    HardSphereResult r;
    r.seconds_per_packing = seconds / seeds;
    r.py_peak = percus_yevick_first_peak(sigma, phi);
    r.measured_peak = structure_factor_peak(mean, 0.5 * r.py_peak, 1.5 * r.py_peak);
    std::size_t best = 0;
    for (std::size_t i = 0; i < mean.s.size(); ++i) {
        if (mean.s[i] > mean.s[best]) best = i;
    }
    std::printf(
        "hard spheres phi %.2f: S(q) peak %.3f 1/um (q sigma %.3f, S %.3f), PY %.3f 1/um "
        "(q sigma %.3f, S %.3f): %+.2f %%; %.2f s per packing\n",
        phi, r.measured_peak, r.measured_peak * sigma, mean.s[best], r.py_peak, r.py_peak * sigma,
        percus_yevick_structure_factor(r.py_peak, sigma, phi),
        100.0 * (r.measured_peak / r.py_peak - 1.0), r.seconds_per_packing);
    return r;
}

TEST(HardSpherePacking, PhiHalfFollowsPercusYevick) {
    // The 3 % on the first-peak position. Measured (N = 1000, L = 10.2 σ, 2 seeds):
    // +0.5 %. The shells are 2π/L = 0.62/σ wide, so the shell-averaged peak height (≈ 2.5)
    // is below PY's 3.24 and is not asserted; the position comes from the parabola vertex.
    const HardSphereResult r = compare_hard_spheres(0.5, 1000, 2);
    EXPECT_NEAR(r.measured_peak / r.py_peak, 1.0, 0.03);
}

TEST(HardSpherePacking, PhiPoint3FollowsPercusYevick) {
    // Cross-check at a fraction RSA also reaches (DisjointPackingAtPhi03FollowsPercusYevick).
    const HardSphereResult r = compare_hard_spheres(0.3, 1000, 2);
    EXPECT_NEAR(r.measured_peak / r.py_peak, 1.0, 0.03);
}

TEST(HardSpherePacking, IsDeterministic) {
    geometry::HardSpherePackingParams p;
    p.count = 200;
    p.box_um = 1.0;
    p.volume_fraction = 0.45;
    p.equilibration_sweeps = 20;
    const geometry::HardSpherePacking a = geometry::make_hard_sphere_packing(p);
    const geometry::HardSpherePacking b = geometry::make_hard_sphere_packing(p);
    ASSERT_EQ(a.centres_um.size(), b.centres_um.size());
    for (std::size_t i = 0; i < a.centres_um.size(); ++i) {
        EXPECT_EQ(a.centres_um[i], b.centres_um[i]);  // bit-identical
    }
    EXPECT_EQ(a.compression_sweeps, b.compression_sweeps);
    p.item = 1;
    const geometry::HardSpherePacking c = geometry::make_hard_sphere_packing(p);
    EXPECT_NE(a.centres_um[0], c.centres_um[0]);
}

TEST(HardSpherePacking, RefusesBadInput) {
    using geometry::HardSpherePackingParams;
    using geometry::make_hard_sphere_packing;
    auto with = [](auto change) {
        HardSpherePackingParams p;
        p.count = 100;
        p.box_um = 1.0;
        p.volume_fraction = 0.3;
        p.equilibration_sweeps = 1;
        change(p);
        return p;
    };
    for (double phi : {0.0, -0.1, 0.56, 0.7, std::nan("")}) {
        EXPECT_THROW(make_hard_sphere_packing(with([&](auto& p) { p.volume_fraction = phi; })),
                     InputError)
            << "phi = " << phi;
    }
    for (double box : {0.0, -1.0, std::numeric_limits<double>::infinity()}) {
        EXPECT_THROW(make_hard_sphere_packing(with([&](auto& p) { p.box_um = box; })), InputError);
    }
    EXPECT_THROW(make_hard_sphere_packing(with([](auto& p) { p.count = 1; })), InputError);
    EXPECT_THROW(make_hard_sphere_packing(with([](auto& p) { p.count = -5; })), InputError);
    // σ > L/2: too few spheres for the fraction (N >= 48 φ / π = 4.6 at φ = 0.3).
    EXPECT_THROW(make_hard_sphere_packing(with([](auto& p) { p.count = 4; })), InputError);
    EXPECT_THROW(make_hard_sphere_packing(with([](auto& p) { p.equilibration_sweeps = -1; })),
                 InputError);
    EXPECT_THROW(make_hard_sphere_packing(with([](auto& p) { p.max_compression_sweeps = 0; })),
                 InputError);
    // A compression cut short says what it reached.
    EXPECT_THROW(make_hard_sphere_packing(with([](auto& p) {
                     p.volume_fraction = 0.5;
                     p.max_compression_sweeps = 2;
                 })),
                 InputError);
    // Small and valid: N = 5 at φ = 0.3 (σ just below L/2), and φ = 0.55 at the edge.
    EXPECT_NO_THROW(make_hard_sphere_packing(with([](auto& p) { p.count = 5; })));
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
