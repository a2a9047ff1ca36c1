// Embree wrappers (errors become exceptions, buffers are padded) and scenes (instancing,
// double-precision hits and normals, builders, input checks).
#include "sim/scene.h"

#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include "common/error.h"
#include "geometry/barb.h"
#include "geometry/barbule.h"
#include "sim/embree_device.h"
#include "tests/sim/sim_test_util.h"
#include "tests/test_util.h"

namespace plumage::sim {
namespace {

using testing::input_error_message;

TEST(EmbreeDevice, ErrorCallbackTurnsEmbreeErrorsIntoExceptions) {
    const EmbreeDevice device;
    EmbreeGeometry geometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
    // A vertex stride that is not a multiple of 4 bytes: Embree reports an invalid
    // operation through the callback; check() turns it into an InvariantError (our bug).
    const std::vector<float> vertices = padded_vertex_buffer({0, 0, 0, 1, 0, 0, 0, 1, 0});
    rtcSetSharedGeometryBuffer(geometry.get(), RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                               vertices.data(), 0, 13, 3);
    try {
        device.check("rtcSetSharedGeometryBuffer");
        FAIL() << "expected an exception";
    } catch (const InvariantError& e) {
        EXPECT_NE(std::string(e.what()).find("Embree error in rtcSetSharedGeometryBuffer"),
                  std::string::npos)
            << e.what();
        EXPECT_NE(std::string(e.what()).find("aligned"), std::string::npos) << e.what();
    }
    // The error was consumed: the device works afterwards.
    EXPECT_NO_THROW(device.check("nothing"));
    EXPECT_NO_THROW(EmbreeScene(device, RTC_SCENE_FLAG_ROBUST, RTC_BUILD_QUALITY_HIGH));
    // A device Embree refuses to create (malformed configuration) is an IoError.
    EXPECT_THROW(EmbreeDevice("threads=abc,foo=bar"), IoError);
}

TEST(EmbreeDevice, VertexBuffersArePaddedByOneFloat) {
    const std::vector<float> xyz = {1, 2, 3, 4, 5, 6};
    const std::vector<float> padded = padded_vertex_buffer(xyz);
    ASSERT_EQ(padded.size(), 7u);
    EXPECT_EQ(padded[5], 6.0f);
    EXPECT_THROW(padded_vertex_buffer({1, 2}), InvariantError);
}

TEST(EmbreeDevice, MovedFromHandlesOwnNothing) {
    EmbreeDevice a;
    EmbreeDevice b = std::move(a);
    EXPECT_EQ(a.get(), nullptr);  // NOLINT(bugprone-use-after-move): the point of the test
    EXPECT_NE(b.get(), nullptr);
    EmbreeScene s(b, RTC_SCENE_FLAG_NONE, RTC_BUILD_QUALITY_LOW);
    EmbreeScene t = std::move(s);
    EXPECT_EQ(s.get(), nullptr);  // NOLINT(bugprone-use-after-move)
    EXPECT_NE(t.get(), nullptr);
}

TEST(SceneInstancing, HitsCarryInstanceDoublePositionAndTransformedNormals) {
    SceneDescription d;
    UnitMesh unit{"tile", {}};
    unit.surfaces.push_back({"square", testing::square_mesh(1.0), absorber()});
    d.units.push_back(std::move(unit));
    // Instance 0: identity. Instance 1: far away, rotated 30° about x and stretched along
    // y (non-uniform scale: normals need the inverse transpose).
    Eigen::Affine3d far = Eigen::Affine3d::Identity();
    far.translate(Vec3d(500.0, -300.0, 10.0));
    far.rotate(Eigen::AngleAxisd(std::numbers::pi / 6.0, Vec3d::UnitX()));
    far.scale(Vec3d(1.0, 3.0, 1.0));
    d.instances = {{0, Eigen::Affine3d::Identity()}, {0, far}};
    const Scene scene(d);

    const auto near_hit = scene.intersect({0.25, 0.5, 5.0}, {0.0, 0.0, -1.0});
    ASSERT_TRUE(near_hit);
    EXPECT_EQ(near_hit->primitive.instance, 0u);
    EXPECT_NEAR((near_hit->position - Vec3d(0.25, 0.5, 0.0)).norm(), 0.0, 1e-7);
    EXPECT_NEAR(near_hit->distance_um, 5.0, 1e-6);
    EXPECT_EQ(near_hit->normals.geometric, Vec3d(0, 0, 1));

    // Aim at the point (0.3, 0.2, 0) of the far tile, from along its normal.
    const Vec3d target = far * Vec3d(0.3, 0.2, 0.0);
    const Vec3d normal = (far.linear().inverse().transpose() * Vec3d::UnitZ()).normalized();
    const auto far_hit = scene.intersect(target + 3.0 * normal, -normal);
    ASSERT_TRUE(far_hit);
    EXPECT_EQ(far_hit->primitive.instance, 1u);
    // Double precision recomputed from barycentrics: on the facet plane to double
    // rounding, and at the aimed point to Embree's float barycentrics.
    EXPECT_NEAR((far_hit->position - target).dot(normal), 0.0, 1e-12);
    EXPECT_NEAR((far_hit->position - target).norm(), 0.0, 1e-4);
    EXPECT_NEAR((far_hit->normals.geometric - normal).norm(), 0.0, 1e-15);
    EXPECT_GT(far_hit->spawn_offset_um, 0.0);
    EXPECT_LT(far_hit->spawn_offset_um, 5e-3);

    // Skipping the facet just hit lets the ray through to nothing.
    int skipped = 0;
    EXPECT_FALSE(scene.intersect(target + 3.0 * normal, -normal, far_hit->primitive, &skipped));
    EXPECT_EQ(skipped, 1);
    // Spawned points lie on the requested side, by the offset.
    EXPECT_NEAR((scene.spawn_point(*far_hit, true) - far_hit->position).dot(normal),
                far_hit->spawn_offset_um, 1e-12);
    EXPECT_LT((scene.spawn_point(*far_hit, false) - far_hit->position).dot(normal), 0.0);
}

// Scene::intersect maps normals of a scaled rotation by the instance's own linear part and
// tests the shading normal in the unit frame; any other linear map takes the inverse
// transpose. Both must give the unit normals the inverse transpose gives, computed here
// independently, geometric and shading (a constant tilted shading normal interpolates to
// itself).
TEST(SceneInstancing, ScaledRotationsAndGeneralMapsGiveTheInverseTransposeNormals) {
    geometry::TriangleMesh mesh = testing::square_mesh(1.0);
    const Vec3d tilted = Vec3d(0.3, -0.2, 1.0).normalized();
    mesh.shading_normals.assign(mesh.positions.size(), tilted);
    SceneDescription d;
    UnitMesh unit{"tile", {}};
    unit.surfaces.push_back({"square", mesh, dielectric_interface(optics::keratin())});
    d.units.push_back(std::move(unit));
    const Eigen::Matrix3d rotation =
        Eigen::AngleAxisd(0.7, Vec3d(1.0, 2.0, 3.0).normalized()).toRotationMatrix();
    Eigen::Affine3d scaled_rotation = Eigen::Affine3d::Identity();
    scaled_rotation.translate(Vec3d(40.0, -7.0, 3.0));
    scaled_rotation.linear() = 2.5 * rotation;
    Eigen::Affine3d general = Eigen::Affine3d::Identity();
    general.translate(Vec3d(-60.0, 20.0, -5.0));
    general.linear() = rotation * Vec3d(1.0, 3.0, 0.5).asDiagonal();
    general.linear()(0, 1) += 0.4;  // and a shear
    d.instances = {{0, scaled_rotation}, {0, general}};
    const Scene scene(d);

    for (std::uint32_t i = 0; i < 2; ++i) {
        const Eigen::Affine3d& t = d.instances[i].transform;
        const Eigen::Matrix3d inverse_transpose = t.linear().inverse().transpose();
        const Vec3d normal = (inverse_transpose * Vec3d::UnitZ()).normalized();
        const Vec3d shading = (inverse_transpose * tilted).normalized();
        const Vec3d target = t * Vec3d(0.3, 0.2, 0.0);
        const auto hit = scene.intersect(target + 3.0 * normal, -normal);
        ASSERT_TRUE(hit) << "instance " << i;
        EXPECT_EQ(hit->primitive.instance, i);
        EXPECT_EQ(hit->surface, 0u);
        EXPECT_NEAR(hit->normals.geometric.norm(), 1.0, 1e-15) << "instance " << i;
        EXPECT_NEAR((hit->normals.geometric - normal).norm(), 0.0, 1e-15) << "instance " << i;
        EXPECT_NEAR((hit->normals.shading - shading).norm(), 0.0, 1e-15) << "instance " << i;
        EXPECT_NEAR((hit->position - target).dot(normal), 0.0, 1e-13) << "instance " << i;
        EXPECT_NEAR(hit->distance_um, 3.0, 1e-5) << "instance " << i;
    }
}

// Diffuse and absorbing surfaces: their events read the geometric normal only, so the scene
// reports it as the shading normal too, whatever normals their mesh carries; a bare interface
// with the same mesh keeps its tilted shading normal.
TEST(SceneInstancing, DiffuseAndAbsorbingSurfacesReportTheGeometricNormal) {
    geometry::TriangleMesh mesh = testing::square_mesh(1.0);
    const Vec3d tilted = Vec3d(0.3, -0.2, 1.0).normalized();
    mesh.shading_normals.assign(mesh.positions.size(), tilted);
    const SurfaceMaterial materials[] = {diffuse_layer(constant_albedo(0.5)), absorber(),
                                         dielectric_interface(optics::keratin())};
    for (const SurfaceMaterial& material : materials) {
        const Scene scene(single_mesh_scene(mesh, material));
        const auto hit = scene.intersect({0.3, 0.2, 3.0}, -Vec3d::UnitZ());
        ASSERT_TRUE(hit);
        EXPECT_EQ(hit->normals.geometric, Vec3d::UnitZ());
        const Vec3d expected =
            material.has_film() || std::holds_alternative<DielectricInterface>(material.layer)
                ? tilted
                : Vec3d::UnitZ();
        EXPECT_NEAR((hit->normals.shading - expected).norm(), 0.0, 1e-15);
    }
}

TEST(SceneBuilders, BarbuleRowIsOneUnitWithFilmAndMelanin) {
    geometry::BarbuleRowParams params;
    params.barbules = 3;
    params.cells_per_barbule = 2;
    params.cell.film_thickness_um = 0.53;
    const geometry::BarbuleRow row = geometry::build_barbule_row(params, {0.05, 0.05});
    const SceneDescription d = barbule_row_scene(row);
    ASSERT_EQ(d.units.size(), 1u);
    ASSERT_EQ(d.units[0].surfaces.size(), 2u);
    EXPECT_EQ(d.instances.size(), 6u);
    const auto& film = std::get<ThinFilmInterface>(d.units[0].surfaces[0].material.layer);
    EXPECT_EQ(film.thickness_um, 0.53);
    EXPECT_EQ(film.film->name(), "keratin");
    const auto& melanin = std::get<DiffuseLayer>(d.units[0].surfaces[1].material.layer);
    // Huang's melanin reflectance: normal-incidence Fresnel air → melanin.
    EXPECT_NEAR(melanin.albedo(550.0),
                optics::fresnel_intensities_unpolarised(1.0, optics::melanin()->index(550.0), 1.0)
                    .reflectance,
                0.0);
    EXPECT_TRUE(d.has_film());
    const Eigen::AlignedBox3d box = d.bounds();
    EXPECT_TRUE(box.isApprox(row.bounds(), 1e-12));
    const Scene scene(d);
    EXPECT_EQ(scene.surface_count(), 2u);
}

TEST(SceneBuilders, BarbulePatchHasCortexMedullaAndBarbules) {
    geometry::BarbulePatchParams params;
    params.barb.medulla_scale = 0.5;
    const geometry::BarbulePatch patch =
        geometry::build_barbule_patch(params, 60.0, 2, {0.05, 0.05});
    const SceneDescription d = barbule_patch_scene(patch);
    ASSERT_EQ(d.units.size(), 2u);
    EXPECT_EQ(d.units[0].surfaces.size(), 2u);  // cortex, medulla
    EXPECT_EQ(d.instances.size(), patch.barb_instances.size() + patch.barbule_instances.size());
    EXPECT_TRUE(std::holds_alternative<DielectricInterface>(d.units[0].surfaces[0].material.layer));
    EXPECT_EQ(d.units[0].surfaces[0].material.inside->name(), "keratin");
    EXPECT_TRUE(std::holds_alternative<DiffuseLayer>(d.units[0].surfaces[1].material.layer));
    EXPECT_EQ(d.units[0].surfaces[1].material.outside->name(), "keratin");
    EXPECT_FALSE(d.has_film());
    const Scene scene(d);
    EXPECT_EQ(scene.surface_count(), 3u);
}

TEST(SceneBuilders, InputErrorsNameTheValue) {
    EXPECT_NE(input_error_message([] {
                  thin_film_interface(optics::keratin(), -0.1);
              }).find("film thickness = -0.1 um"),
              std::string::npos);
    EXPECT_NE(input_error_message([] { constant_albedo(1.5); }).find("albedo = 1.5"),
              std::string::npos);
    EXPECT_NE(
        input_error_message([] { dielectric_interface(nullptr); }).find("inside material is null"),
        std::string::npos);

    SceneDescription d = single_mesh_scene(testing::square_mesh(1.0), absorber(), "plate");
    d.instances.push_back({3, Eigen::Affine3d::Identity()});
    EXPECT_NE(input_error_message([&] { d.validate(); }).find("unit 3: expected an index below 1"),
              std::string::npos);
    d.instances.pop_back();
    d.instances.push_back({0, Eigen::Affine3d(Eigen::Scaling(1.0, 0.0, 1.0))});
    EXPECT_NE(input_error_message([&] { d.validate(); }).find("not finite and invertible"),
              std::string::npos);
    d.instances.pop_back();
    d.units[0].surfaces[0].mesh.positions[1].x() = std::nan("");
    EXPECT_NE(input_error_message([&] { d.validate(); }).find("vertex 1 is not finite"),
              std::string::npos);
    d.units[0].surfaces[0].mesh = testing::square_mesh(1.0);
    d.units[0].surfaces[0].mesh.triangles[1][2] = 9;
    EXPECT_NE(input_error_message([&] { d.validate(); }).find("refers to vertex 9"),
              std::string::npos);
    d.units[0].surfaces[0].mesh = testing::square_mesh(1.0);
    d.units[0].surfaces[0].mesh.shading_normals = {Vec3d::UnitZ()};
    EXPECT_NE(input_error_message([&] { d.validate(); }).find("1 shading normals for 4 vertices"),
              std::string::npos);
}

}  // namespace
}  // namespace plumage::sim
