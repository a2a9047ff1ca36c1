// Meshes and statistics shared by the tracer tests (tests/sim/).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <map>
#include <utility>
#include <vector>

#include "geometry/triangle_mesh.h"

namespace plumage::testing {

using geometry::TriangleMesh;
using geometry::Vec3;

// Flat square [−h, h]² at height z, normal +z (counter-clockwise seen from above).
inline TriangleMesh square_mesh(double half_size, double z = 0.0) {
    TriangleMesh m;
    m.positions = {{-half_size, -half_size, z},
                   {half_size, -half_size, z},
                   {half_size, half_size, z},
                   {-half_size, half_size, z}};
    m.triangles = {{0, 1, 2}, {0, 2, 3}};
    return m;
}

// Closed axis-aligned box, outward winding.
inline TriangleMesh box_mesh(const Vec3& lo, const Vec3& hi) {
    TriangleMesh m;
    for (int i = 0; i < 8; ++i) {
        m.positions.emplace_back((i & 1) ? hi.x() : lo.x(), (i & 2) ? hi.y() : lo.y(),
                                 (i & 4) ? hi.z() : lo.z());
    }
    const std::array<std::array<std::uint32_t, 4>, 6> faces = {
        {{0, 2, 6, 4}, {1, 5, 7, 3}, {0, 4, 5, 1}, {2, 3, 7, 6}, {0, 1, 3, 2}, {4, 6, 7, 5}}};
    const Vec3 centre = 0.5 * (lo + hi);
    for (const auto& f : faces) {
        for (geometry::Triangle t :
             {geometry::Triangle{f[0], f[1], f[2]}, geometry::Triangle{f[0], f[2], f[3]}}) {
            const Vec3 a = m.positions[t[0]], b = m.positions[t[1]], c = m.positions[t[2]];
            if ((b - a).cross(c - a).dot((a + b + c) / 3.0 - centre) < 0.0) std::swap(t[1], t[2]);
            m.triangles.push_back(t);
        }
    }
    return m;
}

// Sphere by subdividing an octahedron, vertices on the sphere, analytic shading normals,
// outward winding. 8·4^levels triangles.
inline TriangleMesh sphere_mesh(double radius, int levels, const Vec3& centre = Vec3::Zero()) {
    std::vector<Vec3> unit = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
    std::vector<geometry::Triangle> tris = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4},
                                            {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
    for (int level = 0; level < levels; ++level) {
        std::map<std::pair<std::uint32_t, std::uint32_t>, std::uint32_t> midpoints;
        auto midpoint = [&](std::uint32_t a, std::uint32_t b) {
            const auto key = std::minmax(a, b);
            auto it = midpoints.find(key);
            if (it != midpoints.end()) return it->second;
            unit.push_back((unit[a] + unit[b]).normalized());
            const auto index = static_cast<std::uint32_t>(unit.size() - 1);
            midpoints.emplace(key, index);
            return index;
        };
        std::vector<geometry::Triangle> next;
        for (const auto& t : tris) {
            const std::uint32_t ab = midpoint(t[0], t[1]), bc = midpoint(t[1], t[2]),
                                ca = midpoint(t[2], t[0]);
            next.insert(next.end(), {{t[0], ab, ca}, {ab, t[1], bc}, {ca, bc, t[2]}, {ab, bc, ca}});
        }
        tris = std::move(next);
    }
    TriangleMesh m;
    for (const Vec3& u : unit) {
        m.positions.push_back(centre + radius * u);
        m.shading_normals.push_back(u);
    }
    for (geometry::Triangle t : tris) {
        const Vec3 a = unit[t[0]], b = unit[t[1]], c = unit[t[2]];
        if ((b - a).cross(c - a).dot(a + b + c) < 0.0) std::swap(t[1], t[2]);
        m.triangles.push_back(t);
    }
    return m;
}

// Standard deviation of a binomial proportion estimate.
inline double binomial_sigma(double p, std::size_t n) {
    return std::sqrt(std::max(p * (1.0 - p), 0.0) / static_cast<double>(n));
}

}  // namespace plumage::testing
