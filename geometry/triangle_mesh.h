// Indexed triangle meshes: the common currency of geometry/ (generators, importers,
// volume meshing) and of the tracer's Embree scene.
//
// Conventions:
//  - Lengths in micrometres, double precision here (features of 1e-4 µm inside 1e3 µm
//    scenes need it); the tracer converts to float per instance, in local coordinates.
//  - Triangles wind counter-clockwise seen from outside: the geometric normal
//    (b − a) × (c − a) points out of the object (into the medium the light comes from).
//  - shading_normals is empty, or holds one unit normal per vertex taken from the
//    analytic surface the mesh approximates (interpolated by the tracer).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace plumage::geometry {

using Vec3 = Eigen::Vector3d;
using Triangle = std::array<std::uint32_t, 3>;

struct TriangleMesh {
    std::vector<Vec3> positions;
    std::vector<Vec3> shading_normals;  // empty or positions.size()
    std::vector<Triangle> triangles;

    std::size_t memory_bytes() const;
    // Unit geometric normal and area of triangle i.
    Vec3 face_normal(std::size_t i) const;
    double face_area(std::size_t i) const;
    double surface_area() const;
    // Axis-aligned bounds: {min, max}.
    std::array<Vec3, 2> bounds() const;
    // Appends other's vertices and triangles (indices offset).
    void append(const TriangleMesh& other);
};

// Binary little-endian PLY (x y z [nx ny nz] as float64, faces as uint32 lists),
// written to a temporary name and renamed. IoError on failure.
void write_ply(const TriangleMesh& mesh, const std::filesystem::path& path);

}  // namespace plumage::geometry

namespace plumage::geometry {

// Cut of a mesh with the plane {p : p[axis] = value}: one segment per crossed triangle,
// for cross-section previews.
struct Segment3 {
    Vec3 a, b;
};
std::vector<Segment3> slice(const TriangleMesh& mesh, int axis, double value);

}  // namespace plumage::geometry
