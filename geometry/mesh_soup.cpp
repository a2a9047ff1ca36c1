// The polygon soup that the readers fill: naming, text helpers, finite checks and polygon
// triangulation (mesh_import_detail.h).
#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <string>

#include <fmt/format.h>

#include "common/error.h"
#include "geometry/mesh_import_detail.h"

namespace plumage::geometry::mesh_import_detail {
namespace {

bool is_blank(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; }

}  // namespace

// ---------------------------------------------------------------------------------------
// Text helpers.

void split_words(std::string_view line, std::vector<std::string_view>& words) {
    words.clear();
    std::size_t i = 0;
    while (i < line.size()) {
        while (i < line.size() && is_blank(line[i])) ++i;
        const std::size_t start = i;
        while (i < line.size() && !is_blank(line[i])) ++i;
        if (i > start) words.push_back(line.substr(start, i - start));
    }
}

// Bytes shown in a message: printable ASCII as is, the rest as \xNN (a PNG signature
// must not put control characters on a terminal).
std::string printable(std::string_view bytes, std::size_t max) {
    std::string out;
    for (std::size_t i = 0; i < std::min(bytes.size(), max); ++i) {
        const auto c = static_cast<unsigned char>(bytes[i]);
        if (c >= 0x20 && c < 0x7f) {
            out += static_cast<char>(c);
        } else {
            out += fmt::format("\\x{:02x}", c);
        }
    }
    if (bytes.size() > max) out += "...";
    return out;
}

// A decimal number, the whole token; nullopt if malformed. "nan" and "inf" parse (the
// caller names the vertex that has one); magnitudes beyond double become ±inf.
std::optional<double> parse_double(std::string_view token) {
    if (!token.empty() && token.front() == '+') token.remove_prefix(1);
    if (token.empty() || token.front() == '+') return std::nullopt;
    double value = 0.0;
    const auto [end, error] = std::from_chars(token.data(), token.data() + token.size(), value);
    if (end != token.data() + token.size()) return std::nullopt;
    if (error == std::errc::result_out_of_range) {
        // from_chars leaves the value unset for both overflow and underflow; strtod tells
        // them apart (±HUGE_VAL or a denormal/zero).
        const std::string copy(token);
        return std::strtod(copy.c_str(), nullptr);
    }
    if (error != std::errc()) return std::nullopt;
    return value;
}

std::optional<long long> parse_integer(std::string_view token) {
    if (!token.empty() && token.front() == '+') token.remove_prefix(1);
    if (token.empty() || token.front() == '+') return std::nullopt;
    long long value = 0;
    const auto [end, error] = std::from_chars(token.data(), token.data() + token.size(), value);
    if (error != std::errc() || end != token.data() + token.size()) return std::nullopt;
    return value;
}

std::string format_vec(const Vec3& v) { return fmt::format("({}, {}, {})", v.x(), v.y(), v.z()); }

// Throws unless the scaled position is finite; names the vertex and the raw values.
Vec3 checked_position(const Vec3& raw, double scale, const Names& names, std::size_t ordinal,
                      std::size_t line) {
    static constexpr const char* kAxis[] = {"x", "y", "z"};
    for (int i = 0; i < 3; ++i) {
        if (!std::isfinite(raw[i])) {
            throw InputError(fmt::format("{}: {} has {} = {}: expected finite coordinates",
                                         names.file(), names.vertex(ordinal, line), kAxis[i],
                                         raw[i]));
        }
    }
    const Vec3 scaled = raw * scale;
    if (!scaled.allFinite()) {
        throw InputError(fmt::format(
            "{}: {} at {} times scale_to_um = {} overflows: expected coordinates below {:g} µm",
            names.file(), names.vertex(ordinal, line), format_vec(raw), scale,
            std::numeric_limits<double>::max()));
    }
    return scaled;
}

// Throws unless the normal is finite and non-zero; returns it normalised.
Vec3 checked_normal(const Vec3& raw, const Names& names, const std::string& owner) {
    if (!raw.allFinite() || raw.squaredNorm() == 0.0) {
        throw InputError(
            fmt::format("{}: {} has shading normal {}: expected a finite non-zero "
                        "normal (or no normals at all)",
                        names.file(), owner, format_vec(raw)));
    }
    return raw.normalized();
}

// ---------------------------------------------------------------------------------------
// Polygons: a triangle fan, when that is the polygon's surface.

void add_polygon(Soup& soup, const std::vector<std::uint32_t>& ids, std::size_t ordinal,
                 std::size_t line, const Names& names) {
    ++soup.faces_read;
    // Consecutive repeats (some exporters close polygons explicitly) carry no area.
    std::vector<std::uint32_t> ring;
    for (const std::uint32_t id : ids) {
        if (ring.empty() || ring.back() != id) ring.push_back(id);
    }
    while (ring.size() > 1 && ring.front() == ring.back()) ring.pop_back();
    if (ring.size() < 3) {
        // Keep it as one degenerate triangle, so the degenerate-face check reports it.
        soup.add_triangle(ids[0], ids[1], ids[2], ordinal, line);
        return;
    }
    if (ring.size() == 3) {
        soup.add_triangle(ring[0], ring[1], ring[2], ordinal, line);
        return;
    }
    const std::size_t k = ring.size();
    auto at = [&](std::size_t i) -> const Vec3& { return soup.positions[ring[i % k]]; };

    Vec3 centroid = Vec3::Zero();
    Vec3 lo = at(0), hi = at(0);
    for (std::size_t i = 0; i < k; ++i) {
        centroid += at(i);
        lo = lo.cwiseMin(at(i));
        hi = hi.cwiseMax(at(i));
    }
    centroid /= static_cast<double>(k);
    // Newell's normal (twice the vector area), taken about the centroid for round-off.
    Vec3 normal = Vec3::Zero();
    for (std::size_t i = 0; i < k; ++i) normal += (at(i) - centroid).cross(at(i + 1) - centroid);
    const std::string face = names.face(ordinal, line);
    if (normal.squaredNorm() > 0.0) {
        normal.normalize();
        const double size = (hi - lo).norm();
        for (std::size_t i = 0; i < k; ++i) {
            const double distance = std::abs((at(i) - centroid).dot(normal));
            if (distance > kPolygonPlanarity * size) {
                throw InputError(fmt::format(
                    "{}: {}: polygon of {} vertices is not planar: {} lies {:g} µm from the "
                    "polygon's plane, more than {:g} of its {:g} µm size: expected a planar "
                    "convex polygon (or triangulate it in the modelling tool)",
                    names.file(), face, k, soup.vertex_name(names, ring[i]), distance,
                    kPolygonPlanarity, size));
            }
        }
        for (std::size_t i = 0; i < k; ++i) {
            const Vec3 in = at(i + k) - at(i + k - 1);
            const Vec3 out = at(i + 1) - at(i);
            // A relative tolerance: collinear corners written in float turn by ~1e-7.
            if (in.cross(out).dot(normal) < -1e-6 * in.norm() * out.norm()) {
                throw InputError(fmt::format(
                    "{}: {}: polygon of {} vertices is not convex (reflex corner at {}): "
                    "expected a convex polygon (or triangulate it in the modelling tool)",
                    names.file(), face, k, soup.vertex_name(names, ring[i])));
            }
        }
    }
    // A fan from an apex that lies on a line with two other vertices has a zero-area
    // triangle, whose removal would open the mesh: pick an apex whose fan has none.
    for (std::size_t apex = 0; apex < k; ++apex) {
        bool clean = true;
        for (std::size_t j = 1; j + 1 < k && clean; ++j) {
            clean = !collinear(soup, ring[apex], ring[(apex + j) % k], ring[(apex + j + 1) % k]);
        }
        if (clean || normal.squaredNorm() == 0.0) {
            // (An all-collinear polygon has no clean fan; its triangles go on to the
            // degenerate-face check, which names the face.)
            for (std::size_t j = 1; j + 1 < k; ++j) {
                soup.add_triangle(ring[apex], ring[(apex + j) % k], ring[(apex + j + 1) % k],
                                  ordinal, line);
            }
            return;
        }
    }
    throw InputError(fmt::format(
        "{}: {}: polygon of {} vertices has collinear vertices that every triangle fan turns "
        "into zero-area triangles: expected triangles (triangulate it in the modelling tool)",
        names.file(), face, k));
}

}  // namespace plumage::geometry::mesh_import_detail
