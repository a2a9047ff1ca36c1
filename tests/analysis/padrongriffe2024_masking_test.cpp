// The Padrón-Griffe 2024 barb/barbule masking term (analysis/models/padrongriffe2024_masking.h):
// against Monte Carlo ray casting on the explicit 2D cross-section that geometry/barb.h builds
// (build_patch_cross_section, tiled periodically, opaque strips as thick as the fibre); against an
// independent exact first-hit ray caster of the authors' own configurations (the parameter sets
// of their figure scripts, masking/scripts/generate-figures.sh and
// generate-masking-paper-figures.sh in juanraul8/PennaceousFeathersRendering), opaque and
// see-through; and its closed-form limits.
#include "analysis/models/padrongriffe2024_masking.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "analysis/models/cross_section_masking_mc.h"
#include "common/constants.h"
#include "common/error.h"
#include "geometry/barb.h"
#include "sim/scatterer/random.h"
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
    p.barb.barb_axis_ratio = 0.5;
    out.push_back({"flat_barb_ratio0.5", p});
    p = base;
    p.barb.barb_axis_ratio = 1.0;
    out.push_back({"round_barb", p});
    p = base;
    p.barbule_inclination_rad = 45.0 * kDeg;
    out.push_back({"steep_barbules_45deg", p});
    p = base;
    p.barbule_length = 10.0;
    out.push_back({"long_barbules_10", p});
    p = base;
    // Twice the automatic spacing: 2 · 2 (r_y + L cos i) in barb widths.
    p.barb_spacing = 2.0 * PadronGriffe2024Masking(base).period_um() / base.barb.barb_width_um;
    out.push_back({"sparse_spacing_2x", p});
    p = base;
    p.barb.barb_rotation_rad = 30.0 * kDeg;
    out.push_back({"barb_rotation_30deg", p});
    p = base;
    p.barbule_rotation_rad = 0.6;  // the 2D cross-section does not depend on it
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
// (analysis/models/cross_section_masking_mc.h, shared with the masking study: jittered
// stratification, each fraction's variance is at most the binomial p(1 − p)/N, and a slice can only
// be misclassified if a boundary of the partition falls inside it).

// Rays per angle: binomial standard error <= 0.5/√N = 0.0025 per fraction.
constexpr int kMaskingRays = 40'000;
// 8 configurations × 90 angles × 3 fractions = 2160 comparisons: 5 σ keeps the chance of a
// false alarm below 2160 × 5.7e-7 ≈ 1e-3.
constexpr double kMaskingSigmas = 5.0;

// One configuration's largest disagreement with the Monte Carlo and where it is.
struct MaskingAgreement {
    double worst = 0.0, worst_angle = 0.0, worst_tolerance = 0.0;
    int worst_component = 0;
    double worst_ratio = 0.0, worst_strict_ratio = 0.0;
    // Power of the comparison: the barb's shadow without any occlusion by barbules, min(1,
    // shadow), must be caught out by the same Monte Carlo.
    double naive_worst = 0.0;
};

