// The Padrón-Griffe 2024 barb/barbule masking term (analysis/padrongriffe2024_masking.h) against
// Monte Carlo ray casting on the explicit 2D cross-section that geometry/barb.h builds
// (build_patch_cross_section, tiled periodically), and its closed-form limits.
#include "analysis/padrongriffe2024_masking.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "analysis/cross_section_masking_mc.h"
#include "common/constants.h"
#include "common/error.h"
#include "geometry/barb.h"
#include "sim/random.h"
#include "tests/test_util.h"

namespace plumage::analysis {
namespace {

using geometry::BarbulePatchParams;
using geometry::PatchCrossSection;
using geometry::SurfaceRole;

struct Configuration {
    const char* name;
    BarbulePatchParams params;
};

// The configurations of the comparison: the geometry defaults (a generic pennaceous vane) and one
// change each, as the paper varies barb shape, barbule angle, length and density.
std::vector<Configuration> configurations() {
    std::vector<Configuration> out;
    const BarbulePatchParams base;
    out.push_back({"default", base});
    BarbulePatchParams p = base;
    p.barb.barb_eccentricity = 0.9;
    out.push_back({"flat_barb_e0.9", p});
    p = base;
    p.barb.barb_eccentricity = 0.0;
    out.push_back({"round_barb_e0", p});
    p = base;
    p.barbule_inclination_rad = 45.0 * kDeg;
    out.push_back({"steep_barbules_45deg", p});
    p = base;
    p.barbule_length = 5.0;
    out.push_back({"long_barbules_5", p});
    p = base;
    // Twice the automatic spacing: 2 · 2 (r_y + L cos i) in barb widths.
    p.barb_spacing = 2.0 * PadronGriffe2024Masking(base).period_um() / base.barb.barb_width_um;
    out.push_back({"sparse_spacing_2x", p});
    p = base;
    p.barb.barb_rotation_rad = 30.0 * kDeg;
    out.push_back({"barb_rotation_30deg", p});
    p = base;
    p.barbule_rotation_rad = 0.6;
    p.barbule_inclination_rad = -0.2;
    p.barb.medulla_scale = 0.5;
    p.barb.medulla_offset_y_um = 2.0;
    p.barb.medulla_offset_z_um = 3.0;
    out.push_back({"medulla_drooping_rotated_barbules", p});
    return out;
}

// ---------------------------------------------------------------------------------------------
// Monte Carlo: parallel rays against the polygons of build_patch_cross_section, tiled with the
// period, one ray at a random position in each of N equal slices of the period
// (analysis/cross_section_masking_mc.h, shared with the masking study: jittered stratification,
// each fraction's variance is at most the binomial p(1 − p)/N, and a slice can only be
// misclassified if a boundary of the partition falls inside it).

TEST(PadronGriffe2024Masking, AgreesWithMonteCarloOnTheExplicitCrossSection) {
    // Rays per angle: binomial standard error <= 0.5/√N = 0.0025 per fraction.
    constexpr int kRays = 40'000;
    // 8 configurations × 90 angles × 3 fractions = 2160 comparisons: 5 σ keeps the chance of a
    // false alarm below 2160 × 5.7e-7 ≈ 1e-3.
    constexpr double kSigmas = 5.0;
    // Fine enough that the barbule roots (a cortex vertex) sit within ~4 nm of the extreme point.
    const geometry::TessellationTolerance tolerance{1e-4, 2e-4};
    std::uint64_t stream = 0;
    double overall = 0.0;
    for (const Configuration& config : configurations()) {
        const PadronGriffe2024Masking masking(config.params);
        const PatchCrossSection section =
            geometry::build_patch_cross_section(config.params, tolerance);
        ASSERT_NEAR(section.period_um, masking.period_um(), 1e-6 * masking.period_um())
            << config.name;
        const double offset = cross_section_offset_um(section, masking, tolerance.max_chord_um);
        Rng rng(kDefaultSeed, stream++);
        double worst = 0.0, worst_ratio = 0.0, worst_angle = 0.0, worst_tolerance = 0.0;
        double worst_strict_ratio = 0.0;
        // Power of the comparison: the barb's shadow without any occlusion by barbules, min(1,
        // shadow), must be caught out by the same Monte Carlo.
        double naive_worst = 0.0;
        int worst_component = 0;
        for (int deg = -89; deg <= 89; deg += 2) {
            const double theta = deg * kDeg;
            const MaskingFractions analytic = masking.in_plane(theta);
            const CrossSectionMaskingEstimate mc =
                estimate_cross_section_masking(section, theta, kRays, rng);
            // Geometry: each boundary of the partition can move by the polygons' offset from the
            // analytic shapes measured across the rays, i.e. offset / |cos θ| along u.
            const auto segments = masking.segments(theta);
            const double boundaries = static_cast<double>(segments.size());
            const double geometric =
                boundaries * offset / (masking.period_um() * std::abs(std::cos(theta)));
            const std::array<double, 3> expected = {analytic.barb, analytic.barbule(),
                                                    analytic.gap};
            naive_worst =
                std::max(naive_worst,
                         std::abs(std::min(1.0, masking.unoccluded(theta).barb) - mc.fraction[0]));
            for (int c = 0; c < 3; ++c) {
                const double f = expected[c];
                const double sigma = std::sqrt(std::max(f * (1.0 - f), 1.0 / kRays) / kRays);
                // The tolerance the issue asks for: binomial ray-count error plus geometry.
                const double tol = kSigmas * sigma + geometric;
                // Stratification's own bound: only slices holding a boundary can be wrong, by 1/N
                // each (plus one slice of round-off either side).
                const double strict = (boundaries + 2.0) / kRays + geometric;
                const double error = std::abs(mc.fraction[c] - f);
                EXPECT_LE(error, tol) << config.name << " θ = " << deg << "° component " << c
                                      << ": analytic " << f << ", Monte Carlo " << mc.fraction[c];
                EXPECT_LE(error, strict) << config.name << " θ = " << deg << "° component " << c;
                if (error > worst) {
                    worst = error;
                    worst_angle = deg;
                    worst_component = c;
                    worst_tolerance = tol;
                }
                worst_ratio = std::max(worst_ratio, error / tol);
                worst_strict_ratio = std::max(worst_strict_ratio, error / strict);
            }
        }
        overall = std::max(overall, worst);
        const char* names[] = {"barb", "barbule", "gap"};
        const std::string summary = fmt::format(
            "{:.2e} at {:+.0f} deg ({}), binomial+geometry tolerance there {:.2e}; largest "
            "error/tolerance {:.3f} (binomial) {:.2f} (stratified bound); geometric offset {:.2g} "
            "um; "
            "barb without occlusion misses by {:.3f}",
            worst, worst_angle, names[worst_component], worst_tolerance, worst_ratio,
            worst_strict_ratio, offset, naive_worst);
        EXPECT_GT(naive_worst, 0.05)
            << config.name << ": the comparison cannot tell occlusion from none";
        RecordProperty(std::string("max_abs_error_") + config.name, summary);
        std::printf("[ info ] masking vs MC %-34s max |error| %s\n", config.name, summary.c_str());
    }
    RecordProperty("max_abs_error_all_configurations", std::to_string(overall));
    std::printf("[ info ] masking vs MC: max |error| over all configurations and angles %.2e\n",
                overall);
    // The stratified bound is at most ~(10 boundaries + 2)/N + geometry ≈ 3e-4 at 60°.
    ASSERT_LT(overall, 2e-4);
}

// ---------------------------------------------------------------------------------------------
// Limits and closed forms.

TEST(PadronGriffe2024Masking, FractionsSumToOneFromAboveAndBelow) {
    for (const Configuration& config : configurations()) {
        const PadronGriffe2024Masking masking(config.params);
        for (double deg = -179.5; deg <= 180.0; deg += 0.5) {
            if (std::abs(std::cos(deg * kDeg)) < PadronGriffe2024Masking::kMinimumCosine) continue;
            const MaskingFractions f = masking.in_plane(deg * kDeg);
            EXPECT_NEAR(f.sum(), 1.0, 1e-12) << config.name << " " << deg;
            for (double v : {f.barb, f.distal_barbule, f.proximal_barbule, f.gap}) {
                EXPECT_GE(v, 0.0);
                EXPECT_LE(v, 1.0);
            }
            // The partition tiles [0, P) without holes or overlaps.
            const auto segments = masking.segments(deg * kDeg);
            ASSERT_FALSE(segments.empty());
            EXPECT_EQ(segments.front().u0_um, 0.0);
            EXPECT_EQ(segments.back().u1_um, masking.period_um());
            for (std::size_t j = 1; j < segments.size(); ++j) {
                EXPECT_EQ(segments[j].u0_um, segments[j - 1].u1_um);
            }
        }
    }
}

TEST(PadronGriffe2024Masking, ZeroLengthBarbulesLeaveOnlyBarb) {
    for (double e : {0.0, 0.6, 0.95}) {
        for (double rotation : {0.0, 0.5}) {
            BarbulePatchParams p;
            p.barb.barb_eccentricity = e;
            p.barb.barb_rotation_rad = rotation;
            p.barbule_length = 0.0;
            const PadronGriffe2024Masking touching(p);  // automatic spacing: barbs side by side
            EXPECT_FALSE(touching.has_barbules());
            p.barb_spacing = 2.5;
            const PadronGriffe2024Masking spaced(p);
            for (double deg = -89.0; deg <= 89.0; deg += 1.0) {
                // Barbs side by side (P = 2 r_y): unrotated ones cover the patch from every angle;
                // a rotated ellipse's shadow can be narrower than its y-extent, so light passes.
                const MaskingFractions f = touching.in_plane(deg * kDeg);
                EXPECT_EQ(f.barbule(), 0.0);
                EXPECT_NEAR(f.barb, std::min(1.0, touching.unoccluded(deg * kDeg).barb), 1e-12)
                    << deg;
                if (rotation == 0.0) {
                    EXPECT_NEAR(f.barb, 1.0, 1e-12) << "touching barbs, " << deg;
                }
                // Spaced barbs: the barb's shadow, min(1, 2 √S11 / P), the rest is gap.
                const MaskingFractions g = spaced.in_plane(deg * kDeg);
                const double shadow = std::min(1.0, spaced.unoccluded(deg * kDeg).barb);
                EXPECT_NEAR(g.barb, shadow, 1e-12) << e << " " << rotation << " " << deg;
                EXPECT_NEAR(g.gap, 1.0 - shadow, 1e-12);
                // The closed form of the shadow: 2 √(a² (sρ − tθ cρ)² + b² (cρ + tθ sρ)²).
                const double a = spaced.barb_semi_major_um(), b = spaced.barb_semi_minor_um();
                const double tn = std::tan(deg * kDeg), s = std::sin(rotation),
                             c = std::cos(rotation);
                const double width = 2.0 * std::sqrt(a * a * std::pow(s - tn * c, 2) +
                                                     b * b * std::pow(c + tn * s, 2));
                EXPECT_NEAR(spaced.unoccluded(deg * kDeg).barb, width / spaced.period_um(), 1e-12);
            }
        }
    }
    // Continuity: barbules of 1e-6 barb widths change the fractions by about their own shadow.
    BarbulePatchParams p;
    p.barb_spacing = 2.0;
    p.barbule_length = 0.0;
    const PadronGriffe2024Masking none(p);
    p.barbule_length = 1e-6;
    p.barbule_width_um = 1e-6;
    const PadronGriffe2024Masking tiny(p);
    for (double deg = -80.0; deg <= 80.0; deg += 10.0) {
        EXPECT_NEAR(none.in_plane(deg * kDeg).barb, tiny.in_plane(deg * kDeg).barb, 1e-6);
        EXPECT_NEAR(tiny.in_plane(deg * kDeg).barbule(), 0.0, 1e-6);
    }
}

TEST(PadronGriffe2024Masking, NormalIncidenceMatchesClosedFormProjectedWidths) {
    // Horizontal barbules (i = 0): at normal incidence the barb's shadow is [−r_y, r_y], each
    // strip's [r_y, r_y + L] (mirrored), nothing overlaps, so barb = 2 r_y / P, each barbule
    // L / P, gap the rest, with r_y = √(a² sin² ρ + b² cos² ρ).
    for (double e : {0.0, 0.6, 0.9}) {
        for (double rotation : {0.0, 0.3, -1.0}) {
            for (double spacing : {0.0, 9.0}) {
                BarbulePatchParams p;
                p.barb.barb_eccentricity = e;
                p.barb.barb_rotation_rad = rotation;
                p.barbule_inclination_rad = 0.0;
                p.barb_spacing = spacing;
                const PadronGriffe2024Masking masking(p);
                const double a = 0.5 * p.barb.barb_width_um, b = a * std::sqrt(1.0 - e * e);
                const double ry = std::hypot(a * std::sin(rotation), b * std::cos(rotation));
                const double length = p.barbule_length * p.barb.barb_width_um;
                const double period =
                    spacing > 0.0 ? spacing * p.barb.barb_width_um : 2.0 * (ry + length);
                ASSERT_NEAR(masking.period_um(), period, 1e-12 * period);
                const MaskingFractions f = masking.in_plane(0.0);
                EXPECT_NEAR(f.barb, 2.0 * ry / period, 1e-12)
                    << e << " " << rotation << " " << spacing;
                EXPECT_NEAR(f.distal_barbule, length / period, 1e-12);
                EXPECT_NEAR(f.proximal_barbule, length / period, 1e-12);
                EXPECT_NEAR(f.gap, 1.0 - 2.0 * (ry + length) / period, 1e-12);
            }
        }
    }
    // Inclined barbules: each strip's unoccluded shadow has the closed form
    // |L (±cos i − sin i tan θ)| + 2h |sin i ± cos i tan θ| (its long side and its end face).
    BarbulePatchParams p;
    p.barbule_inclination_rad = 0.35;
    const PadronGriffe2024Masking masking(p);
    const double length = masking.barbule_length_um(), h = masking.strip_half_thickness_um();
    for (double deg = -85.0; deg <= 85.0; deg += 5.0) {
        const double tn = std::tan(deg * kDeg), i = p.barbule_inclination_rad;
        const double distal = std::abs(length * (std::cos(i) - std::sin(i) * tn)) +
                              2.0 * h * std::abs(std::sin(i) + std::cos(i) * tn);
        const double proximal = std::abs(length * (-std::cos(i) - std::sin(i) * tn)) +
                                2.0 * h * std::abs(std::sin(i) - std::cos(i) * tn);
        const MaskingFractions u = masking.unoccluded(deg * kDeg);
        EXPECT_NEAR(u.distal_barbule * masking.period_um(), distal, 1e-9 * distal) << deg;
        EXPECT_NEAR(u.proximal_barbule * masking.period_um(), proximal, 1e-9 * proximal) << deg;
        // Occlusion only removes: every visible fraction is at most its shadow.
        const MaskingFractions f = masking.in_plane(deg * kDeg);
        EXPECT_LE(f.barb, u.barb + 1e-12);
        EXPECT_LE(f.distal_barbule, u.distal_barbule + 1e-12);
        EXPECT_LE(f.proximal_barbule, u.proximal_barbule + 1e-12);
    }
}

TEST(PadronGriffe2024Masking, MirrorSymmetryAndGrazingOpacity) {
    // An unrotated barb is symmetric in y: viewing from −θ swaps distal and proximal.
    const PadronGriffe2024Masking masking(BarbulePatchParams{});
    for (double deg = -89.0; deg <= 89.0; deg += 3.0) {
        const MaskingFractions f = masking.in_plane(deg * kDeg), g = masking.in_plane(-deg * kDeg);
        EXPECT_NEAR(f.barb, g.barb, 1e-12);
        EXPECT_NEAR(f.distal_barbule, g.proximal_barbule, 1e-12);
        EXPECT_NEAR(f.gap, g.gap, 1e-12);
    }
    // Sparse barbs: light passes at normal incidence but not at grazing (the paper's "as the
    // feather rotates, it becomes more opaque").
    BarbulePatchParams p;
    p.barb_spacing = 15.0;
    const PadronGriffe2024Masking sparse(p);
    EXPECT_GT(sparse.in_plane(0.0).gap, 0.2);
    EXPECT_LT(sparse.in_plane(85.0 * kDeg).gap, sparse.in_plane(0.0).gap);
    EXPECT_EQ(sparse.in_plane(89.5 * kDeg).gap, 0.0);
    std::printf("[ info ] sparse vane gap: %.4f at 0 deg, %.4f at 60 deg, %.4f at 85 deg\n",
                sparse.in_plane(0.0).gap, sparse.in_plane(60.0 * kDeg).gap,
                sparse.in_plane(85.0 * kDeg).gap);
}

TEST(PadronGriffe2024Masking, ThreeDimensionalDirectionsUseTheProjectedAngle) {
    const PadronGriffe2024Masking masking(BarbulePatchParams{});
    for (const Vec3d& w :
         {Vec3d(0.3, 0.4, 0.866), Vec3d(-0.7, -0.2, 0.5), Vec3d(0.1, 0.5, -0.86)}) {
        const Vec3d d = w.normalized();
        const MaskingFractions f = masking(d);
        const MaskingFractions g = masking.in_plane(std::atan2(d.y(), d.z()));
        EXPECT_EQ(f.barb, g.barb);
        EXPECT_EQ(f.distal_barbule, g.distal_barbule);
        // Tilting along the barb axis does not change what the extruded cross-section shows.
        const Vec3d tilted = Vec3d(3.0, d.y(), d.z()).normalized();
        EXPECT_NEAR(masking(tilted).barb, f.barb, 1e-12);
    }
    // Grazing and axial directions are clamped, not refused.
    EXPECT_NEAR(masking(Vec3d(0.0, 1.0, 0.0)).sum(), 1.0, 1e-12);
    EXPECT_NEAR(masking(Vec3d(1.0, 0.0, 0.0)).sum(), 1.0, 1e-12);
}

TEST(PadronGriffe2024Masking, RejectsBadParametersWithTheirRange) {
    using plumage::testing::input_error_message;
    auto message = [](auto modify) {
        return input_error_message([&] {
            BarbulePatchParams p;
            modify(p);
            PadronGriffe2024Masking m(p);
        });
    };
    auto contains = [](const std::string& text, const std::string& part) {
        return text.find(part) != std::string::npos;
    };
    std::string m = message([](BarbulePatchParams& p) { p.barb.barb_eccentricity = 1.2; });
    EXPECT_TRUE(contains(m, "barb_eccentricity = 1.2: expected a value in [0, 0.999]")) << m;
    m = message([](BarbulePatchParams& p) { p.barbule_inclination_rad = 2.0; });
    EXPECT_TRUE(contains(m, "barbule_inclination_rad = 2: expected an angle in (-pi/2, pi/2)"))
        << m;
    m = message([](BarbulePatchParams& p) { p.barbule_length = -1.0; });
    EXPECT_TRUE(contains(m, "barbule_length = -1: expected a length in [0, 1000] barb widths"))
        << m;
    m = message([](BarbulePatchParams& p) { p.barb_spacing = 0.5; });
    EXPECT_TRUE(contains(m, "barb_spacing = 0.5: expected 0 (automatic")) << m;
    m = message([](BarbulePatchParams& p) { p.barb.barb_width_um = std::nan(""); });
    EXPECT_TRUE(contains(m, "barb_width_um = nan")) << m;
    m = message([](BarbulePatchParams& p) { p.barbule_width_um = 0.0; });
    EXPECT_TRUE(contains(m, "barbule_width_um = 0: expected a finite width > 0")) << m;
    EXPECT_EQ(message([](BarbulePatchParams&) {}), "no InputError");
    const PadronGriffe2024Masking masking(BarbulePatchParams{});
    m = input_error_message([&] { masking.in_plane(0.5 * kPi); });
    EXPECT_TRUE(contains(m, "view angle = 1.5707963")) << m;
    EXPECT_TRUE(contains(m, "at least 0.1 deg away from the patch plane")) << m;
}

}  // namespace
}  // namespace plumage::analysis
