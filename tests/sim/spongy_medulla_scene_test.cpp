// The barb patch's spongy medulla (sim/scene.h SpongyMedulla): its surfaces and their sides,
// the melanin core's mesh nested strictly inside the medulla, and the refused inputs. A
// synthetic isotropic medium stands in for the computed one (tests/studies/
// spongy_medulla_test.cpp traces the real one).
#include <cmath>
#include <memory>

#include <gtest/gtest.h>

#include "common/constants.h"
#include "common/error.h"
#include "geometry/barb.h"
#include "sim/scattering_medium.h"
#include "sim/scene.h"
#include "sim/tracer.h"
#include "tests/test_util.h"

namespace plumage::sim {
namespace {

std::shared_ptr<const ScatteringMedium> isotropic_medium(double mu_s_per_um) {
    std::vector<MediumTable> tables;
    for (double lambda : {400.0, 700.0}) {
        tables.push_back({lambda, 1.27, mu_s_per_um, 0.0, {1.0, -1.0}, {0.25 / kPi, 0.25 / kPi}});
    }
    return std::make_shared<const ScatteringMedium>(std::move(tables));
}

geometry::BarbulePatch small_patch(double medulla_scale = 0.8) {
    geometry::BarbulePatchParams p;
    p.barb.barb_width_um = 32.0;    // horizontal
    p.barb.barb_axis_ratio = 1.25;  // 40 µm tall
    p.barb.medulla_scale = medulla_scale;
    p.barb.medulla_offset_y_um = 1.0;
    p.barb.medulla_offset_z_um = -0.5;
    p.barbule_length = 2.0;
    return geometry::build_barbule_patch(p, 400.0, 1, {0.5, 10.0 * kDeg});
}

double half_length(const geometry::TriangleMesh& mesh) {
    double x_max = 0.0;
    for (const Vec3d& p : mesh.positions) x_max = std::max(x_max, std::abs(p.x()));
    return x_max;
}

// Inside the medulla's ellipse (cross-section) and between the ends of `medulla`, with a margin.
bool strictly_inside_medulla(const geometry::BarbulePatch& patch,
                             const geometry::TriangleMesh& medulla, const Vec3d& q, double margin) {
    const auto& b = patch.params.barb;
    const double c = 0.5 * b.barb_width_um * b.medulla_scale;
    const double a = c * b.barb_axis_ratio;
    // rotation 0: semi-axis a along z, c along y.
    const double y = q.y() - b.medulla_offset_y_um, z = q.z() - b.medulla_offset_z_um;
    const double level = std::hypot(y / (c - margin), z / (a - margin));
    return level < 1.0 && std::abs(q.x()) < half_length(medulla) - margin;
}

TEST(SpongyMedullaScene, SurfacesNameTheMediumOnTheRightSides) {
    const geometry::BarbulePatch patch = small_patch();
    const auto medium = isotropic_medium(0.5);
    BarbulePatchMaterials materials;
    materials.spongy_medulla = SpongyMedulla{medium, 0.7, optics::melanin()};
    const SceneDescription scene = barbule_patch_scene(patch, materials);
    const UnitMesh& barb = scene.units.at(0);
    ASSERT_EQ(barb.surfaces.size(), 3u);
    const Surface& medulla = barb.surfaces[1];
    const Surface& core = barb.surfaces[2];
    EXPECT_EQ(medulla.name, "medulla");
    EXPECT_TRUE(std::holds_alternative<DielectricInterface>(medulla.material.layer));
    EXPECT_EQ(medulla.material.outside, optics::keratin());
    EXPECT_EQ(medulla.material.inside, medium->effective_material());
    EXPECT_EQ(medulla.material.inside_medium, medium);
    EXPECT_EQ(core.name, "medulla core");
    EXPECT_EQ(core.material.outside, medium->effective_material());
    EXPECT_EQ(core.material.outside_medium, medium);
    EXPECT_EQ(core.material.inside, optics::melanin());
    // The spongy medulla's ends are moved in from the cortex's (coplanar in the patch) by half
    // the cortex wall, (1 − 0.8)/2 × 16 µm = 1.6 µm; its cross-section is the patch's.
    EXPECT_NEAR(half_length(medulla.mesh), half_length(patch.barb_cortex) - 1.6, 1e-9);
    EXPECT_EQ(medulla.mesh.triangles, patch.barb_medulla.triangles);
    // The core lies strictly inside the medulla: its wall is (1 − 0.7) × the medulla's
    // semi-minor axis, 0.3 × 16 × 0.8 = 3.84 µm; at least 3 µm everywhere (the polygon's
    // chords cut inside the ellipse by at most the chord tolerance, 0.5 µm).
    ASSERT_EQ(core.mesh.triangles.size(), patch.barb_medulla.triangles.size());
    for (const Vec3d& q : core.mesh.positions) {
        ASSERT_TRUE(strictly_inside_medulla(patch, medulla.mesh, q, 3.0)) << q.transpose();
    }
    // The same winding as the medulla (outward normals): the signed volume is positive and
    // 0.7² of the medulla's, the length shrunk by the wall at each end.
    auto volume = [](const geometry::TriangleMesh& m) {
        double v = 0.0;
        for (const auto& t : m.triangles) {
            v += m.positions[t[0]].dot(m.positions[t[1]].cross(m.positions[t[2]])) / 6.0;
        }
        return v;
    };
    const double ratio = volume(core.mesh) / volume(medulla.mesh);
    const double half = half_length(medulla.mesh);
    EXPECT_GT(ratio, 0.0);
    EXPECT_NEAR(ratio, 0.49 * (half - 3.84) / half, 1e-9);
    // Without a core: the medulla surface alone.
    materials.spongy_medulla->core_scale = 0.0;
    EXPECT_EQ(barbule_patch_scene(patch, materials).units.at(0).surfaces.size(), 2u);
}

// A closed, lossless barb with a scattering medulla: every path leaves with weight 1, and
// none meets a surface from a side it did not travel in (the shell's material is one
// object on both of its surfaces).
TEST(SpongyMedullaScene, LosslessSpongyBarbConservesEnergyPerPath) {
    const geometry::BarbulePatch patch = small_patch();
    BarbulePatchMaterials materials;
    materials.spongy_medulla = SpongyMedulla{isotropic_medium(0.5), 0.0, optics::melanin()};
    const ExplicitScatterer tracer(barbule_patch_scene(patch, materials));
    int scattered = 0;
    for (int i = 0; i < 2000; ++i) {
        Rng rng(17, static_cast<std::uint64_t>(i));
        const Vec2 entry(rng.uniform() * 20.0 - 10.0, rng.uniform() * 20.0 - 10.0);
        const PathResult path = tracer.trace({0.0, 0.0, 1.0}, 550.0, entry, rng);
        ASSERT_TRUE(path.event.has_value()) << "path " << i;
        ASSERT_NEAR(path.event->weight, 1.0, 1e-12) << "path " << i;
        ASSERT_FALSE(path.reached_max_events);
        ASSERT_EQ(path.medium_mismatches, 0) << "path " << i;
        scattered += path.medium_scatters > 0;
    }
    EXPECT_GT(scattered, 1000);  // the medulla (τ ≈ 0.5 × 26 µm) scatters most entering paths
}

TEST(SpongyMedullaScene, BadInputIsAnInputErrorNamingTheParameter) {
    const geometry::BarbulePatch patch = small_patch();
    BarbulePatchMaterials materials;
    materials.spongy_medulla = SpongyMedulla{nullptr, 0.5, optics::melanin()};
    EXPECT_NE(testing::input_error_message([&] {
                  barbule_patch_scene(patch, materials);
              }).find("medium is null"),
              std::string::npos);
    materials.spongy_medulla = SpongyMedulla{isotropic_medium(0.5), 0.99, optics::melanin()};
    EXPECT_NE(testing::input_error_message([&] {
                  barbule_patch_scene(patch, materials);
              }).find("core_scale = 0.99"),
              std::string::npos);
    materials.spongy_medulla->core_scale = -0.1;
    EXPECT_THROW(barbule_patch_scene(patch, materials), InputError);
    materials.spongy_medulla->core_scale = 0.5;
    materials.spongy_medulla->core = nullptr;
    EXPECT_THROW(barbule_patch_scene(patch, materials), InputError);
    materials.spongy_medulla->core = optics::melanin();
    EXPECT_NE(testing::input_error_message([&] {
                  barbule_patch_scene(small_patch(0.0), materials);
              }).find("no medulla"),
              std::string::npos);
}

}  // namespace
}  // namespace plumage::sim