// The analytic fractions against the Monte Carlo at every other degree of (−90°, 90°), each
// within its binomial tolerance and the stratification's own bound (both plus the polygons'
// geometric offset).
MaskingAgreement compare_with_monte_carlo(const Configuration& config,
                                          const PadronGriffe2024Masking& masking,
                                          const PatchCrossSection& section, double offset,
                                          Rng& rng) {
    MaskingAgreement a;
    for (int deg = -89; deg <= 89; deg += 2) {
        const double theta = deg * kDeg;
        const MaskingFractions analytic = masking.fractions(theta, RowTransmittance{});
        const CrossSectionMaskingEstimate mc =
            estimate_cross_section_masking(section, theta, kMaskingRays, rng);
        // Geometry: each boundary of the partition can move by the polygons' offset from the
        // analytic shapes measured across the rays, i.e. offset / |cos θ| along u.
        const auto segments = masking.segments(theta);
        const double boundaries = static_cast<double>(segments.size());
        const double geometric =
            boundaries * offset / (masking.period_um() * std::abs(std::cos(theta)));
        const std::array<double, 3> expected = {analytic.barb, analytic.barbule(), analytic.gap};
        a.naive_worst =
            std::max(a.naive_worst,
                     std::abs(std::min(1.0, masking.unoccluded(theta).barb) - mc.fraction[0]));
        for (int c = 0; c < 3; ++c) {
            const double f = expected[c];
            const double sigma =
                std::sqrt(std::max(f * (1.0 - f), 1.0 / kMaskingRays) / kMaskingRays);
            // The tolerance the issue asks for: binomial ray-count error plus geometry.
            const double tol = kMaskingSigmas * sigma + geometric;
            // Stratification's own bound: only slices holding a boundary can be wrong, by 1/N
            // each (plus one slice of round-off either side).
            const double strict = (boundaries + 2.0) / kMaskingRays + geometric;
            const double error = std::abs(mc.fraction[c] - f);
            EXPECT_LE(error, tol) << config.name << " θ = " << deg << "° component " << c
                                  << ": analytic " << f << ", Monte Carlo " << mc.fraction[c];
            EXPECT_LE(error, strict) << config.name << " θ = " << deg << "° component " << c;
            if (error > a.worst) {
                a.worst = error;
                a.worst_angle = deg;
                a.worst_component = c;
                a.worst_tolerance = tol;
            }
            a.worst_ratio = std::max(a.worst_ratio, error / tol);
            a.worst_strict_ratio = std::max(a.worst_strict_ratio, error / strict);
        }
    }
    return a;
}

