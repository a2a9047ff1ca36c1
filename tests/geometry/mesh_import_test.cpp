// Mesh import and validation: a cube read from OBJ, ASCII PLY and binary PLY; the repairs
// (winding, inside-out shells, duplicate vertices, degenerate faces, shading normals);
// and the rejections, each asserted on the words of its message.
#include "geometry/mesh_import.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "tests/test_util.h"

namespace plumage::geometry {
namespace {

using plumage::testing::input_error_message;

::testing::AssertionResult contains(const std::string& text, const std::string& part) {
    if (text.find(part) != std::string::npos) return ::testing::AssertionSuccess();
    return ::testing::AssertionFailure() << "'" << part << "' is not in:\n" << text;
}
#define EXPECT_CONTAINS(text, part) EXPECT_TRUE(contains((text), (part)))

// A polygon soup to write in each format; faces index positions from 0.
struct MeshData {
    std::vector<Vec3> positions;
    std::vector<std::vector<std::uint32_t>> faces;
};

// Axis-aligned cube [origin, origin + s]³, 12 triangles wound counter-clockwise seen from
// outside.
MeshData cube(double s, const Vec3& origin = Vec3::Zero()) {
    MeshData m;
    const double corners[8][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0},
                                  {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
    for (const auto& c : corners) m.positions.push_back(origin + s * Vec3(c[0], c[1], c[2]));
    m.faces = {{0, 2, 1}, {0, 3, 2}, {4, 5, 6}, {4, 6, 7}, {0, 1, 5}, {0, 5, 4},
               {3, 7, 6}, {3, 6, 2}, {0, 4, 7}, {0, 7, 3}, {1, 2, 6}, {1, 6, 5}};
    return m;
}

void append(MeshData& to, const MeshData& from) {
    const auto offset = static_cast<std::uint32_t>(to.positions.size());
    to.positions.insert(to.positions.end(), from.positions.begin(), from.positions.end());
    for (auto face : from.faces) {
        for (auto& v : face) v += offset;
        to.faces.push_back(face);
    }
}

void reverse_all(MeshData& m) {
    for (auto& face : m.faces) std::reverse(face.begin(), face.end());
}

// OBJ: a comment on line 1, then one 'v' per line, then one 'f' per line.
std::string to_obj(const MeshData& m) {
    std::string text = "# plumage test mesh\n";
    for (const Vec3& p : m.positions) text += fmt::format("v {} {} {}\n", p.x(), p.y(), p.z());
    for (const auto& face : m.faces) {
        text += "f";
        for (const auto v : face) text += fmt::format(" {}", v + 1);
        text += "\n";
    }
    return text;
}
std::size_t obj_vertex_line(std::size_t v) { return 2 + v; }
std::size_t obj_face_line(const MeshData& m, std::size_t f) { return 2 + m.positions.size() + f; }

// ASCII PLY: a 9-line header, then one vertex and one face per line.
std::string to_ascii_ply(const MeshData& m) {
    std::string text = fmt::format(
        "ply\nformat ascii 1.0\nelement vertex {}\nproperty float x\nproperty float y\n"
        "property float z\nelement face {}\nproperty list uchar int vertex_indices\nend_header\n",
        m.positions.size(), m.faces.size());
    for (const Vec3& p : m.positions) text += fmt::format("{} {} {}\n", p.x(), p.y(), p.z());
    for (const auto& face : m.faces) {
        text += fmt::format("{}", face.size());
        for (const auto v : face) text += fmt::format(" {}", v);
        text += "\n";
    }
    return text;
}
std::size_t ply_face_line(const MeshData& m, std::size_t f) { return 10 + m.positions.size() + f; }

template <typename T>
void put(std::string& bytes, T value) {
    char raw[sizeof(T)];
    std::memcpy(raw, &value, sizeof(T));
    bytes.append(raw, sizeof(T));
}

// Binary little-endian PLY with float32 coordinates and an extra per-vertex uchar and
// per-face int property that the reader must skip.
std::string to_binary_ply(const MeshData& m) {
    std::string bytes = fmt::format(
        "ply\nformat binary_little_endian 1.0\ncomment written by the test\n"
        "element vertex {}\nproperty float x\nproperty float y\nproperty float z\n"
        "property uchar quality\nelement face {}\nproperty list uchar uint vertex_indices\n"
        "property int material\nend_header\n",
        m.positions.size(), m.faces.size());
    for (const Vec3& p : m.positions) {
        for (int i = 0; i < 3; ++i) put(bytes, static_cast<float>(p[i]));
        put(bytes, std::uint8_t{7});
    }
    for (const auto& face : m.faces) {
        put(bytes, static_cast<std::uint8_t>(face.size()));
        for (const auto v : face) put(bytes, v);
        put(bytes, std::int32_t{-1});
    }
    return bytes;
}

std::filesystem::path scratch_dir() {
    return std::filesystem::temp_directory_path() /
           ("plumage_mesh_import_test_" + std::to_string(::getpid()));
}

std::filesystem::path scratch(const std::string& name) {
    std::filesystem::create_directories(scratch_dir());
    return scratch_dir() / name;
}

// Each test writes its files into scratch_dir(), removed after it.
class MeshImport : public ::testing::Test {
protected:
    void TearDown() override {
        std::error_code ignored;
        std::filesystem::remove_all(scratch_dir(), ignored);
    }
};

std::filesystem::path write(const std::string& name, const std::string& bytes) {
    const auto path = scratch(name);
    std::ofstream out(path, std::ios::binary);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    return path;
}

double signed_volume(const TriangleMesh& mesh) {
    double volume = 0.0;
    for (const Triangle& t : mesh.triangles) {
        volume += mesh.positions[t[0]].dot(mesh.positions[t[1]].cross(mesh.positions[t[2]])) / 6.0;
    }
    return volume;
}

// For a convex body: every face normal points away from the centre.
bool faces_point_away_from(const TriangleMesh& mesh, const Vec3& centre) {
    for (std::size_t i = 0; i < mesh.triangles.size(); ++i) {
        const Triangle& t = mesh.triangles[i];
        const Vec3 middle =
            (mesh.positions[t[0]] + mesh.positions[t[1]] + mesh.positions[t[2]]) / 3;
        if (mesh.face_normal(i).dot(middle - centre) <= 0.0) return false;
    }
    return true;
}

const MeshDefect* find_defect(const MeshReport& report, MeshDefectKind kind) {
    for (const MeshDefect& d : report.defects) {
        if (d.kind == kind) return &d;
    }
    return nullptr;
}

// The cube [0, s]³: 12 triangles on 8 vertices, outward.
void expect_cube(const TriangleMesh& mesh, double s) {
    EXPECT_EQ(mesh.triangles.size(), 12u);
    EXPECT_EQ(mesh.positions.size(), 8u);
    EXPECT_NEAR(mesh.surface_area(), 6 * s * s, 1e-12 * s * s);
    EXPECT_NEAR(signed_volume(mesh), s * s * s, 1e-12 * s * s * s);
    EXPECT_TRUE(faces_point_away_from(mesh, Vec3::Constant(s / 2)));
}

// ... and nothing to report.
void expect_valid_cube(const ImportedMesh& imported, double s) {
    expect_cube(imported.mesh, s);
    EXPECT_TRUE(imported.report.clean()) << imported.report.summary();
    EXPECT_TRUE(imported.report.closed);
    EXPECT_EQ(imported.report.components, 1u);
}

TEST_F(MeshImport, CubeFromObjAsciiPlyAndBinaryPly) {
    const double s = 2.5;  // exact in float, so binary float32 loses nothing
    expect_valid_cube(import_mesh(write("cube.obj", to_obj(cube(s)))), s);
    expect_valid_cube(import_mesh(write("cube.ply", to_ascii_ply(cube(s)))), s);
    expect_valid_cube(import_mesh(write("cube_binary.PLY", to_binary_ply(cube(s)))), s);
}

TEST_F(MeshImport, BinaryPlyFromWritePlyRoundTripsWithShadingNormals) {
    TriangleMesh mesh;
    const MeshData c = cube(3.0);
    mesh.positions = c.positions;
    for (const Vec3& p : c.positions)
        mesh.shading_normals.push_back((p - Vec3::Constant(1.5)).normalized());
    for (const auto& f : c.faces) mesh.triangles.push_back({f[0], f[1], f[2]});
    const auto path = scratch("roundtrip.ply");
    write_ply(mesh, path);
    const ImportedMesh back = import_mesh(path);
    EXPECT_TRUE(back.report.clean()) << back.report.summary();
    EXPECT_EQ(back.mesh.positions, mesh.positions);
    EXPECT_EQ(back.mesh.triangles, mesh.triangles);
    ASSERT_EQ(back.mesh.shading_normals.size(), 8u);
    for (std::size_t v = 0; v < 8; ++v) {
        EXPECT_LT((back.mesh.shading_normals[v] - mesh.shading_normals[v]).norm(), 1e-15);
    }
}

TEST_F(MeshImport, ScaleToUmConvertsFileUnits) {
    const auto path = write("cube_nm.obj", to_obj(cube(2500.0)));  // nanometres
    const TriangleMesh mesh = read_mesh(path, {.scale_to_um = 1e-3});
    EXPECT_NEAR(mesh.surface_area(), 6 * 2.5 * 2.5, 1e-12);
    for (const double bad : {0.0, -1.0, std::nan(""), std::numeric_limits<double>::infinity()}) {
        EXPECT_CONTAINS(input_error_message([&] { read_mesh(path, {.scale_to_um = bad}); }),
                        "scale_to_um");
    }
}

TEST_F(MeshImport, ObjQuadsIndexFormsNegativeIndicesAndIgnoredStatements) {
    // The cube as six convex quads, each written in another index form; the normals are
    // per vertex (radial), so they survive as shading normals.
    std::string text =
        "# exported by hand\nmtllib feather.mtl\no cube\n"
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n";
    for (const auto& c : cube(1.0).positions) {
        const Vec3 n = c - Vec3::Constant(0.5);
        text += fmt::format("vn {} {} {}\n", 2 * n.x(), 2 * n.y(), 2 * n.z());  // not unit
    }
    text +=
        "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\ng sides\nusemtl keratin\ns 1\n"
        "f 1//1 4//4 3//3 2//2\n"             // bottom
        "f 5/1/5 6/2/6 7/3/7 8/4/8  # top\n"  // v/vt/vn
        "f -8//-8 -7//-7 -3//-3 -4//-4\n"     // front, negative indices
        "f 4//4 8//8 7//7 3//3\r\n"           // back, CRLF
        "f 1/1/1 5/2/5 8/3/8 4/4/4\n"         // left
        "f 2//2 3//3 7//7 6//6\n";            // right
    const ImportedMesh imported = import_mesh(write("quads.obj", text));
    expect_valid_cube(imported, 1.0);
    EXPECT_EQ(imported.report.faces_read, 6u);
    ASSERT_EQ(imported.mesh.shading_normals.size(), 8u);
    for (std::size_t v = 0; v < 8; ++v) {
        const Vec3 radial = (imported.mesh.positions[v] - Vec3::Constant(0.5)).normalized();
        EXPECT_NEAR(imported.mesh.shading_normals[v].dot(radial), 1.0, 1e-15);
    }
}

TEST_F(MeshImport, ObjFlatShadedNormalsAreDroppedAndReported) {
    // One normal per face, as flat-shading exporters write: a vertex gets three normals.
    const MeshData c = cube(1.0);
    std::string text;
    for (const Vec3& p : c.positions) text += fmt::format("v {} {} {}\n", p.x(), p.y(), p.z());
    for (std::size_t f = 0; f < c.faces.size(); ++f) {
        TriangleMesh one;
        one.positions = c.positions;
        one.triangles = {{c.faces[f][0], c.faces[f][1], c.faces[f][2]}};
        const Vec3 n = one.face_normal(0);
        text += fmt::format("vn {} {} {}\n", n.x(), n.y(), n.z());
    }
    for (std::size_t f = 0; f < c.faces.size(); ++f) {
        text += fmt::format("f {0}//{3} {1}//{3} {2}//{3}\n", c.faces[f][0] + 1, c.faces[f][1] + 1,
                            c.faces[f][2] + 1, f + 1);
    }
    const ImportedMesh imported = import_mesh(write("flat.obj", text));
    EXPECT_TRUE(imported.mesh.shading_normals.empty());
    EXPECT_EQ(imported.report.count(MeshDefectKind::shading_normals_dropped), 1u);
    EXPECT_CONTAINS(imported.report.summary(), "different normals on different faces");
    EXPECT_EQ(imported.mesh.triangles.size(), 12u);
}

TEST_F(MeshImport, PolygonFanAvoidsCollinearVertices) {
    // The bottom and front sides as pentagons sharing a midpoint m on their common edge:
    // a fan from corner 0 would contain the zero-area triangle (0, 1, m).
    const std::string text =
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n"
        "v 0.5 0 0\n"
        "f 1 4 3 2 9\nf 5 6 7 8\nf 1 9 2 6 5\nf 4 8 7 3\nf 1 5 8 4\nf 2 3 7 6\n";
    const ImportedMesh imported = import_mesh(write("pentagons.obj", text));
    EXPECT_TRUE(imported.report.clean()) << imported.report.summary();
    EXPECT_EQ(imported.mesh.triangles.size(), 14u);
    for (std::size_t i = 0; i < imported.mesh.triangles.size(); ++i) {
        EXPECT_GT(imported.mesh.face_area(i), 0.1);
    }
    EXPECT_NEAR(imported.mesh.surface_area(), 6.0, 1e-12);
    EXPECT_NEAR(signed_volume(imported.mesh), 1.0, 1e-12);
}

TEST_F(MeshImport, InvertedFaceIsFlippedAndReported) {
    MeshData c = cube(2.0);
    std::reverse(c.faces[4].begin(), c.faces[4].end());
    const ImportedMesh imported = import_mesh(write("one_inverted.obj", to_obj(c)));
    EXPECT_EQ(imported.mesh.triangles.size(), 12u);
    EXPECT_NEAR(signed_volume(imported.mesh), 8.0, 1e-12);
    EXPECT_TRUE(faces_point_away_from(imported.mesh, Vec3::Constant(1.0)));
    EXPECT_EQ(imported.report.count(MeshDefectKind::inconsistent_orientation), 1u);
    EXPECT_EQ(imported.report.count(MeshDefectKind::inward_orientation), 0u);
    const MeshDefect* d = find_defect(imported.report, MeshDefectKind::inconsistent_orientation);
    ASSERT_NE(d, nullptr);
    EXPECT_EQ(d->index, 4u);
    EXPECT_EQ(d->line, obj_face_line(c, 4));
    EXPECT_TRUE(d->repaired);
    EXPECT_CONTAINS(d->message, fmt::format("face on line {}", obj_face_line(c, 4)));
}

TEST_F(MeshImport, InsideOutCubeIsTurnedOutward) {
    MeshData c = cube(2.0);
    reverse_all(c);
    const ImportedMesh imported = import_mesh(write("inside_out.ply", to_ascii_ply(c)));
    EXPECT_NEAR(signed_volume(imported.mesh), 8.0, 1e-12);
    EXPECT_TRUE(faces_point_away_from(imported.mesh, Vec3::Constant(1.0)));
    EXPECT_EQ(imported.report.count(MeshDefectKind::inward_orientation), 1u);
    EXPECT_EQ(imported.report.count(MeshDefectKind::inconsistent_orientation), 0u);
    EXPECT_CONTAINS(imported.report.summary(), "inside-out");
}

TEST_F(MeshImport, NestedShellBoundsTheCavity) {
    // A hollow box: the inner shell, written outward, must face into the cavity.
    MeshData hollow = cube(4.0);
    append(hollow, cube(2.0, Vec3::Constant(1.0)));
    const ImportedMesh imported = import_mesh(write("hollow.obj", to_obj(hollow)));
    EXPECT_NEAR(signed_volume(imported.mesh), 64.0 - 8.0, 1e-12);
    EXPECT_EQ(imported.report.components, 2u);
    EXPECT_EQ(imported.report.count(MeshDefectKind::inward_orientation), 1u);
}

TEST_F(MeshImport, InsideOutShadingNormalsFollowTheFaces) {
    // Inside-out winding and inward normals, as a mirrored export gives.
    MeshData c = cube(1.0);
    reverse_all(c);
    std::string text =
        "ply\nformat ascii 1.0\nelement vertex 8\nproperty double x\n"
        "property double y\nproperty double z\nproperty double nx\n"
        "property double ny\nproperty double nz\nelement face 12\n"
        "property list uchar int vertex_indices\nend_header\n";
    for (const Vec3& p : c.positions) {
        const Vec3 inward = Vec3::Constant(0.5) - p;
        text += fmt::format("{} {} {} {} {} {}\n", p.x(), p.y(), p.z(), inward.x(), inward.y(),
                            inward.z());
    }
    for (const auto& f : c.faces) text += fmt::format("3 {} {} {}\n", f[0], f[1], f[2]);
    const ImportedMesh imported = import_mesh(write("inside_out_normals.ply", text));
    EXPECT_EQ(imported.report.count(MeshDefectKind::inward_orientation), 1u);
    EXPECT_EQ(imported.report.count(MeshDefectKind::shading_normal_flipped), 8u);
    for (std::size_t v = 0; v < 8; ++v) {
        const Vec3 outward = (imported.mesh.positions[v] - Vec3::Constant(0.5)).normalized();
        EXPECT_NEAR(imported.mesh.shading_normals[v].dot(outward), 1.0, 1e-15);
    }
}

TEST_F(MeshImport, DuplicateVerticesAreMerged) {
    // The top face written with its own copies of the top corners (an unwelded seam).
    MeshData c = cube(1.5);
    for (std::uint32_t v = 4; v < 8; ++v) c.positions.push_back(c.positions[v]);
    for (const std::size_t f : {2, 3}) {
        for (auto& v : c.faces[f]) v += 4;
    }
    const auto path = write("unwelded.obj", to_obj(c));
    const ImportedMesh imported = import_mesh(path);
    expect_cube(imported.mesh, 1.5);
    EXPECT_TRUE(imported.report.closed);
    EXPECT_EQ(imported.report.count(MeshDefectKind::duplicate_vertex), 4u);
    EXPECT_EQ(imported.report.count(MeshDefectKind::isolated_vertex), 0u);
    const MeshDefect* d = find_defect(imported.report, MeshDefectKind::duplicate_vertex);
    ASSERT_NE(d, nullptr);
    EXPECT_EQ(d->index, 8u);
    EXPECT_EQ(d->other, 4u);
    EXPECT_CONTAINS(d->message, "vertex 9 (line 10) is at the same position as vertex 5");
    // Without repair, the seam is an open border.
    EXPECT_CONTAINS(input_error_message([&] { read_mesh(path, {.repair = false}); }),
                    "border edge");
}

TEST_F(MeshImport, DegenerateFaceIsRemoved) {
    // A zero-area triangle along the cube's edge 0–1, through an extra midpoint vertex.
    MeshData c = cube(1.0);
    c.positions.push_back(Vec3(0.5, 0, 0));
    c.faces.push_back({0, 8, 1});
    const auto path = write("degenerate.obj", to_obj(c));
    const ImportedMesh imported = import_mesh(path);
    expect_cube(imported.mesh, 1.0);
    EXPECT_EQ(imported.report.count(MeshDefectKind::degenerate_face), 1u);
    EXPECT_EQ(imported.report.count(MeshDefectKind::isolated_vertex), 1u);  // the midpoint
    const MeshDefect* d = find_defect(imported.report, MeshDefectKind::degenerate_face);
    ASSERT_NE(d, nullptr);
    EXPECT_EQ(d->line, obj_face_line(c, 12));
    EXPECT_CONTAINS(d->message, "zero area");
    const std::string rejected = input_error_message([&] { read_mesh(path, {.repair = false}); });
    EXPECT_CONTAINS(rejected, "zero area");
    EXPECT_CONTAINS(rejected, fmt::format("face on line {}", obj_face_line(c, 12)));
}

TEST_F(MeshImport, RepairOffRejectsWhatRepairWouldFix) {
    MeshData c = cube(1.0);
    std::reverse(c.faces[7].begin(), c.faces[7].end());
    const std::string message = input_error_message(
        [&] { read_mesh(write("inverted_norepair.ply", to_ascii_ply(c)), {.repair = false}); });
    EXPECT_CONTAINS(message, "inverted_norepair.ply");
    EXPECT_CONTAINS(message, "face 7 (line");
    EXPECT_CONTAINS(message, "winds against its neighbours");
    EXPECT_CONTAINS(message, "repair is off");
}

TEST_F(MeshImport, RejectsNonManifoldEdge) {
    // A fin on the cube's edge 0–1: three faces on one edge.
    MeshData c = cube(1.0);
    c.positions.push_back(Vec3(0.5, -1.0, -1.0));
    c.faces.push_back({0, 1, 8});
    const auto path = write("fin.obj", to_obj(c));
    for (const bool require_closed : {true, false}) {
        const std::string message =
            input_error_message([&] { read_mesh(path, {.require_closed = require_closed}); });
        EXPECT_CONTAINS(message, "fin.obj");
        EXPECT_CONTAINS(message, "non-manifold edge");
        EXPECT_CONTAINS(message, "edge between vertex 1 (line 2) and vertex 2 (line 3)");
        EXPECT_CONTAINS(message, "shared by 3 faces");
        EXPECT_CONTAINS(message, fmt::format("face on line {}", obj_face_line(c, 12)));
    }
}

TEST_F(MeshImport, RejectsNonManifoldVertex) {
    // Two cubes touching at one corner (its duplicate is merged first).
    MeshData c = cube(1.0);
    append(c, cube(1.0, Vec3::Constant(1.0)));
    const std::string message =
        input_error_message([&] { read_mesh(write("bowtie.ply", to_ascii_ply(c))); });
    EXPECT_CONTAINS(message, "non-manifold vertex");
    EXPECT_CONTAINS(message, "vertex 6 (line 16)");  // (1, 1, 1), kept over vertex 8
    EXPECT_CONTAINS(message, "2 separate fans");
}

TEST_F(MeshImport, RejectsMoebiusStripEvenWhenOpenIsAllowed) {
    // Six segments around a circle, the cross-section turning by π in all: after one turn
    // the strip's edge a joins its edge b, so no winding agrees with every neighbour.
    const int n = 6;
    const double pi = std::acos(-1.0);
    std::string text;
    for (int i = 0; i < n; ++i) {
        const double phi = 2 * pi * i / n, twist = pi * i / n;
        for (const double s : {-0.3, 0.3}) {
            const double r = 1 + s * std::cos(twist);
            text += fmt::format("v {} {} {}\n", r * std::cos(phi), r * std::sin(phi),
                                s * std::sin(twist));
        }
    }
    for (int i = 0; i < n; ++i) {
        const int a = 2 * i + 1, b = 2 * i + 2;  // OBJ indices of a_i, b_i
        const int a_next = i + 1 < n ? a + 2 : 2, b_next = i + 1 < n ? b + 2 : 1;
        text += fmt::format("f {} {} {}\nf {} {} {}\n", a, a_next, b_next, a, b_next, b);
    }
    const std::string message = input_error_message(
        [&] { read_mesh(write("moebius.obj", text), {.require_closed = false}); });
    EXPECT_CONTAINS(message, "non-orientable surface: the surface containing face on line 13");
    EXPECT_CONTAINS(message, "expected a two-sided surface");
}

TEST_F(MeshImport, RejectsOpenMeshUnlessAllowed) {
    MeshData c = cube(1.0);
    c.faces.pop_back();  // the right side loses a triangle
    const auto path = write("open.obj", to_obj(c));
    const std::string message = input_error_message([&] { read_mesh(path); });
    EXPECT_CONTAINS(message, "open.obj");
    EXPECT_CONTAINS(message, "border edge");
    EXPECT_CONTAINS(message, "mesh is open");
    EXPECT_CONTAINS(message, "3 defects");  // the hole's three edges
    EXPECT_CONTAINS(message, fmt::format("face on line {}", obj_face_line(c, 10)));

    // Allowed (a one-sided film): loads, and the other checks still run and repair.
    std::reverse(c.faces[0].begin(), c.faces[0].end());
    const ImportedMesh film = import_mesh(write("film.obj", to_obj(c)), {.require_closed = false});
    EXPECT_EQ(film.mesh.triangles.size(), 11u);
    EXPECT_NEAR(film.mesh.surface_area(), 5.5, 1e-12);
    EXPECT_FALSE(film.report.closed);
    EXPECT_EQ(film.report.count(MeshDefectKind::border_edge), 0u);
    EXPECT_EQ(film.report.count(MeshDefectKind::inconsistent_orientation), 1u);
    EXPECT_TRUE(faces_point_away_from(film.mesh, Vec3::Constant(0.5)));
}

TEST_F(MeshImport, RejectsSelfIntersection) {
    // Two boxes that interpenetrate.
    MeshData c = cube(1.0);
    append(c, cube(1.0, Vec3(0.5, 0.25, 0.4)));
    const std::string message =
        input_error_message([&] { read_mesh(write("overlap.obj", to_obj(c))); });
    EXPECT_CONTAINS(message, "overlap.obj");
    EXPECT_CONTAINS(message, "self-intersection");
    EXPECT_CONTAINS(message, "self-intersection: face on line");
    EXPECT_CONTAINS(message, " cross: expected a surface that does not pass through itself");
    EXPECT_CONTAINS(message, "defects that are not safely repairable");

    // Open films are checked too: a flap that passes through the sheet...
    const std::string pierced =
        "v 0 0 0\nv 2 0 0\nv 2 2 0\nv 0 2 0\nv 1 1 -1\nv 1 1 1\nv 3 1 1\n"
        "f 1 2 3\nf 1 3 4\nf 5 6 7\n";
    EXPECT_CONTAINS(input_error_message([&] {
                        read_mesh(write("pierced.obj", pierced), {.require_closed = false});
                    }),
                    "self-intersection: face on line 8 and face on line 10 cross");
    // ... and a face folded flat back onto its neighbour across their shared edge.
    const std::string folded = "v 0 0 0\nv 2 0 0\nv 0 2 0\nv 0.5 0.5 0\nf 1 2 3\nf 3 2 4\n";
    EXPECT_CONTAINS(input_error_message(
                        [&] { read_mesh(write("folded.obj", folded), {.require_closed = false}); }),
                    "self-intersection: face on line 5 and face on line 6 cross");
}

TEST_F(MeshImport, RejectsNonFiniteVertexNamingIt) {
    MeshData c = cube(1.0);
    c.positions[2].x() = std::nan("");
    const std::string obj = input_error_message([&] { read_mesh(write("nan.obj", to_obj(c))); });
    EXPECT_CONTAINS(obj, "nan.obj");
    EXPECT_CONTAINS(obj, fmt::format("vertex 3 (line {}) has x = nan", obj_vertex_line(2)));
    EXPECT_CONTAINS(obj, "expected finite coordinates");

    c.positions[2].x() = 1.0;
    c.positions[5].z() = std::numeric_limits<double>::infinity();
    EXPECT_CONTAINS(input_error_message([&] { read_mesh(write("inf.ply", to_binary_ply(c))); }),
                    "vertex 5 has z = inf");
    EXPECT_CONTAINS(
        input_error_message([&] { read_mesh(write("inf_ascii.ply", to_ascii_ply(c))); }),
        "vertex 5 (line 15) has z = inf");
    // Finite in the file, infinite in micrometres.
    c.positions[5].z() = 1e300;
    EXPECT_CONTAINS(input_error_message(
                        [&] { read_mesh(write("huge.obj", to_obj(c)), {.scale_to_um = 1e10}); }),
                    "vertex 6 (line 7) at (1, 0, 1e+300) times scale_to_um");
}

TEST_F(MeshImport, RejectsEmptyFile) {
    EXPECT_CONTAINS(input_error_message([&] { read_mesh(write("empty.obj", "")); }),
                    "empty.obj': the file is empty");
    EXPECT_CONTAINS(input_error_message([&] { read_mesh(write("empty.ply", "")); }),
                    "empty.ply': the file is empty: expected a PLY mesh");
    EXPECT_CONTAINS(input_error_message([&] { read_mesh(write("comments.obj", "# nothing\n\n")); }),
                    "no vertices");
    EXPECT_CONTAINS(
        input_error_message([&] { read_mesh(write("points.obj", "v 0 0 0\nv 1 0 0\n")); }),
        "no faces");
}

TEST_F(MeshImport, RejectsWrongFormat) {
    const std::string png("\x89PNG\r\n\x1a\n\0\0\0\rIHDR", 16);
    const std::string as_ply = input_error_message([&] { read_mesh(write("image.ply", png)); });
    EXPECT_CONTAINS(as_ply, "image.ply");
    EXPECT_CONTAINS(as_ply, "starts with \"\\x89PNG");
    EXPECT_CONTAINS(as_ply, "expected a PLY file");
    EXPECT_CONTAINS(input_error_message([&] { read_mesh(write("image.obj", png)); }),
                    "binary data");
    EXPECT_CONTAINS(input_error_message([&] { read_mesh(write("garbage.ply", "hello world\n")); }),
                    "expected a PLY file");
    EXPECT_CONTAINS(
        input_error_message([&] { read_mesh(write("garbage.obj", "v 0 0 0\nhello\n")); }),
        "line 2: unsupported OBJ statement 'hello'");
    EXPECT_CONTAINS(input_error_message([&] { read_mesh(write("cube.stl", "solid cube\n")); }),
                    "unknown format '.stl': expected a .ply or .obj file");
    EXPECT_CONTAINS(input_error_message([&] { read_mesh(scratch("no_such_mesh.obj")); }),
                    "does not exist");
    const std::string big_endian = input_error_message(
        [&] { read_mesh(write("big.ply", "ply\nformat binary_big_endian 1.0\nend_header\n")); });
    EXPECT_CONTAINS(big_endian, "line 2");
    EXPECT_CONTAINS(big_endian, "expected 'format ascii 1.0' or 'format binary_little_endian");
    // A binary body shorter than the header declares.
    std::string truncated = to_binary_ply(cube(1.0));
    truncated.resize(truncated.size() - 10);
    EXPECT_CONTAINS(input_error_message([&] { read_mesh(write("truncated.ply", truncated)); }),
                    "face 11: the file ends inside property 'vertex_indices'");
}

TEST_F(MeshImport, RejectsOutOfRangeIndexNamingTheFace) {
    MeshData c = cube(1.0);
    c.faces[5][1] = 8;  // one past the last vertex
    const std::string obj = input_error_message([&] { read_mesh(write("range.obj", to_obj(c))); });
    EXPECT_CONTAINS(obj, "range.obj");
    EXPECT_CONTAINS(obj, fmt::format("face on line {}: vertex index 9 is out of range: "
                                     "expected 1..8 or -8..-1",
                                     obj_face_line(c, 5)));
    const std::string ply =
        input_error_message([&] { read_mesh(write("range.ply", to_ascii_ply(c))); });
    EXPECT_CONTAINS(ply, fmt::format("face 5 (line {}): vertex index 8 is out of range: "
                                     "expected 0..7",
                                     ply_face_line(c, 5)));
    EXPECT_CONTAINS(
        input_error_message([&] { read_mesh(write("range_bin.ply", to_binary_ply(c))); }),
        "face 5: vertex index 8 is out of range");
    EXPECT_CONTAINS(input_error_message([&] {
                        read_mesh(write("zero.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n"));
                    }),
                    "face on line 4: vertex index 0 is out of range");
    EXPECT_CONTAINS(input_error_message([&] {
                        read_mesh(write("vt.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1 2/1 3/1\n"));
                    }),
                    "texture coordinate index 1 is out of range");
}

TEST_F(MeshImport, RejectsMalformedNumbers) {
    EXPECT_CONTAINS(input_error_message([&] {
                        read_mesh(write("bad.obj", "v 0 0 0\nv 1.0abc 0 0\nv 0 1 0\nf 1 2 3\n"));
                    }),
                    "line 2: '1.0abc' is not a number");
    MeshData c = cube(1.0);
    std::string text = to_ascii_ply(c);
    text.replace(text.find("end_header\n") + 11, 1, "0..0");  // vertex 0's x
    EXPECT_CONTAINS(input_error_message([&] { read_mesh(write("bad.ply", text)); }),
                    "vertex 0 (line 10): '0..0' is not a valid float: expected property 'x'");
    EXPECT_CONTAINS(input_error_message([&] {
                        read_mesh(write("short.obj", "v 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"));
                    }),
                    "line 1: 'v' with 2 values: expected x y z");
}

TEST_F(MeshImport, RejectsNonConvexAndNonPlanarPolygons) {
    // An L-shaped hexagon: reflex at (1, 1).
    EXPECT_CONTAINS(
        input_error_message([&] {
            read_mesh(
                write("l_shape.obj",
                      "v 0 0 0\nv 2 0 0\nv 2 1 0\nv 1 1 0\nv 1 2 0\nv 0 2 0\nf 1 2 3 4 5 6\n"),
                {.require_closed = false});
        }),
        "face on line 7: polygon of 6 vertices is not convex (reflex corner at vertex 4 "
        "(line 4))");
    EXPECT_CONTAINS(input_error_message([&] {
                        read_mesh(
                            write("warped.ply",
                                  "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\n"
                                  "property float y\nproperty float z\nelement face 1\n"
                                  "property list uchar int vertex_index\nend_header\n"
                                  "0 0 0\n1 0 0\n1 1 0.5\n0 1 0\n4 0 1 2 3\n"),
                            {.require_closed = false});
                    }),
                    "face 0 (line 14): polygon of 4 vertices is not planar");
}

TEST_F(MeshImport, CheckMeshReportsWithoutChanging) {
    TriangleMesh mesh;
    const MeshData c = cube(1.0);
    mesh.positions = c.positions;
    for (const auto& f : c.faces) mesh.triangles.push_back({f[0], f[2], f[1]});  // inside-out
    const MeshReport inside_out = check_mesh(mesh);
    EXPECT_EQ(inside_out.count(MeshDefectKind::inward_orientation), 1u);
    ASSERT_FALSE(inside_out.defects.empty());
    EXPECT_FALSE(inside_out.defects.front().repaired);
    EXPECT_CONTAINS(inside_out.defects.front().message, "triangle 0");

    mesh.triangles.pop_back();
    const MeshReport open = check_mesh(mesh);
    EXPECT_EQ(open.count(MeshDefectKind::border_edge), 3u);
    EXPECT_FALSE(open.closed);
    EXPECT_TRUE(check_mesh(mesh, /*require_closed=*/false).clean());
}

}  // namespace
}  // namespace plumage::geometry
