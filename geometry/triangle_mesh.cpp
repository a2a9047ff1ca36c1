#include "geometry/triangle_mesh.h"

#include <unistd.h>

#include <fstream>
#include <limits>

#include <fmt/format.h>

#include "common/error.h"

namespace plumage::geometry {

std::size_t TriangleMesh::memory_bytes() const {
    return sizeof(*this) + positions.capacity() * sizeof(Vec3) +
           shading_normals.capacity() * sizeof(Vec3) + triangles.capacity() * sizeof(Triangle);
}

Vec3 TriangleMesh::face_normal(std::size_t i) const {
    const Triangle& t = triangles[i];
    return (positions[t[1]] - positions[t[0]])
        .cross(positions[t[2]] - positions[t[0]])
        .normalized();
}

double TriangleMesh::face_area(std::size_t i) const {
    const Triangle& t = triangles[i];
    return 0.5 *
           (positions[t[1]] - positions[t[0]]).cross(positions[t[2]] - positions[t[0]]).norm();
}

double TriangleMesh::surface_area() const {
    double area = 0.0;
    for (std::size_t i = 0; i < triangles.size(); ++i) area += face_area(i);
    return area;
}

std::array<Vec3, 2> TriangleMesh::bounds() const {
    Vec3 lo = Vec3::Constant(std::numeric_limits<double>::infinity());
    Vec3 hi = -lo;
    for (const Vec3& p : positions) {
        lo = lo.cwiseMin(p);
        hi = hi.cwiseMax(p);
    }
    return {lo, hi};
}

void TriangleMesh::append(const TriangleMesh& other) {
    const auto offset = static_cast<std::uint32_t>(positions.size());
    PLUMAGE_CHECK(shading_normals.size() == positions.size() ||
                      (shading_normals.empty() && positions.empty()) ||
                      (shading_normals.empty() && other.shading_normals.empty()),
                  "appending meshes with and without shading normals");
    positions.insert(positions.end(), other.positions.begin(), other.positions.end());
    shading_normals.insert(shading_normals.end(), other.shading_normals.begin(),
                           other.shading_normals.end());
    for (const Triangle& t : other.triangles) {
        triangles.push_back({t[0] + offset, t[1] + offset, t[2] + offset});
    }
}

void write_ply(const TriangleMesh& mesh, const std::filesystem::path& path) {
    const bool normals = !mesh.shading_normals.empty();
    std::filesystem::path temporary = path;
    temporary += fmt::format(".partial-{}", ::getpid());
    {
        std::ofstream out(temporary, std::ios::binary);
        if (!out) throw IoError(fmt::format("cannot create '{}'", temporary.string()));
        out << "ply\nformat binary_little_endian 1.0\ncomment plumage: lengths in micrometres\n"
            << "element vertex " << mesh.positions.size() << "\n"
            << "property double x\nproperty double y\nproperty double z\n";
        if (normals) out << "property double nx\nproperty double ny\nproperty double nz\n";
        out << "element face " << mesh.triangles.size() << "\n"
            << "property list uchar uint vertex_indices\nend_header\n";
        for (std::size_t i = 0; i < mesh.positions.size(); ++i) {
            out.write(reinterpret_cast<const char*>(mesh.positions[i].data()), 3 * sizeof(double));
            if (normals) {
                out.write(reinterpret_cast<const char*>(mesh.shading_normals[i].data()),
                          3 * sizeof(double));
            }
        }
        for (const Triangle& t : mesh.triangles) {
            const std::uint8_t three = 3;
            out.write(reinterpret_cast<const char*>(&three), 1);
            out.write(reinterpret_cast<const char*>(t.data()), 3 * sizeof(std::uint32_t));
        }
        if (!out) throw IoError(fmt::format("cannot write '{}'", temporary.string()));
    }
    std::error_code error;
    std::filesystem::rename(temporary, path, error);
    if (error) {
        std::filesystem::remove(temporary, error);
        throw IoError(fmt::format("cannot rename PLY into place: '{}'", path.string()));
    }
}

}  // namespace plumage::geometry

namespace plumage::geometry {

std::vector<Segment3> slice(const TriangleMesh& mesh, int axis, double value) {
    std::vector<Segment3> segments;
    for (const Triangle& t : mesh.triangles) {
        Vec3 crossings[3];
        int count = 0;
        for (int e = 0; e < 3 && count < 2; ++e) {
            const Vec3& p = mesh.positions[t[e]];
            const Vec3& q = mesh.positions[t[(e + 1) % 3]];
            const double dp = p[axis] - value, dq = q[axis] - value;
            if ((dp < 0.0) != (dq < 0.0)) crossings[count++] = p + (q - p) * (dp / (dp - dq));
        }
        if (count == 2) segments.push_back({crossings[0], crossings[1]});
    }
    return segments;
}

}  // namespace plumage::geometry
