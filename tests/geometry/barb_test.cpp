// Barbs and barb + barbule patches: ellipse outlines, closed outward tubes with the
// right volume (straight and bent: Pappus), medulla placement, cross-sections.
#include "geometry/barb.h"
#include "common/constants.h"

#include <cmath>
#include <map>

#include <gtest/gtest.h>

#include "tests/test_util.h"

namespace plumage::geometry {
namespace {

using plumage::testing::input_error_message;

double signed_area(const std::vector<Eigen::Vector2d>& polygon) {
    double area = 0.0;
    for (std::size_t i = 0; i < polygon.size(); ++i) {
        const auto& a = polygon[i];
        const auto& b = polygon[(i + 1) % polygon.size()];
        area += 0.5 * (a.x() * b.y() - b.x() * a.y());
    }
    return area;
}

double enclosed_volume(const TriangleMesh& mesh) {
    double volume = 0.0;
    for (const Triangle& t : mesh.triangles) {
        volume += mesh.positions[t[0]].dot(mesh.positions[t[1]].cross(mesh.positions[t[2]])) / 6.0;
    }
    return volume;
}

// Closed and consistently oriented: every directed edge appears once and its reverse
// once (vertices compared by position: caps have their own vertices).
bool closed_and_oriented(const TriangleMesh& mesh) {
    std::map<std::pair<std::array<double, 3>, std::array<double, 3>>, int> edges;
    auto key = [&](std::uint32_t v) {
        const Vec3& p = mesh.positions[v];
        return std::array<double, 3>{p.x(), p.y(), p.z()};
    };
    for (const Triangle& t : mesh.triangles) {
        for (int e = 0; e < 3; ++e) ++edges[{key(t[e]), key(t[(e + 1) % 3])}];
    }
    for (const auto& [edge, count] : edges) {
        if (count != 1) return false;
        const auto reverse = edges.find({edge.second, edge.first});
        if (reverse == edges.end() || reverse->second != 1) return false;
    }
    return true;
}

TEST(BarbGeometry, CortexOutlineIsTheRotatedEllipseCounterClockwise) {
    BarbParams p;
    p.barb_rotation_rad = 0.4;
    const Barb barb(p);
    // The authors' meaning: horizontal semi-axis w/2, vertical w/2 × axis ratio (1.5).
    const double a = barb.vertical_semi_axis_um(), b = barb.horizontal_semi_axis_um();
    EXPECT_NEAR(b, 15.0, 1e-12);
    EXPECT_NEAR(a, 1.5 * b, 1e-12);
    for (double chord : {0.1, 0.01, 0.001}) {
        const auto outline = barb.cortex_outline({chord, 0.1});
        for (const auto& q : outline) {
            const double along = q.x() * std::sin(0.4) + q.y() * std::cos(0.4);
            const double across = q.x() * std::cos(0.4) - q.y() * std::sin(0.4);
            EXPECT_NEAR(std::pow(along / a, 2) + std::pow(across / b, 2), 1.0, 1e-12);
        }
        // Inscribed polygon: area short of πab by at most chord × perimeter.
        const double area = signed_area(outline);
        EXPECT_GT(area, 0.0);
        EXPECT_LT(kPi * a * b - area, chord * 2.0 * kPi * a);
        EXPECT_GE(kPi * a * b - area, 0.0);
    }
}

TEST(BarbGeometry, TubesAreClosedOutwardAndHoldTheirVolume) {
    const Barb barb({});
    const double a = barb.vertical_semi_axis_um(), b = barb.horizontal_semi_axis_um();
    const double length = 200.0;
    for (double bend : {0.0, 150.0}) {
        const TriangleMesh tube = barb.cortex_mesh(length, bend, {0.005, 0.05});
        EXPECT_TRUE(closed_and_oriented(tube)) << "bend " << bend;
        // Pappus: a bent tube whose section's centroid is on the axis holds area × length.
        const double expected = kPi * a * b * length;
        EXPECT_NEAR(enclosed_volume(tube), expected,
                    0.005 * 2.0 * kPi * a * length + 0.01 * expected * (bend > 0))
            << "bend " << bend;
        EXPECT_GT(enclosed_volume(tube), 0.0);
    }
    EXPECT_NE(input_error_message([&] {
                  barb.cortex_mesh(100.0, 5.0, {0.01, 0.05});
              }).find("folds"),
              std::string::npos);
}

TEST(BarbGeometry, OffCentreMedullaSitsInsideTheCortex) {
    BarbParams p;
    p.medulla_scale = 0.6;
    p.medulla_offset_z_um = 3.0;
    const Barb barb(p);
    const TriangleMesh medulla = barb.medulla_mesh(50.0, 0.0, {0.01, 0.05});
    EXPECT_TRUE(closed_and_oriented(medulla));
    const double a = barb.vertical_semi_axis_um(), b = barb.horizontal_semi_axis_um();
    for (const Vec3& v : medulla.positions) {
        EXPECT_LT(std::pow(v.z() / a, 2) + std::pow(v.y() / b, 2), 1.0);
    }
    EXPECT_NEAR(enclosed_volume(medulla), kPi * 0.36 * a * b * 50.0, 0.01 * 2.0 * kPi * a * 50.0);
    p.medulla_offset_z_um = 10.0;
    EXPECT_NE(input_error_message([&] { Barb{p}; }).find("medulla strictly inside"),
              std::string::npos);
    p.medulla_scale = 0.99;
    EXPECT_NE(input_error_message([&] { Barb{p}; }).find("medulla_scale = 0.99"),
              std::string::npos);
    BarbParams flat;
    flat.barb_axis_ratio = 0.01;
    EXPECT_NE(input_error_message([&] { Barb{flat}; }).find("barb_axis_ratio = 0.01"),
              std::string::npos);
}

TEST(BarbGeometry, PatchCrossSectionHasBarbAndInclinedBarbules) {
    BarbulePatchParams p;
    const PatchCrossSection s = build_patch_cross_section(p, {0.01, 0.05});
    ASSERT_EQ(s.shapes.size(), 3u);
    EXPECT_EQ(s.shapes[0].role, SurfaceRole::barb_cortex);
    for (const auto& shape : s.shapes) EXPECT_GT(signed_area(shape.polygon), 0.0);
    // Barbule strips: each barbule is length × barb width / 2 = 45 µm long (the authors'), rising
    // by the inclination, as thick as the fibre (axis ratio × width = 3.2 µm).
    const auto& strip = s.shapes[1].polygon;
    const Eigen::Vector2d axis = 0.5 * (strip[1] + strip[2]) - 0.5 * (strip[0] + strip[3]);
    // (Less h tan i = 1.6 tan 0.35: the thick tips of neighbouring barbs would overlap.)
    EXPECT_NEAR(axis.norm(), 45.0 - 1.6 * std::tan(0.35), 1e-9);
    const Eigen::Vector2d tip_corner = strip[1];  // the outer corner of the tip face
    EXPECT_NEAR(tip_corner.x(), 0.5 * p.period_um(), 1e-9);
    EXPECT_NEAR(std::atan2(axis.y(), axis.x()), 0.35, 1e-12);
    EXPECT_NEAR((strip[3] - strip[0]).norm(), 3.2, 1e-9);
    // Automatic spacing: the authors' period, barb width × (1 + length cos i).
    EXPECT_NEAR(s.period_um, 30.0 * (1.0 + 3.0 * std::cos(0.35)), 1e-9);
    EXPECT_NEAR(p.period_um(), s.period_um, 1e-12);
    BarbulePatchParams bad = p;
    bad.barb_spacing = 2.0;  // below the automatic 3.82 barb widths: barbules would cross
    EXPECT_NE(input_error_message([&] {
                  build_patch_cross_section(bad, {0.01, 0.05});
              }).find("at least 3.8"),
              std::string::npos);
}

TEST(BarbGeometry, PatchInstancesBarbulesOnBothSides) {
    BarbulePatchParams p;
    const BarbulePatch patch = build_barbule_patch(p, 120.0, 3, {0.05, 0.05});
    EXPECT_EQ(patch.barb_instances.size(), 3u);
    // Pitch: width × (1 + gap 0.5) = 12 µm: 120 µm hold 10 per row.
    EXPECT_EQ(patch.barbule_instances.size(), 3u * 2u * 10u);
    EXPECT_TRUE(closed_and_oriented(patch.barbule));
    // The barbule runs along +y, rising by the inclination, as long as the authors' barbule less
    // the root clearance, 8 µm wide along x (the barb axis), 3.2 µm thick.
    const auto box = patch.barbule.bounds();
    const double length = 45.0 - 1.6 * std::tan(0.35) - patch.root_clearance_um;
    EXPECT_NEAR(box[1].y() - box[0].y(), length * std::cos(0.35) + 3.2 * std::sin(0.35), 0.1);
    EXPECT_NEAR(box[1].x() - box[0].x(), 8.0, 0.05);
    // Neighbouring fibres of a row leave a 4 µm gap (the see-through barbules of the authors),
    // and each row has its own phase along x.
    std::vector<double> row0, row1;
    for (int j = 0; j < 10; ++j) {
        row0.push_back(patch.barbule_instances[j].translation().x());
        row1.push_back(patch.barbule_instances[10 + j].translation().x());
    }
    for (int j = 1; j < 10; ++j) EXPECT_NEAR(row0[j] - row0[j - 1], 12.0, 1e-9);
    EXPECT_GT(std::abs(std::remainder(row0[0] - row1[0], 12.0)), 1e-3);
    EXPECT_LT(patch.memory_bytes(), 10u * 1000u * 1000u);
}

// The tracer has no nested media: no barbule vertex may lie inside the cortex it grows from
// (the patch moves barbules out by root_clearance_um), and automatic spacing still lets the
// moved tips just meet. Upright, flat, rotated and steep barbules.
TEST(BarbGeometry, BarbulesStartOutsideTheCortex) {
    const TessellationTolerance tolerance{0.05, 0.05};
    for (const double rotation : {0.0, 0.5}) {
        for (const double barbule_ratio : {0.4, 1.5}) {
            for (const double inclination : {0.1, 0.35, 0.9}) {
                BarbulePatchParams p;
                p.barb.barb_rotation_rad = rotation;
                p.barbule_axis_ratio = barbule_ratio;
                p.barbule_inclination_rad = inclination;
                p.barbule_width_um = 14.0;
                const BarbulePatch patch = build_barbule_patch(p, 60.0, 1, tolerance);
                const auto cortex = Barb(p.barb).cortex_outline(tolerance);
                EXPECT_GE(patch.root_clearance_um, 0.0);
                EXPECT_LT(patch.root_clearance_um,
                          0.5 * p.barbule_width_um * std::max(1.0, barbule_ratio));
                int inside = 0;
                for (const auto& t : patch.barbule_instances) {
                    for (const Vec3& v : patch.barbule.positions) {
                        const Vec3 w = t * v;
                        // Even-odd test against the cortex polygon (y, z); barb axis at y = 0.
                        bool in = false;
                        for (std::size_t i = 0, j = cortex.size() - 1; i < cortex.size(); j = i++) {
                            const auto& a = cortex[i];
                            const auto& b = cortex[j];
                            if ((a.y() > w.z()) != (b.y() > w.z()) &&
                                w.y() <
                                    (b.x() - a.x()) * (w.z() - a.y()) / (b.y() - a.y()) + a.x()) {
                                in = !in;
                            }
                        }
                        inside += in;
                    }
                }
                EXPECT_EQ(inside, 0) << "rotation " << rotation << ", barbule ratio "
                                     << barbule_ratio << ", inclination " << inclination;
                // The barbules end where the authors' end: the period is theirs.
                const PatchCrossSection s = build_patch_cross_section(p, tolerance);
                EXPECT_NEAR(patch.period_um, s.period_um, 1e-9);
                EXPECT_NEAR(patch.period_um, p.automatic_period_um(), 1e-9);
            }
        }
    }
    // An explicit spacing below the automatic period is refused, naming the smallest one; the
    // explicit patch builds barbules perpendicular to the barb only.
    BarbulePatchParams tight;
    tight.barb_spacing = 1.0;
    EXPECT_NE(input_error_message([&] {
                  build_barbule_patch(tight, 60.0, 2, tolerance);
              }).find("at least"),
              std::string::npos);
    BarbulePatchParams slanted;
    slanted.barbule_rotation_rad = 0.8;
    EXPECT_NE(input_error_message([&] {
                  build_barbule_patch(slanted, 60.0, 2, tolerance);
              }).find("pi/2 (90 deg) for the explicit patch"),
              std::string::npos);
}

}  // namespace
}  // namespace plumage::geometry