TEST(PadronGriffe2024Masking, AgreesWithMonteCarloOnTheExplicitCrossSection) {
    // Fine enough that the barbule roots (a cortex vertex) sit within ~4 nm of the extreme point.
    const geometry::TessellationTolerance tolerance{1e-4, 2e-4};
    std::uint64_t stream = 0;
    double overall = 0.0;
    for (const Configuration& config : configurations()) {
        // The polygons' barbules are opaque strips as thick as the fibre.
        const PadronGriffe2024Masking masking(config.params, BarbuleStrips::kFibreThickness);
        const PatchCrossSection section =
            geometry::build_patch_cross_section(config.params, tolerance);
        ASSERT_NEAR(section.period_um, masking.period_um(), 1e-6 * masking.period_um())
            << config.name;
        const double offset = cross_section_offset_um(section, masking, tolerance.max_chord_um);
        Rng rng(kDefaultSeed, stream++);
        const MaskingAgreement a = compare_with_monte_carlo(config, masking, section, offset, rng);
        overall = std::max(overall, a.worst);
        const char* names[] = {"barb", "barbule", "gap"};
        const std::string summary = fmt::format(
            "{:.2e} at {:+.0f} deg ({}), binomial+geometry tolerance there {:.2e}; largest "
            "error/tolerance {:.3f} (binomial) {:.2f} (stratified bound); geometric offset {:.2g} "
            "um; "
            "barb without occlusion misses by {:.3f}",
            a.worst, a.worst_angle, names[a.worst_component], a.worst_tolerance, a.worst_ratio,
            a.worst_strict_ratio, offset, a.naive_worst);
        EXPECT_GT(a.naive_worst, 0.05)
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
    for (double e : {1.0, 0.6, 3.0}) {
        for (double rotation : {0.0, 0.5}) {
            BarbulePatchParams p;
            p.barb.barb_axis_ratio = e;
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
                const double a = spaced.barb_vertical_semi_axis_um(),
                             b = spaced.barb_horizontal_semi_axis_um();
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
    // (1 − T) L / P, gap the rest, with r_y = √(a² sin² ρ + b² cos² ρ) and, seen along the row's
    // normal, T = s / (1 + s) (the open part of the pitch).
    for (double e : {1.0, 0.6, 2.0}) {
        for (double rotation : {0.0, 0.3, -1.0}) {
            for (double spacing : {0.0, 9.0}) {
                BarbulePatchParams p;
                p.barb.barb_axis_ratio = e;
                p.barb.barb_rotation_rad = rotation;
                p.barbule_inclination_rad = 0.0;
                p.barb_spacing = spacing;
                p.barbule_separation = 0.0;  // opaque rows
                const PadronGriffe2024Masking masking(p, BarbuleStrips::kFibreThickness);
                const double b = 0.5 * p.barb.barb_width_um, a = b * e;
                const double ry = std::hypot(a * std::sin(rotation), b * std::cos(rotation));
                const double length = 0.5 * p.barbule_length * p.barb.barb_width_um;
                const double period =
                    spacing > 0.0 ? spacing * p.barb.barb_width_um : 2.0 * (ry + length);
                ASSERT_NEAR(masking.period_um(), period, 1e-12 * period);
                const MaskingFractions f = masking.in_plane(0.0);
                EXPECT_NEAR(f.barb, 2.0 * ry / period, 1e-12)
                    << e << " " << rotation << " " << spacing;
                EXPECT_NEAR(f.distal_barbule, length / period, 1e-12);
                EXPECT_NEAR(f.proximal_barbule, length / period, 1e-12);
                EXPECT_NEAR(f.gap, 1.0 - 2.0 * (ry + length) / period, 1e-12);
                // See-through rows pass s / (1 + s) of what reaches them.
                p.barbule_separation = 1.5;
                const MaskingFractions g =
                    PadronGriffe2024Masking(p, BarbuleStrips::kFibreThickness).in_plane(0.0);
                EXPECT_NEAR(g.barb, f.barb, 1e-12);
                EXPECT_NEAR(g.distal_barbule, f.distal_barbule / 2.5, 1e-12);
                EXPECT_NEAR(g.gap, f.gap + 2.0 * f.distal_barbule * 1.5 / 2.5, 1e-12);
            }
        }
    }
    // Inclined barbules: each strip's unoccluded shadow has the closed form
    // |L (±cos i − sin i tan θ)| + 2h |sin i ± cos i tan θ| (its long side and its end face).
    BarbulePatchParams p;
    p.barbule_inclination_rad = 0.35;
    const PadronGriffe2024Masking masking(p, BarbuleStrips::kFibreThickness);
    EXPECT_EQ(PadronGriffe2024Masking(p).strip_half_thickness_um(), 0.0);  // authors: segments
    const double length = masking.barbule_length_um(), h = masking.strip_half_thickness_um();
    EXPECT_NEAR(h, 0.5 * p.barbule_axis_ratio * p.barbule_width_um, 1e-15);
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
        const MaskingFractions g =
            masking.fractions(std::atan2(d.y(), d.z()), masking.row_transmittance(d));
        EXPECT_EQ(f.barb, g.barb);
        EXPECT_EQ(f.distal_barbule, g.distal_barbule);
        // Tilting along the barb axis does not change what the barbs hide (the extruded
        // cross-section), only how much light the rows let through.
        const Vec3d tilted = Vec3d(3.0, d.y(), d.z()).normalized();
        EXPECT_NEAR(masking.fractions(std::atan2(d.y(), d.z()), {}).barb,
                    masking.fractions(std::atan2(tilted.y(), tilted.z()), {}).barb, 1e-12);
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
    std::string m = message([](BarbulePatchParams& p) { p.barb.barb_axis_ratio = 0.0; });
    EXPECT_TRUE(contains(m,
                         "barb_axis_ratio = 0: expected a vertical/horizontal axis ratio in "
                         "[0.05, 20] (Padrón-Griffe's barb excentricity)"))
        << m;
    m = message([](BarbulePatchParams& p) { p.barbule_separation = -0.5; });
    EXPECT_TRUE(contains(m, "barbule_separation = -0.5: expected a gap >= 0")) << m;
    m = message([](BarbulePatchParams& p) { p.barbule_inclination_rad = 2.0; });
    EXPECT_TRUE(contains(m, "barbule_inclination_rad = 2: expected an angle in (-pi/2, pi/2)"))
        << m;
    m = message([](BarbulePatchParams& p) { p.barbule_length = -1.0; });
    EXPECT_TRUE(contains(m,
                         "barbule_length = -1: expected a length in [0, 1000] (each barbule "
                         "length x barb width / 2; 0: no barbules)"))
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

// ---------------------------------------------------------------------------------------------
// The authors' own configurations, against an independent exact first-hit ray caster.
//
// The caster below knows the authors' barb-level geometry directly (masking/barbs.h: ellipse
// barbs of horizontal semi-axis a and vertical a × ratio centred on the vane plane, period
// 2a (1 + L cos i), barbule segments of length L a from the barbs' side extremes) and the
// barbule level (masking/barbules.h: a row of ellipses, pitch 2b (1 + s)). It intersects each
// ray with every shape of the neighbouring periods (a quadratic per ellipse, a 2×2 solve per
// segment), orders the hits by distance from the viewer, lets a barbule pass T of what reaches it
// and stops the rest, and averages over rays at the midpoints of N equal slices of the period.
// Only slices holding a boundary can be off, by 1/N each: the tolerance is (boundaries + 2)/N.

// Fractions (barb, distal, proximal, gap) of one ray family at in-plane angle θ.
struct CastFractions {
    std::array<double, 4> f{};
};

CastFractions cast_authors_barbs(double ratio, double length, double inclination, double t_distal,
                                 double t_proximal, double theta, int rays) {
    const double a = 0.5, b = 0.5 * ratio;  // barb width 1
    const double ci = std::cos(inclination), si = std::sin(inclination);
    const double seg = length * a;
    const double period = 2.0 * a + 2.0 * seg * ci;
    const Eigen::Vector2d w(std::sin(theta), std::cos(theta));  // towards the viewer
    // Depth range to consider: neighbours within this many periods.
    const int reach =
        3 + static_cast<int>(std::ceil((b + seg) * std::abs(std::tan(theta)) / period));
    CastFractions out;
    std::vector<std::pair<double, int>> hits;
    for (int n = 0; n < rays; ++n) {
        const double u = (n + 0.5) / rays * period;
        hits.clear();
        // The ray's line: (u, 0) + s w, the viewer at s → +∞; the first hit has the largest s.
        for (int k = -reach; k <= reach; ++k) {
            const double cy = k * period;
            // Barb: ((y − cy)/a)² + (z/b)² = 1.
            const double py = u - cy;
            const double qa = w.x() * w.x() / (a * a) + w.y() * w.y() / (b * b);
            const double qb = 2.0 * py * w.x() / (a * a);
            const double qc = py * py / (a * a) - 1.0;
            const double disc = qb * qb - 4.0 * qa * qc;
            if (disc >= 0.0) hits.push_back({(-qb + std::sqrt(disc)) / (2.0 * qa), 0});
            // Segments: start + t d, t ∈ [0, seg].
            for (int side = 0; side < 2; ++side) {
                const double sign = side == 0 ? 1.0 : -1.0;
                const Eigen::Vector2d start(cy + sign * a, 0.0);
                const Eigen::Vector2d d(sign * ci, si);
                // (u, 0) + s w = start + t d.
                const double det = w.x() * (-d.y()) - (-d.x()) * w.y();
                if (std::abs(det) < 1e-15) continue;
                const Eigen::Vector2d r = start - Eigen::Vector2d(u, 0.0);
                const double s_hit = (r.x() * (-d.y()) - (-d.x()) * r.y()) / det;
                const double t_hit = (w.x() * r.y() - w.y() * r.x()) / det;
                if (t_hit >= 0.0 && t_hit <= seg) hits.push_back({s_hit, 1 + side});
            }
        }
        std::sort(hits.begin(), hits.end(),
                  [](const auto& p, const auto& q) { return p.first > q.first; });
        double remaining = 1.0;
        for (const auto& [depth, what] : hits) {
            if (what == 0) {
                out.f[0] += remaining;
                remaining = 0.0;
                break;
            }
            const double through = what == 1 ? t_distal : t_proximal;
            out.f[what] += remaining * (1.0 - through);
            remaining *= through;
        }
        out.f[3] += remaining;
    }
    for (double& v : out.f) v /= rays;
    return out;
}

// The open fraction of a row of ellipses (semi-axes 1/2 across, ratio/2 along the row's normal,
// pitch 1 + s) seen along (across, normal) = (a, n): rays through N slices of the pitch.
double cast_authors_row(double ratio, double separation, double a, double n, int rays) {
    const double pitch = 1.0 + separation, ha = 0.5, hn = 0.5 * ratio;
    if (std::abs(n) < 1e-15) return 0.0;
    // Rays (x0, 0) + s (a, n) meet ellipse k where ((x − k p)/ha)² + (y/hn)² = 1.
    int open = 0;
    const int reach = 2 + static_cast<int>(std::ceil(hn * std::abs(a / n) / pitch));
    for (int j = 0; j < rays; ++j) {
        const double x0 = (j + 0.5) / rays * pitch;
        bool hit = false;
        for (int k = -reach; k <= reach && !hit; ++k) {
            const double px = x0 - k * pitch;
            const double qa = a * a / (ha * ha) + n * n / (hn * hn);
            const double qb = 2.0 * px * a / (ha * ha);
            const double qc = px * px / (ha * ha) - 1.0;
            hit = qb * qb - 4.0 * qa * qc >= 0.0;
        }
        if (!hit) ++open;
    }
    return static_cast<double>(open) / rays;
}

// The authors' parameters (ratio, L, inclination) as ours: barb width 1 (the term is scale-free).
BarbulePatchParams authors_vane(double barb_ratio, double length, double inclination_rad,
                                double barbule_ratio = 1.0, double rotation_rad = 0.5 * kPi,
                                double separation = 0.0) {
    BarbulePatchParams p;
    p.barb.barb_width_um = 1.0;
    p.barb.barb_axis_ratio = barb_ratio;
    p.barbule_length = length;
    p.barbule_inclination_rad = inclination_rad;
    p.barbule_axis_ratio = barbule_ratio;
    p.barbule_rotation_rad = rotation_rad;
    p.barbule_separation = separation;
    p.barbule_width_um = 0.1;
    return p;
}

TEST(PadronGriffe2024Masking, AuthorsBarbConfigurationsAgreeWithExactRayCasting) {
    // masking/scripts/generate-figures.sh and generate-masking-paper-figures.sh, "barbs":
    // (barb excentricity, barbule length, inclination in degrees, left and right transparency).
    struct BarbConfig {
        const char* name;
        double ratio, length, inclination_deg, left, right;
    };
    const BarbConfig configs[] = {
        {"planar", 1, 2, 0, 0, 0},
        {"planartransparent", 1, 2, 0, .5, .5},
        {"planarhalftransparent", 1, 2, 0, .5, 0},
        {"upwards", 1, 1, 45, 0, 0},
        {"upwardstransparent", 1, 1, 45, .5, .5},
        {"upwardshalftransparent", 1, 1, 45, .5, 0},
        {"downwards", 1, 1, -45, 0, 0},
        {"excentric", 3, 1, 45, 0, 0},
        {"unexcentric", 0.3, 1, 45, 0, 0},
        {"unexcentrictransparent", 0.3, 1, 45, .5, .5},
        {"unexcentrichalftransparent", 0.3, 1, 45, .5, 0},
        {"longbarbules", 1.5, 4, 45, .5, .5},
        {"paper_barb_figure", 1.5, 2.75, 45, .5, .5},
    };
    constexpr int kRays = 20'000;
    double worst = 0.0;
    for (const BarbConfig& c : configs) {
        const PadronGriffe2024Masking masking(
            authors_vane(c.ratio, c.length, c.inclination_deg * kDeg));
        // The authors' right barbule leaves the barb towards +x (our distal, +y), the left one
        // towards −x (our proximal).
        const RowTransmittance rows{c.right, c.left};
        for (int deg = -85; deg <= 85; deg += 5) {
            const double theta = deg * kDeg + 1e-4;  // off exact angles, as the scripts' ".01"
            const MaskingFractions f = masking.fractions(theta, rows);
            const CastFractions cast = cast_authors_barbs(
                c.ratio, c.length, c.inclination_deg * kDeg, c.right, c.left, theta, kRays);
            const double bound =
                (static_cast<double>(masking.segments(theta).size()) + 8.0) / kRays;
            const std::array<double, 4> analytic = {f.barb, f.distal_barbule, f.proximal_barbule,
                                                    f.gap};
            for (int k = 0; k < 4; ++k) {
                const double error = std::abs(analytic[k] - cast.f[k]);
                worst = std::max(worst, error);
                EXPECT_LE(error, bound) << c.name << " θ = " << deg << "° component " << k
                                        << ": analytic " << analytic[k] << ", cast " << cast.f[k];
            }
        }
    }
    std::printf("[ info ] authors' barb configurations vs exact casting: max |error| %.2e\n",
                worst);
}

TEST(PadronGriffe2024Masking, AuthorsBarbuleRowsAgreeWithExactRayCasting) {
    // "barbules" (excentricity, separation): opaque (1, 0), normal (1, 1), transmittance (1, 10),
    // excentric (2, 1), and the paper's barbule figure (2, 1); 3D directions through the rows'
    // frames (masking/feather-base.h), rotation 45° and 90°, inclination 0 and 45°.
    const double rows[][2] = {{1, 0}, {1, 1}, {1, 10}, {2, 1}, {0.4, 0.5}};
    constexpr int kRays = 40'000;
    double worst = 0.0;
    for (const auto& row : rows) {
        for (double rotation_deg : {45.0, 90.0}) {
            for (double inclination_deg : {0.0, 45.0}) {
                const PadronGriffe2024Masking masking(authors_vane(
                    1.0, 1.0, inclination_deg * kDeg, row[0], rotation_deg * kDeg, row[1]));
                // The frames are the authors': axis (cos i cos r, ±cos i sin r, sin i).
                const double i = inclination_deg * kDeg, r = rotation_deg * kDeg;
                EXPECT_NEAR((masking.row_axis(0) - Vec3d(std::cos(i) * std::cos(r),
                                                         std::cos(i) * std::sin(r), std::sin(i)))
                                .norm(),
                            0.0, 1e-15);
                EXPECT_NEAR((masking.row_axis(1) - Vec3d(std::cos(i) * std::cos(r),
                                                         -std::cos(i) * std::sin(r), std::sin(i)))
                                .norm(),
                            0.0, 1e-15);
                for (double polar = 0.0; polar <= 80.0; polar += 20.0) {
                    for (double azimuth = 0.0; azimuth < 360.0; azimuth += 45.0) {
                        const Vec3d w(std::sin(polar * kDeg) * std::cos(azimuth * kDeg),
                                      std::sin(polar * kDeg) * std::sin(azimuth * kDeg),
                                      std::cos(polar * kDeg));
                        const RowTransmittance t = masking.row_transmittance(w);
                        for (int side = 0; side < 2; ++side) {
                            const double cast =
                                cast_authors_row(row[0], row[1], w.dot(masking.row_across(side)),
                                                 w.dot(masking.row_normal(side)), kRays);
                            const double analytic = side == 0 ? t.distal : t.proximal;
                            worst = std::max(worst, std::abs(analytic - cast));
                            EXPECT_LE(std::abs(analytic - cast), 4.0 / kRays)
                                << "row " << row[0] << "," << row[1] << " r " << rotation_deg
                                << " i " << inclination_deg << " ω " << w.transpose();
                        }
                    }
                }
            }
        }
    }
    std::printf("[ info ] authors' barbule rows vs exact casting: max |error| %.2e\n", worst);
}

TEST(PadronGriffe2024Masking, AuthorsFeatherConfigurationsComposeBothLevels) {
    // "feathers" (barb exc., barbule exc., length, rotation°, inclination°, separation): standard
    // (1, 1, 1, 45, 0, 1), strongbarb (3, 1, 1, 45, 0, 1), strongbarbule (1, 1, 3, 45, 45, 1), and
    // the same opaque (separation 0). operator()(ω) is the barb level at the projected angle with
    // each row's transmittance at ω: both cast independently here.
    struct FeatherConfig {
        const char* name;
        double barb, barbule, length, rotation_deg, inclination_deg, separation;
    };
    const FeatherConfig configs[] = {{"standard", 1, 1, 1, 45, 0, 1},
                                     {"strongbarb", 3, 1, 1, 45, 0, 1},
                                     {"strongbarbule", 1, 1, 3, 45, 45, 1},
                                     {"strongbarbule_opaque", 1, 1, 3, 45, 45, 0}};
    constexpr int kRays = 20'000;
    double worst = 0.0;
    for (const FeatherConfig& c : configs) {
        const PadronGriffe2024Masking masking(authors_vane(c.barb, c.length,
                                                           c.inclination_deg * kDeg, c.barbule,
                                                           c.rotation_deg * kDeg, c.separation));
        for (double polar = -75.0; polar <= 75.0; polar += 15.0) {
            for (double azimuth : {0.0, 30.0, 75.0}) {
                // Polar angle measured in the plane at `azimuth` from the cross-section plane.
                const double p = polar * kDeg + 1e-4, q = azimuth * kDeg;
                const Vec3d w(std::sin(p) * std::sin(q), std::sin(p) * std::cos(q), std::cos(p));
                const double across_d = w.dot(masking.row_across(0)),
                             n_d = w.dot(masking.row_normal(0));
                const double across_p = w.dot(masking.row_across(1)),
                             n_p = w.dot(masking.row_normal(1));
                const double t_d = cast_authors_row(c.barbule, c.separation, across_d, n_d, kRays);
                const double t_p = cast_authors_row(c.barbule, c.separation, across_p, n_p, kRays);
                const double theta = std::atan2(w.y(), w.z());
                const CastFractions cast = cast_authors_barbs(
                    c.barb, c.length, c.inclination_deg * kDeg, t_d, t_p, theta, kRays);
                const MaskingFractions f = masking(w);
                const std::array<double, 4> analytic = {f.barb, f.distal_barbule,
                                                        f.proximal_barbule, f.gap};
                const double bound =
                    (static_cast<double>(masking.segments(theta).size()) + 16.0) / kRays;
                for (int k = 0; k < 4; ++k) {
                    worst = std::max(worst, std::abs(analytic[k] - cast.f[k]));
                    EXPECT_LE(std::abs(analytic[k] - cast.f[k]), bound)
                        << c.name << " ω " << w.transpose() << " component " << k;
                }
            }
        }
    }
    std::printf("[ info ] authors' feather configurations vs exact casting: max |error| %.2e\n",
                worst);
}

TEST(PadronGriffe2024Masking, WorkedExampleOfTheIssue) {
    // Barb ratio 0.6, barbule length 3, inclination 0.35 rad, gap 1: at normal view the barb
    // covers 1 / (1 + 3 cos 0.35) = 0.2619 of the patch whatever the rows let through; each row
    // covers (1 − barb)/2 and passes s/(1 + s) = 1/2 of it.
    BarbulePatchParams p = authors_vane(0.6, 3.0, 0.35, 1.0, 0.5 * kPi, 1.0);
    const PadronGriffe2024Masking masking(p);
    const double barb = 1.0 / (1.0 + 3.0 * std::cos(0.35));
    const MaskingFractions f = masking(Vec3d::UnitZ());
    EXPECT_NEAR(f.barb, barb, 1e-12);
    EXPECT_NEAR(barb, 0.2619, 1e-4);
    EXPECT_NEAR(f.distal_barbule, 0.25 * (1.0 - barb), 1e-12);
    EXPECT_NEAR(f.proximal_barbule, 0.25 * (1.0 - barb), 1e-12);
    EXPECT_NEAR(f.gap, 0.5 * (1.0 - barb), 1e-12);
    p.barbule_separation = 0.0;
    EXPECT_NEAR(PadronGriffe2024Masking(p)(Vec3d::UnitZ()).barb, barb, 1e-12);
    EXPECT_NEAR(PadronGriffe2024Masking(p)(Vec3d::UnitZ()).gap, 0.0, 1e-12);
}

}  // namespace
}  // namespace plumage::analysis
