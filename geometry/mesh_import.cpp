#include "geometry/mesh_import.h"

#include <algorithm>
#include <bit>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <limits>
#include <numeric>
#include <optional>
#include <set>
#include <string_view>
#include <tuple>
#include <utility>

// CGAL stays in this file: its headers cost seconds per translation unit.
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/orientation.h>
#include <CGAL/Polygon_mesh_processing/polygon_soup_to_polygon_mesh.h>
#include <CGAL/Polygon_mesh_processing/self_intersections.h>
#include <CGAL/Surface_mesh.h>
#include <fmt/format.h>

#include "common/error.h"

namespace plumage::geometry {
namespace {

namespace PMP = CGAL::Polygon_mesh_processing;
// Exact predicates: "collinear" and "these triangles cross" must not depend on round-off.
using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;
using SurfaceMesh = CGAL::Surface_mesh<Point>;

// Binary PLY is read by copying bytes into host scalars.
static_assert(std::endian::native == std::endian::little,
              "binary_little_endian PLY reading assumes a little-endian host");

static_assert(static_cast<std::size_t>(MeshDefectKind::shading_normals_dropped) + 1 ==
                  kMeshDefectKinds,
              "kMeshDefectKinds counts MeshDefectKind");

constexpr std::size_t kMaxVertices = std::numeric_limits<std::uint32_t>::max();
// Defects named in a rejection message; the report lists more.
constexpr std::size_t kMaxNamedInMessage = 8;

// ---------------------------------------------------------------------------------------
// Naming vertices and faces the way the user will look for them in the file.

enum class Source { obj, ply, memory };

class Names final {
public:
    Names(Source source, std::string file) : source_(source), file_(std::move(file)) {}

    // OBJ vertices by the 1-based index that face statements use; PLY by element index.
    std::string vertex(std::size_t ordinal, std::size_t line) const {
        if (source_ == Source::obj) return fmt::format("vertex {} (line {})", ordinal + 1, line);
        if (line != 0) return fmt::format("vertex {} (line {})", ordinal, line);
        return fmt::format("vertex {}", ordinal);
    }
    std::string face(std::size_t ordinal, std::size_t line) const {
        if (source_ == Source::obj) return fmt::format("face on line {}", line);
        if (source_ == Source::memory) return fmt::format("triangle {}", ordinal);
        if (line != 0) return fmt::format("face {} (line {})", ordinal, line);
        return fmt::format("face {}", ordinal);
    }
    // Prefix of every InputError: the file, quoted.
    const std::string& file() const { return file_; }

private:
    Source source_;
    std::string file_;
};

// A triangle soup plus where each vertex and triangle came from, for messages. Triangles
// of one fan-triangulated polygon share their face ordinal and line.
struct Soup {
    std::vector<Vec3> positions;
    std::vector<Vec3> normals;  // empty or one per position
    std::vector<std::size_t> vertex_ordinal;
    std::vector<std::size_t> vertex_line;
    std::vector<Triangle> triangles;
    std::vector<std::size_t> face_ordinal;
    std::vector<std::size_t> face_line;
    std::size_t faces_read = 0;

    void add_triangle(std::uint32_t a, std::uint32_t b, std::uint32_t c, std::size_t ordinal,
                      std::size_t line) {
        triangles.push_back({a, b, c});
        face_ordinal.push_back(ordinal);
        face_line.push_back(line);
    }
    std::string vertex_name(const Names& names, std::uint32_t v) const {
        return names.vertex(vertex_ordinal[v], vertex_line[v]);
    }
    std::string face_name(const Names& names, std::size_t t) const {
        return names.face(face_ordinal[t], face_line[t]);
    }
    Point point(std::uint32_t v) const {
        const Vec3& p = positions[v];
        return Point(p.x(), p.y(), p.z());
    }
};

// ---------------------------------------------------------------------------------------
// Text helpers.

bool is_blank(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; }

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

// Lines of a text, numbered from 1, without their "\n" or "\r\n".
class LineReader final {
public:
    explicit LineReader(std::string_view text, std::size_t first_line = 1)
        : text_(text), next_line_(first_line) {}

    bool next(std::string_view& line) {
        if (pos_ >= text_.size()) return false;
        const std::size_t end = std::min(text_.find('\n', pos_), text_.size());
        line = text_.substr(pos_, end - pos_);
        if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
        pos_ = end + 1;
        number_ = next_line_++;
        return true;
    }
    std::size_t number() const { return number_; }
    std::size_t offset() const { return std::min(pos_, text_.size()); }

private:
    std::string_view text_;
    std::size_t pos_ = 0;
    std::size_t next_line_;
    std::size_t number_ = 0;
};

// Bytes shown in a message: printable ASCII as is, the rest as \xNN (a PNG signature
// must not put control characters on a terminal).
std::string printable(std::string_view bytes, std::size_t max = 24) {
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
            clean = !CGAL::collinear(soup.point(ring[apex]), soup.point(ring[(apex + j) % k]),
                                     soup.point(ring[(apex + j + 1) % k]));
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

// ---------------------------------------------------------------------------------------
// OBJ.

// Per-corner OBJ normals become per-vertex shading normals only when every corner of every
// face names one, and a vertex always gets the same vector.
struct ObjNormals {
    std::vector<Vec3> values;                 // vn statements
    std::vector<std::size_t> lines;           // their lines
    std::vector<std::int64_t> vertex_normal;  // per vertex: vn index, -1 none yet
    bool corner_with = false;
    bool corner_without = false;
    std::optional<std::string> dropped_because;  // first reason to drop, naming the place
};

Soup parse_obj(std::string_view text, double scale, const Names& names, ObjNormals& normals) {
    // OBJ has no magic number: binary bytes early on mean it is some other file.
    const std::string_view head = text.substr(0, 4096);
    if (head.find('\0') != std::string_view::npos) {
        throw InputError(
            fmt::format("{}: binary data (starts with \"{}\"): expected a text OBJ "
                        "file",
                        names.file(), printable(text.substr(0, 16))));
    }
    Soup soup;
    std::size_t texture_coordinates = 0;
    std::size_t faces = 0;
    LineReader lines(text);
    std::string_view line;
    std::vector<std::string_view> words;
    std::vector<std::uint32_t> polygon;
    std::vector<std::int64_t> corner_normals;
    while (lines.next(line)) {
        const std::size_t n = lines.number();
        if (const std::size_t hash = line.find('#'); hash != std::string_view::npos) {
            line = line.substr(0, hash);
        }
        split_words(line, words);
        if (words.empty()) continue;
        const std::string_view keyword = words[0];
        auto numbers = [&](std::size_t first, std::size_t count, const char* expected) {
            Vec3 v = Vec3::Zero();
            for (std::size_t i = 0; i < count; ++i) {
                const auto value = parse_double(words[first + i]);
                if (!value) {
                    throw InputError(fmt::format("{}: line {}: '{}' is not a number: expected {}",
                                                 names.file(), n, printable(words[first + i]),
                                                 expected));
                }
                if (i < 3) v[static_cast<Eigen::Index>(i)] = *value;
            }
            return v;
        };
        if (keyword == "v") {
            // x y z, optionally a weight w (for rational curves; meaningless on a
            // polygon) or r g b (a vertex colour): both ignored.
            const std::size_t count = words.size() - 1;
            if (count != 3 && count != 4 && count != 6) {
                throw InputError(fmt::format(
                    "{}: line {}: 'v' with {} values: expected x y z (then optionally w, or r g b)",
                    names.file(), n, count));
            }
            const Vec3 raw = numbers(1, count, "vertex coordinates 'v x y z'");
            const std::size_t ordinal = soup.positions.size();
            if (ordinal >= kMaxVertices) {
                throw InputError(fmt::format("{}: line {}: more than {} vertices: expected fewer",
                                             names.file(), n, kMaxVertices));
            }
            soup.positions.push_back(checked_position(raw, scale, names, ordinal, n));
            soup.vertex_ordinal.push_back(ordinal);
            soup.vertex_line.push_back(n);
        } else if (keyword == "vn") {
            if (words.size() != 4) {
                throw InputError(fmt::format("{}: line {}: 'vn' with {} values: expected nx ny nz",
                                             names.file(), n, words.size() - 1));
            }
            const Vec3 raw = numbers(1, 3, "a normal 'vn nx ny nz'");
            if (!raw.allFinite()) {
                throw InputError(fmt::format("{}: line {}: normal {}: expected finite numbers",
                                             names.file(), n, format_vec(raw)));
            }
            normals.values.push_back(raw);
            normals.lines.push_back(n);
        } else if (keyword == "vt") {
            ++texture_coordinates;
        } else if (keyword == "f") {
            if (words.size() < 4) {
                throw InputError(
                    fmt::format("{}: face on line {} has {} vertices: expected at least 3",
                                names.file(), n, words.size() - 1));
            }
            polygon.clear();
            corner_normals.clear();
            for (std::size_t c = 1; c < words.size(); ++c) {
                // v, v/vt, v//vn or v/vt/vn.
                std::string_view parts[3];
                std::size_t part_count = 0;
                bool too_many_parts = false;
                for (std::string_view rest = words[c];;) {
                    if (part_count == 3) {
                        too_many_parts = true;
                        break;
                    }
                    const std::size_t slash = rest.find('/');
                    parts[part_count++] = rest.substr(0, slash);
                    if (slash == std::string_view::npos) break;
                    rest.remove_prefix(slash + 1);
                }
                auto index = [&](std::string_view token, std::size_t available,
                                 const char* what) -> std::int64_t {
                    const auto value = parse_integer(token);
                    if (!value) {
                        throw InputError(fmt::format(
                            "{}: face on line {}: '{}' is not an index: expected v, v/vt, v//vn "
                            "or v/vt/vn with integer indices",
                            names.file(), n, printable(words[c])));
                    }
                    const auto count = static_cast<long long>(available);
                    // Negative indices count back from the last one read before this line.
                    const long long resolved = *value > 0 ? *value - 1 : count + *value;
                    if (count == 0) {
                        throw InputError(fmt::format(
                            "{}: face on line {}: {} index {} is out of range: none is defined "
                            "before this line",
                            names.file(), n, what, *value));
                    }
                    if (*value == 0 || resolved < 0 || resolved >= count) {
                        throw InputError(fmt::format(
                            "{}: face on line {}: {} index {} is out of range: expected 1..{} or "
                            "-{}..-1 ({} defined before this line)",
                            names.file(), n, what, *value, count, count, count));
                    }
                    return resolved;
                };
                if (too_many_parts || parts[0].empty()) {
                    throw InputError(
                        fmt::format("{}: face on line {}: '{}': expected v, v/vt, v//vn or v/vt/vn",
                                    names.file(), n, printable(words[c])));
                }
                polygon.push_back(
                    static_cast<std::uint32_t>(index(parts[0], soup.positions.size(), "vertex")));
                // Texture coordinates are not used, but a dangling one means a corrupt file.
                if (part_count >= 2 && !parts[1].empty()) {
                    index(parts[1], texture_coordinates, "texture coordinate");
                }
                corner_normals.push_back(part_count == 3 && !parts[2].empty()
                                             ? index(parts[2], normals.values.size(), "normal")
                                             : -1);
            }
            normals.vertex_normal.resize(soup.positions.size(), -1);
            for (std::size_t c = 0; c < polygon.size() && !normals.dropped_because; ++c) {
                const std::uint32_t v = polygon[c];
                const std::int64_t vn = corner_normals[c];
                (vn >= 0 ? normals.corner_with : normals.corner_without) = true;
                if (normals.corner_with && normals.corner_without) {
                    normals.dropped_because = fmt::format(
                        "some face corners have normals and others not (face on line {})", n);
                    break;
                }
                if (vn < 0) continue;
                std::int64_t& assigned = normals.vertex_normal[v];
                const Vec3& value = normals.values[static_cast<std::size_t>(vn)];
                if (assigned >= 0 && assigned != vn &&
                    (normals.values[static_cast<std::size_t>(assigned)] - value).norm() >
                        1e-6 * value.norm()) {
                    normals.dropped_because = fmt::format(
                        "{} has different normals on different faces (line {}): a crease, "
                        "which per-vertex shading normals cannot hold",
                        names.vertex(v, soup.vertex_line[v]), n);
                    break;
                }
                assigned = vn;
            }
            add_polygon(soup, polygon, faces, n, names);
            ++faces;
        } else if (keyword == "vp" || keyword == "usemtl" || keyword == "mtllib" ||
                   keyword == "o" || keyword == "g" || keyword == "s") {
            // Parameter-space vertices, materials, object/group names and smoothing groups
            // do not change the surface.
        } else {
            throw InputError(fmt::format(
                "{}: line {}: unsupported OBJ statement '{}': expected v, vn or f (vt, vp, "
                "usemtl, mtllib, o, g and s are ignored)",
                names.file(), n, printable(keyword)));
        }
    }
    if (soup.positions.empty()) {
        throw InputError(
            fmt::format("{}: no vertices ('v' lines): expected an OBJ mesh", names.file()));
    }
    if (faces == 0) {
        throw InputError(fmt::format(
            "{}: no faces ('f' lines): expected a surface mesh, not a point cloud", names.file()));
    }
    if (normals.corner_with && !normals.dropped_because) {
        soup.normals.assign(soup.positions.size(), Vec3::UnitZ());
        normals.vertex_normal.resize(soup.positions.size(), -1);
        for (std::size_t v = 0; v < soup.positions.size(); ++v) {
            // Vertices in no face get none; they are isolated and removed (or, with repair
            // off, keep +z: no triangle interpolates it).
            const std::int64_t vn = normals.vertex_normal[v];
            if (vn < 0) continue;
            const auto i = static_cast<std::size_t>(vn);
            soup.normals[v] =
                checked_normal(normals.values[i], names,
                               fmt::format("{} (normal on line {})",
                                           names.vertex(v, soup.vertex_line[v]), normals.lines[i]));
        }
    }
    return soup;
}

// ---------------------------------------------------------------------------------------
// PLY.

enum class PlyType { int8, uint8, int16, uint16, int32, uint32, float32, float64 };

std::optional<PlyType> ply_type(std::string_view name) {
    if (name == "char" || name == "int8") return PlyType::int8;
    if (name == "uchar" || name == "uint8") return PlyType::uint8;
    if (name == "short" || name == "int16") return PlyType::int16;
    if (name == "ushort" || name == "uint16") return PlyType::uint16;
    if (name == "int" || name == "int32") return PlyType::int32;
    if (name == "uint" || name == "uint32") return PlyType::uint32;
    if (name == "float" || name == "float32") return PlyType::float32;
    if (name == "double" || name == "float64") return PlyType::float64;
    return std::nullopt;
}

const char* ply_type_name(PlyType type) {
    switch (type) {
        case PlyType::int8:
            return "char";
        case PlyType::uint8:
            return "uchar";
        case PlyType::int16:
            return "short";
        case PlyType::uint16:
            return "ushort";
        case PlyType::int32:
            return "int";
        case PlyType::uint32:
            return "uint";
        case PlyType::float32:
            return "float";
        case PlyType::float64:
            return "double";
    }
    return "?";
}

std::size_t ply_size(PlyType type) {
    switch (type) {
        case PlyType::int8:
        case PlyType::uint8:
            return 1;
        case PlyType::int16:
        case PlyType::uint16:
            return 2;
        case PlyType::int32:
        case PlyType::uint32:
        case PlyType::float32:
            return 4;
        case PlyType::float64:
            return 8;
    }
    return 0;
}

bool ply_is_float(PlyType type) { return type == PlyType::float32 || type == PlyType::float64; }

struct PlyProperty {
    std::string name;
    PlyType type = PlyType::float32;  // the item type, for lists
    bool is_list = false;
    PlyType count_type = PlyType::uint8;
};

struct PlyElement {
    std::string name;
    std::size_t count = 0;
    std::size_t header_line = 0;
    std::vector<PlyProperty> properties;
};

struct PlyHeader {
    bool binary = false;
    std::vector<PlyElement> elements;
    std::size_t body_offset = 0;
    std::size_t body_first_line = 0;
};

PlyHeader parse_ply_header(std::string_view bytes, const Names& names) {
    LineReader lines(bytes);
    std::string_view line;
    if (!lines.next(line) || line != "ply") {
        throw InputError(
            fmt::format("{}: starts with \"{}\": expected a PLY file, whose first "
                        "line is 'ply'",
                        names.file(), printable(bytes.substr(0, 16))));
    }
    PlyHeader header;
    bool have_format = false;
    std::vector<std::string_view> words;
    while (true) {
        if (!lines.next(line)) {
            throw InputError(
                fmt::format("{}: the PLY header has no 'end_header' line: expected "
                            "one before the data",
                            names.file()));
        }
        const std::size_t n = lines.number();
        split_words(line, words);
        if (words.empty()) continue;
        const std::string_view keyword = words[0];
        if (keyword == "end_header") break;
        if (keyword == "comment" || keyword == "obj_info") continue;
        if (keyword == "format") {
            if (words.size() != 3 || words[2] != "1.0" ||
                (words[1] != "ascii" && words[1] != "binary_little_endian")) {
                throw InputError(
                    fmt::format("{}: line {}: '{}': expected 'format ascii 1.0' or 'format "
                                "binary_little_endian 1.0'",
                                names.file(), n, printable(line, 60)));
            }
            header.binary = words[1] == "binary_little_endian";
            have_format = true;
        } else if (keyword == "element") {
            const auto count = words.size() == 3 ? parse_integer(words[2]) : std::nullopt;
            if (!count || *count < 0) {
                throw InputError(fmt::format("{}: line {}: '{}': expected 'element <name> <count>'",
                                             names.file(), n, printable(line, 60)));
            }
            header.elements.push_back(
                {std::string(words[1]), static_cast<std::size_t>(*count), n, {}});
        } else if (keyword == "property") {
            if (header.elements.empty()) {
                throw InputError(fmt::format(
                    "{}: line {}: property before any element: expected 'element' first",
                    names.file(), n));
            }
            PlyProperty property;
            const bool list = words.size() >= 2 && words[1] == "list";
            if (words.size() != (list ? 5u : 3u)) {
                throw InputError(fmt::format(
                    "{}: line {}: '{}': expected 'property <type> <name>' or 'property list "
                    "<count type> <item type> <name>'",
                    names.file(), n, printable(line, 60)));
            }
            const std::size_t type_word = list ? 3 : 1;
            const auto type = ply_type(words[type_word]);
            const auto count_type = list ? ply_type(words[2]) : PlyType::uint8;
            if (!type || !count_type) {
                throw InputError(fmt::format(
                    "{}: line {}: unknown PLY type in '{}': expected char, uchar, short, ushort, "
                    "int, uint, float or double",
                    names.file(), n, printable(line, 60)));
            }
            if (list && ply_is_float(*count_type)) {
                throw InputError(
                    fmt::format("{}: line {}: list count type {}: expected an "
                                "integer type",
                                names.file(), n, ply_type_name(*count_type)));
            }
            property.name = std::string(words[type_word + 1]);
            property.type = *type;
            property.is_list = list;
            property.count_type = *count_type;
            header.elements.back().properties.push_back(std::move(property));
        } else {
            throw InputError(fmt::format(
                "{}: line {}: unknown PLY header line '{}': expected format, element, property, "
                "comment or end_header",
                names.file(), n, printable(line, 60)));
        }
    }
    if (!have_format) {
        throw InputError(
            fmt::format("{}: the PLY header has no 'format' line: expected 'format "
                        "ascii 1.0' or 'format binary_little_endian 1.0'",
                        names.file()));
    }
    header.body_offset = lines.offset();
    header.body_first_line = lines.number() + 1;
    return header;
}

// Reads element instances from a binary_little_endian body.
class PlyBinaryReader final {
public:
    PlyBinaryReader(std::string_view body, const Names& names) : body_(body), names_(names) {}

    void check_count(const PlyElement& element) const {
        // Smallest instance: lists empty. Guards the reservations below against a count
        // that the file cannot hold.
        std::size_t min_size = 0;
        for (const PlyProperty& p : element.properties) {
            min_size += ply_size(p.is_list ? p.count_type : p.type);
        }
        const std::size_t left = body_.size() - pos_;
        if (min_size > 0 && element.count > left / min_size) {
            throw InputError(fmt::format(
                "{}: element '{}' (line {}) declares {} instances of at least {} bytes, but only "
                "{} bytes are left: expected a count that matches the data",
                names_.file(), element.name, element.header_line, element.count, min_size, left));
        }
    }
    // check_count has bounded the count by the bytes left.
    std::size_t reservable(const PlyElement& element) const { return element.count; }
    void begin(const char* what, std::size_t index) {
        what_ = what;
        index_ = index;
    }
    double scalar(PlyType type, const PlyProperty& property) {
        const std::size_t size = ply_size(type);
        if (body_.size() - pos_ < size) {
            throw InputError(fmt::format(
                "{}: {} {}: the file ends inside property '{}': expected {} more bytes",
                names_.file(), what_, index_, property.name, size - (body_.size() - pos_)));
        }
        const char* p = body_.data() + pos_;
        pos_ += size;
        switch (type) {
            case PlyType::int8:
                return load<std::int8_t>(p);
            case PlyType::uint8:
                return load<std::uint8_t>(p);
            case PlyType::int16:
                return load<std::int16_t>(p);
            case PlyType::uint16:
                return load<std::uint16_t>(p);
            case PlyType::int32:
                return load<std::int32_t>(p);
            case PlyType::uint32:
                return load<std::uint32_t>(p);
            case PlyType::float32:
                return load<float>(p);
            case PlyType::float64:
                return load<double>(p);
        }
        return 0.0;
    }
    void end() {}
    std::size_t line() const { return 0; }
    void finish() const {
        if (pos_ != body_.size()) {
            throw InputError(fmt::format(
                "{}: {} bytes follow the last element: expected the file to end there (do the "
                "element counts match the data?)",
                names_.file(), body_.size() - pos_));
        }
    }

private:
    template <typename T>
    static double load(const char* p) {
        T value;
        std::memcpy(&value, p, sizeof(T));
        return static_cast<double>(value);
    }

    std::string_view body_;
    const Names& names_;
    std::size_t pos_ = 0;
    const char* what_ = "";
    std::size_t index_ = 0;
};

// Reads element instances from an ASCII body: one instance per line.
class PlyAsciiReader final {
public:
    PlyAsciiReader(std::string_view body, std::size_t first_line, const Names& names)
        : lines_(body, first_line), names_(names), text_size_(body.size()) {}

    void check_count(const PlyElement&) const {}
    // An ASCII count is only checked as lines run out; reserve no more than the text holds.
    std::size_t reservable(const PlyElement& element) const {
        return std::min(element.count, text_size_ / 6);
    }
    void begin(const char* what, std::size_t index) {
        what_ = what;
        index_ = index;
        std::string_view line;
        do {
            if (!lines_.next(line)) {
                throw InputError(
                    fmt::format("{}: the file ends before {} {}: expected one line "
                                "per element",
                                names_.file(), what_, index_));
            }
            split_words(line, words_);
        } while (words_.empty());
        next_word_ = 0;
    }
    double scalar(PlyType type, const PlyProperty& property) {
        if (next_word_ >= words_.size()) {
            throw InputError(fmt::format(
                "{}: {} {} (line {}): too few values: expected property "
                "'{}' ({})",
                names_.file(), what_, index_, lines_.number(), property.name, ply_type_name(type)));
        }
        const std::string_view token = words_[next_word_++];
        if (ply_is_float(type)) {
            const auto value = parse_double(token);
            if (!value) throw not_a_number(token, type, property);
            return *value;
        }
        const auto value = parse_integer(token);
        const long long lo = type == PlyType::int8    ? INT8_MIN
                             : type == PlyType::int16 ? INT16_MIN
                             : type == PlyType::int32 ? INT32_MIN
                                                      : 0;
        const long long hi = type == PlyType::int8     ? INT8_MAX
                             : type == PlyType::uint8  ? UINT8_MAX
                             : type == PlyType::int16  ? INT16_MAX
                             : type == PlyType::uint16 ? UINT16_MAX
                             : type == PlyType::int32  ? INT32_MAX
                                                       : UINT32_MAX;
        if (!value || *value < lo || *value > hi) throw not_a_number(token, type, property);
        return static_cast<double>(*value);
    }
    void end() const {
        if (next_word_ != words_.size()) {
            throw InputError(fmt::format("{}: {} {} (line {}): {} values: expected {}",
                                         names_.file(), what_, index_, lines_.number(),
                                         words_.size(), next_word_));
        }
    }
    std::size_t line() const { return lines_.number(); }
    void finish() {
        std::string_view line;
        while (lines_.next(line)) {
            split_words(line, words_);
            if (!words_.empty()) {
                throw InputError(fmt::format(
                    "{}: line {}: data after the last element: expected the file to end (do the "
                    "element counts match the data?)",
                    names_.file(), lines_.number()));
            }
        }
    }

private:
    InputError not_a_number(std::string_view token, PlyType type,
                            const PlyProperty& property) const {
        return InputError(
            fmt::format("{}: {} {} (line {}): '{}' is not a valid {}: expected "
                        "property '{}'",
                        names_.file(), what_, index_, lines_.number(), printable(token),
                        ply_type_name(type), property.name));
    }

    LineReader lines_;
    const Names& names_;
    std::size_t text_size_;
    std::vector<std::string_view> words_;
    std::size_t next_word_ = 0;
    const char* what_ = "";
    std::size_t index_ = 0;
};

template <typename Reader>
Soup read_ply_body(Reader& reader, const PlyHeader& header, double scale, const Names& names) {
    const PlyElement* vertex = nullptr;
    const PlyElement* face = nullptr;
    for (const PlyElement& e : header.elements) {
        if (e.name == "vertex") vertex = &e;
        if (e.name == "face") face = &e;
    }
    if (vertex == nullptr) {
        throw InputError(fmt::format("{}: no 'vertex' element: expected vertices", names.file()));
    }
    if (face == nullptr) {
        throw InputError(fmt::format(
            "{}: no 'face' element: expected a surface mesh, not a point cloud", names.file()));
    }
    if (vertex->count > kMaxVertices) {
        throw InputError(fmt::format("{}: {} vertices: expected at most {}", names.file(),
                                     vertex->count, kMaxVertices));
    }
    // Which vertex property is x, y, z, nx, ny, nz.
    std::array<int, 6> slot;
    slot.fill(-1);
    static constexpr const char* kVertexNames[] = {"x", "y", "z", "nx", "ny", "nz"};
    for (std::size_t i = 0; i < vertex->properties.size(); ++i) {
        const PlyProperty& p = vertex->properties[i];
        for (std::size_t s = 0; s < 6; ++s) {
            if (p.name != kVertexNames[s]) continue;
            if (p.is_list || !ply_is_float(p.type)) {
                throw InputError(fmt::format(
                    "{}: vertex property '{}' is {}{}: expected float or double", names.file(),
                    p.name, p.is_list ? "a list of " : "", ply_type_name(p.type)));
            }
            slot[s] = static_cast<int>(i);
        }
    }
    if (slot[0] < 0 || slot[1] < 0 || slot[2] < 0) {
        throw InputError(
            fmt::format("{}: element 'vertex' (line {}) lacks x, y or z: expected "
                        "all three",
                        names.file(), vertex->header_line));
    }
    const int normal_slots = (slot[3] >= 0) + (slot[4] >= 0) + (slot[5] >= 0);
    if (normal_slots != 0 && normal_slots != 3) {
        throw InputError(
            fmt::format("{}: element 'vertex' (line {}) has only some of nx, ny, "
                        "nz: expected all three or none",
                        names.file(), vertex->header_line));
    }
    int index_list = -1;
    for (std::size_t i = 0; i < face->properties.size(); ++i) {
        const PlyProperty& p = face->properties[i];
        if (p.name != "vertex_indices" && p.name != "vertex_index") continue;
        if (!p.is_list || ply_is_float(p.type)) {
            throw InputError(fmt::format("{}: face property '{}': expected a list of integers",
                                         names.file(), p.name));
        }
        index_list = static_cast<int>(i);
    }
    if (index_list < 0) {
        throw InputError(
            fmt::format("{}: element 'face' (line {}) has no 'vertex_indices' list: "
                        "expected 'property list uchar int vertex_indices'",
                        names.file(), face->header_line));
    }

    Soup soup;
    // Faces are kept raw until all vertices are known: the header may declare faces first.
    std::vector<std::int64_t> face_indices;
    std::vector<std::size_t> face_offsets{0};
    std::vector<std::size_t> face_lines;
    std::vector<double> values;
    for (const PlyElement& element : header.elements) {
        reader.check_count(element);
        const bool is_vertex = &element == vertex;
        const bool is_face = &element == face;
        const char* what = is_vertex ? "vertex" : is_face ? "face" : element.name.c_str();
        // An element without properties has nothing to read (and its count bounds nothing).
        if (element.properties.empty()) continue;
        if (is_vertex) {
            const std::size_t expected = reader.reservable(element);
            soup.positions.reserve(expected);
            if (normal_slots == 3) soup.normals.reserve(expected);
        }
        for (std::size_t i = 0; i < element.count; ++i) {
            reader.begin(what, i);
            values.assign(element.properties.size(), 0.0);
            for (std::size_t pi = 0; pi < element.properties.size(); ++pi) {
                const PlyProperty& p = element.properties[pi];
                if (!p.is_list) {
                    values[pi] = reader.scalar(p.type, p);
                    continue;
                }
                const double count = reader.scalar(p.count_type, p);
                if (count < 0) {
                    throw InputError(
                        fmt::format("{}: {} {}: list '{}' has {} items: expected a "
                                    "count >= 0",
                                    names.file(), what, i, p.name, count));
                }
                const auto items = static_cast<std::size_t>(count);
                const bool keep = is_face && static_cast<int>(pi) == index_list;
                for (std::size_t j = 0; j < items; ++j) {
                    const double item = reader.scalar(p.type, p);
                    if (keep) face_indices.push_back(static_cast<std::int64_t>(item));
                }
            }
            reader.end();
            if (is_vertex) {
                const Vec3 raw(values[static_cast<std::size_t>(slot[0])],
                               values[static_cast<std::size_t>(slot[1])],
                               values[static_cast<std::size_t>(slot[2])]);
                soup.positions.push_back(checked_position(raw, scale, names, i, reader.line()));
                soup.vertex_ordinal.push_back(i);
                soup.vertex_line.push_back(reader.line());
                if (normal_slots == 3) {
                    const Vec3 normal(values[static_cast<std::size_t>(slot[3])],
                                      values[static_cast<std::size_t>(slot[4])],
                                      values[static_cast<std::size_t>(slot[5])]);
                    soup.normals.push_back(
                        checked_normal(normal, names, names.vertex(i, reader.line())));
                }
            } else if (is_face) {
                face_offsets.push_back(face_indices.size());
                face_lines.push_back(reader.line());
            }
        }
    }
    reader.finish();
    if (face->count == 0) {
        throw InputError(
            fmt::format("{}: element 'face' is empty: expected a surface mesh, not a point cloud",
                        names.file()));
    }

    const auto vertex_count = static_cast<std::int64_t>(soup.positions.size());
    std::vector<std::uint32_t> polygon;
    for (std::size_t f = 0; f + 1 < face_offsets.size(); ++f) {
        polygon.clear();
        const std::size_t begin = face_offsets[f], end = face_offsets[f + 1];
        if (end - begin < 3) {
            throw InputError(fmt::format("{}: {} has {} vertices: expected at least 3",
                                         names.file(), names.face(f, face_lines[f]), end - begin));
        }
        for (std::size_t j = begin; j < end; ++j) {
            if (face_indices[j] < 0 || face_indices[j] >= vertex_count) {
                throw InputError(fmt::format(
                    "{}: {}: vertex index {} is out of range: expected 0..{} ({} vertices)",
                    names.file(), names.face(f, face_lines[f]), face_indices[j], vertex_count - 1,
                    vertex_count));
            }
            polygon.push_back(static_cast<std::uint32_t>(face_indices[j]));
        }
        add_polygon(soup, polygon, f, face_lines[f], names);
    }
    return soup;
}

Soup parse_ply(std::string_view bytes, double scale, const Names& names) {
    const PlyHeader header = parse_ply_header(bytes, names);
    const std::string_view body = bytes.substr(header.body_offset);
    if (header.binary) {
        PlyBinaryReader reader(body, names);
        return read_ply_body(reader, header, scale, names);
    }
    PlyAsciiReader reader(body, header.body_first_line, names);
    return read_ply_body(reader, header, scale, names);
}

// ---------------------------------------------------------------------------------------
// Checks and repairs.

// Counts every defect, lists the first kMaxListedPerKind of each kind; the message is only
// formatted for listed ones.
class Reporter final {
public:
    explicit Reporter(MeshReport& report) : report_(report) {}

    template <typename MakeMessage>
    void add(MeshDefectKind kind, std::size_t index, std::size_t other, std::size_t line,
             bool repaired, MakeMessage&& make_message) {
        std::size_t& count = report_.counts[static_cast<std::size_t>(kind)];
        if (++count <= MeshReport::kMaxListedPerKind) {
            report_.defects.push_back({kind, index, other, line, make_message(), repaired});
        }
    }

private:
    MeshReport& report_;
};

bool is_blocking(MeshDefectKind kind, bool repair) {
    switch (kind) {
        case MeshDefectKind::border_edge:
        case MeshDefectKind::non_manifold_edge:
        case MeshDefectKind::non_manifold_vertex:
        case MeshDefectKind::non_orientable:
        case MeshDefectKind::self_intersection:
            return true;
        case MeshDefectKind::degenerate_face:
        case MeshDefectKind::inconsistent_orientation:
        case MeshDefectKind::inward_orientation:
        case MeshDefectKind::shading_normal_flipped:
            return !repair;
        case MeshDefectKind::duplicate_vertex:
        case MeshDefectKind::isolated_vertex:
        case MeshDefectKind::shading_normals_dropped:
            return false;
    }
    return true;
}

std::size_t blocking_count(const MeshReport& report, bool repair) {
    std::size_t total = 0;
    for (std::size_t k = 0; k < kMeshDefectKinds; ++k) {
        if (is_blocking(static_cast<MeshDefectKind>(k), repair)) total += report.counts[k];
    }
    return total;
}

// Keeps the triangles whose flag is set, with their sources.
void keep_triangles(Soup& soup, const std::vector<char>& keep) {
    std::size_t out = 0;
    for (std::size_t t = 0; t < soup.triangles.size(); ++t) {
        if (!keep[t]) continue;
        soup.triangles[out] = soup.triangles[t];
        soup.face_ordinal[out] = soup.face_ordinal[t];
        soup.face_line[out] = soup.face_line[t];
        ++out;
    }
    soup.triangles.resize(out);
    soup.face_ordinal.resize(out);
    soup.face_line.resize(out);
}

void drop_normals(Soup& soup, Reporter& reporter, const std::string& reason) {
    soup.normals.clear();
    reporter.add(MeshDefectKind::shading_normals_dropped, 0, 0, 0, true, [&] {
        return fmt::format("{}: shading normals dropped, the tracer uses face normals", reason);
    });
}

// 1. Bit-identical positions. Returns, per vertex, whether it was merged into another.
std::vector<char> merge_duplicates(Soup& soup, const Names& names, bool repair,
                                   Reporter& reporter) {
    const std::size_t n = soup.positions.size();
    std::vector<std::uint32_t> order(n);
    std::iota(order.begin(), order.end(), 0u);
    const auto& p = soup.positions;
    std::sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) {
        if (p[a].x() != p[b].x()) return p[a].x() < p[b].x();
        if (p[a].y() != p[b].y()) return p[a].y() < p[b].y();
        if (p[a].z() != p[b].z()) return p[a].z() < p[b].z();
        return a < b;
    });
    std::vector<std::uint32_t> target(n);
    std::iota(target.begin(), target.end(), 0u);
    std::vector<char> merged(n, 0);
    std::optional<std::string> normal_conflict;
    for (std::size_t i = 1, keep = 0; i < n; ++i) {
        const std::uint32_t v = order[i];
        if (p[v] != p[order[keep]]) {
            keep = i;
            continue;
        }
        const std::uint32_t kept = order[keep];  // the first in file order of the group
        reporter.add(MeshDefectKind::duplicate_vertex, soup.vertex_ordinal[v],
                     soup.vertex_ordinal[kept], soup.vertex_line[v], repair, [&] {
                         return fmt::format("{} is at the same position as {}, {} µm: {}",
                                            soup.vertex_name(names, v),
                                            soup.vertex_name(names, kept), format_vec(p[v]),
                                            repair ? "merged" : "not merged (repair is off)");
                     });
        if (!repair) continue;
        target[v] = kept;
        merged[v] = 1;
        if (!soup.normals.empty() && !normal_conflict &&
            (soup.normals[v] - soup.normals[kept]).norm() > 1e-6) {
            normal_conflict = fmt::format(
                "{} and {} share a position but not a shading normal "
                "(a crease)",
                soup.vertex_name(names, v), soup.vertex_name(names, kept));
        }
    }
    if (repair) {
        for (Triangle& t : soup.triangles) {
            for (std::uint32_t& v : t) v = target[v];
        }
    }
    if (normal_conflict) drop_normals(soup, reporter, *normal_conflict);
    return merged;
}

// 2. Triangles with a repeated vertex or collinear vertices (exact predicate).
void remove_degenerate(Soup& soup, const Names& names, bool repair, Reporter& reporter) {
    std::vector<char> keep(soup.triangles.size(), 1);
    for (std::size_t t = 0; t < soup.triangles.size(); ++t) {
        const auto [a, b, c] = soup.triangles[t];
        const char* reason = nullptr;
        if (a == b || b == c || a == c) {
            reason = "uses one vertex twice";
        } else if (CGAL::collinear(soup.point(a), soup.point(b), soup.point(c))) {
            reason = "has zero area (its vertices are collinear)";
        }
        if (reason == nullptr) continue;
        keep[t] = 0;
        reporter.add(MeshDefectKind::degenerate_face, soup.face_ordinal[t], 0, soup.face_line[t],
                     repair, [&] {
                         return fmt::format(
                             "{} {}: {}", soup.face_name(names, t), reason,
                             repair ? "removed" : "expected a triangle of non-zero area");
                     });
    }
    // Removed even without repair: the later checks need a clean surface to say anything,
    // and import rejects the mesh anyway.
    keep_triangles(soup, keep);
}

// 3. Vertices in no triangle. Merged duplicates are removed silently (already reported).
void remove_isolated(Soup& soup, const Names& names, bool repair, const std::vector<char>& merged,
                     Reporter& reporter) {
    const std::size_t n = soup.positions.size();
    std::vector<char> used(n, 0);
    for (const Triangle& t : soup.triangles) {
        for (const std::uint32_t v : t) used[v] = 1;
    }
    for (std::uint32_t v = 0; v < n; ++v) {
        if (used[v] || merged[v]) continue;
        reporter.add(MeshDefectKind::isolated_vertex, soup.vertex_ordinal[v], 0,
                     soup.vertex_line[v], repair, [&] {
                         return fmt::format("{} is in no face: {}", soup.vertex_name(names, v),
                                            repair ? "removed" : "left (repair is off)");
                     });
    }
    if (!repair) return;
    std::vector<std::uint32_t> index(n, 0);
    std::uint32_t out = 0;
    for (std::uint32_t v = 0; v < n; ++v) {
        if (!used[v]) continue;
        index[v] = out;
        soup.positions[out] = soup.positions[v];
        if (!soup.normals.empty()) soup.normals[out] = soup.normals[v];
        soup.vertex_ordinal[out] = soup.vertex_ordinal[v];
        soup.vertex_line[out] = soup.vertex_line[v];
        ++out;
    }
    soup.positions.resize(out);
    if (!soup.normals.empty()) soup.normals.resize(out);
    soup.vertex_ordinal.resize(out);
    soup.vertex_line.resize(out);
    for (Triangle& t : soup.triangles) {
        for (std::uint32_t& v : t) v = index[v];
    }
}

class UnionFind final {
public:
    explicit UnionFind(std::size_t n) : parent_(n) {
        std::iota(parent_.begin(), parent_.end(), std::size_t{0});
    }
    std::size_t find(std::size_t x) {
        while (parent_[x] != x) x = parent_[x] = parent_[parent_[x]];
        return x;
    }
    void unite(std::size_t a, std::size_t b) { parent_[find(a)] = find(b); }

private:
    std::vector<std::size_t> parent_;
};

struct Topology {
    std::vector<std::uint32_t> component;  // per triangle
    std::size_t components = 0;
    bool closed = true;
};

constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();

// 4–6. Edge incidence: borders, non-manifold edges and vertices, then a consistent winding
// per edge-connected component (breadth-first, flipping the minority). Returns nullopt when
// a blocking defect was found.
std::optional<Topology> check_topology(Soup& soup, const Names& names, bool repair,
                                       bool require_closed, Reporter& reporter,
                                       const MeshReport& report) {
    const std::size_t faces = soup.triangles.size();
    struct HalfEdge {
        std::uint32_t lo, hi, face;
        std::uint8_t k;  // the edge from corner k to corner k + 1
        bool forward;    // lo → hi
    };
    std::vector<HalfEdge> half_edges;
    half_edges.reserve(3 * faces);
    for (std::size_t f = 0; f < faces; ++f) {
        const Triangle& t = soup.triangles[f];
        for (std::uint8_t k = 0; k < 3; ++k) {
            const std::uint32_t a = t[k], b = t[(k + 1) % 3];
            half_edges.push_back(
                {std::min(a, b), std::max(a, b), static_cast<std::uint32_t>(f), k, a < b});
        }
    }
    std::sort(half_edges.begin(), half_edges.end(), [](const HalfEdge& x, const HalfEdge& y) {
        return std::tie(x.lo, x.hi, x.face, x.k) < std::tie(y.lo, y.hi, y.face, y.k);
    });

    auto corner = [&](std::uint32_t f, std::uint32_t v) {
        const Triangle& t = soup.triangles[f];
        return 3 * std::size_t{f} + (t[0] == v ? 0 : t[1] == v ? 1 : 2);
    };
    auto edge_name = [&](const HalfEdge& h) {
        return fmt::format("edge between {} and {}", soup.vertex_name(names, h.lo),
                           soup.vertex_name(names, h.hi));
    };
    UnionFind corners(3 * faces);
    // Across each manifold edge: the neighbouring face, and whether it runs the edge the
    // same way (which consistent winding forbids).
    std::vector<std::uint32_t> neighbour(3 * faces, kNone);
    std::vector<char> same_direction(3 * faces, 0);
    std::vector<char> on_bad_edge(soup.positions.size(), 0);
    Topology topology;
    for (std::size_t i = 0; i < half_edges.size();) {
        std::size_t j = i + 1;
        while (j < half_edges.size() && half_edges[j].lo == half_edges[i].lo &&
               half_edges[j].hi == half_edges[i].hi) {
            ++j;
        }
        const HalfEdge& h = half_edges[i];
        if (j - i == 1) {
            topology.closed = false;
            if (require_closed) {
                reporter.add(MeshDefectKind::border_edge, soup.face_ordinal[h.face], 0,
                             soup.face_line[h.face], false, [&] {
                                 return fmt::format(
                                     "border edge: {} of {} has no other face, the mesh is open "
                                     "there (a missing face?): expected a closed surface "
                                     "(require_closed = false accepts open films)",
                                     edge_name(h), soup.face_name(names, h.face));
                             });
            }
        } else if (j - i > 2) {
            on_bad_edge[h.lo] = on_bad_edge[h.hi] = 1;
            reporter.add(
                MeshDefectKind::non_manifold_edge, soup.face_ordinal[h.face],
                soup.face_ordinal[half_edges[i + 1].face], soup.face_line[h.face], false, [&] {
                    std::string list;
                    for (std::size_t e = i; e < j && e < i + 4; ++e) {
                        list += (e > i ? ", " : "") + soup.face_name(names, half_edges[e].face);
                    }
                    if (j - i > 4) list += ", ...";
                    return fmt::format(
                        "non-manifold edge: {} is shared by {} faces ({}): "
                        "expected at most 2",
                        edge_name(h), j - i, list);
                });
        } else {
            const HalfEdge& g = half_edges[i + 1];
            corners.unite(corner(h.face, h.lo), corner(g.face, h.lo));
            corners.unite(corner(h.face, h.hi), corner(g.face, h.hi));
            const bool same = h.forward == g.forward;
            neighbour[3 * std::size_t{h.face} + h.k] = g.face;
            neighbour[3 * std::size_t{g.face} + g.k] = h.face;
            same_direction[3 * std::size_t{h.face} + h.k] = same;
            same_direction[3 * std::size_t{g.face} + g.k] = same;
        }
        i = j;
    }
    // A manifold vertex has one fan of faces around it, joined through its edges.
    std::vector<std::pair<std::uint32_t, std::size_t>> vertex_fans;
    vertex_fans.reserve(3 * faces);
    for (std::size_t c = 0; c < 3 * faces; ++c) {
        vertex_fans.emplace_back(soup.triangles[c / 3][c % 3], corners.find(c));
    }
    std::sort(vertex_fans.begin(), vertex_fans.end());
    vertex_fans.erase(std::unique(vertex_fans.begin(), vertex_fans.end()), vertex_fans.end());
    for (std::size_t i = 0; i < vertex_fans.size();) {
        std::size_t j = i + 1;
        while (j < vertex_fans.size() && vertex_fans[j].first == vertex_fans[i].first) ++j;
        const std::uint32_t v = vertex_fans[i].first;
        // (A vertex on a non-manifold edge is already named by that edge.)
        if (j - i > 1 && !on_bad_edge[v]) {
            reporter.add(MeshDefectKind::non_manifold_vertex, soup.vertex_ordinal[v], 0,
                         soup.vertex_line[v], false, [&] {
                             return fmt::format(
                                 "non-manifold vertex: the faces around {} form {} separate fans "
                                 "(surfaces touching at a point): expected one",
                                 soup.vertex_name(names, v), j - i);
                         });
        }
        i = j;
    }
    if (blocking_count(report, true) > 0) return std::nullopt;

    // Winding: parity[f] says whether f must flip to agree with its component's seed.
    topology.component.assign(faces, kNone);
    std::vector<char> parity(faces, 0);
    std::vector<std::uint32_t> members;
    bool orientable = true;
    for (std::uint32_t seed = 0; seed < faces; ++seed) {
        if (topology.component[seed] != kNone) continue;
        const auto id = static_cast<std::uint32_t>(topology.components++);
        members.clear();
        members.push_back(seed);
        topology.component[seed] = id;
        bool this_orientable = true;
        for (std::size_t m = 0; m < members.size(); ++m) {
            const std::uint32_t f = members[m];
            for (std::size_t k = 0; k < 3; ++k) {
                const std::uint32_t g = neighbour[3 * std::size_t{f} + k];
                if (g == kNone) continue;
                const char expected = parity[f] ^ same_direction[3 * std::size_t{f} + k];
                if (topology.component[g] == kNone) {
                    topology.component[g] = id;
                    parity[g] = expected;
                    members.push_back(g);
                } else if (parity[g] != expected) {
                    this_orientable = false;
                }
            }
        }
        if (!this_orientable) {
            orientable = false;
            reporter.add(MeshDefectKind::non_orientable, soup.face_ordinal[seed], 0,
                         soup.face_line[seed], false, [&] {
                             return fmt::format(
                                 "non-orientable surface: the surface containing {} is one-sided, "
                                 "like a Möbius strip: expected a two-sided surface",
                                 soup.face_name(names, seed));
                         });
            continue;
        }
        std::size_t odd = 0;
        for (const std::uint32_t f : members) odd += parity[f];
        // Flip the smaller class: the faces that disagree with most of their surface.
        const char flip = odd <= members.size() - odd ? 1 : 0;
        for (const std::uint32_t f : members) {
            if (parity[f] != flip) continue;
            reporter.add(MeshDefectKind::inconsistent_orientation, soup.face_ordinal[f], 0,
                         soup.face_line[f], repair, [&] {
                             return fmt::format(
                                 "{} winds against its neighbours (inconsistent orientation): {}",
                                 soup.face_name(names, f),
                                 repair ? "flipped"
                                        : "expected the winding of its neighbours (repair is off)");
                         });
            std::swap(soup.triangles[f][1], soup.triangles[f][2]);
        }
    }
    if (!orientable) return std::nullopt;
    return topology;
}

// The soup as a CGAL halfedge mesh: face i is triangle i; vertices in no triangle are left
// out (orient_to_bound_a_volume crashes on isolated vertices, which the soup keeps when
// repair is off), so soup_vertex maps the mesh's vertices back.
struct CgalMesh {
    SurfaceMesh mesh;
    std::vector<std::uint32_t> soup_vertex;
};

CgalMesh to_surface_mesh(const Soup& soup) {
    // Invariant of check_topology: CGAL can hold the soup as a halfedge mesh.
    PLUMAGE_CHECK(PMP::is_polygon_soup_a_polygon_mesh(soup.triangles),
                  "a soup that passed the topology checks must be a polygon mesh");
    CgalMesh out;
    std::vector<std::uint32_t> mesh_vertex(soup.positions.size(), kNone);
    for (const Triangle& t : soup.triangles) {
        for (const std::uint32_t v : t) {
            if (mesh_vertex[v] != kNone) continue;
            mesh_vertex[v] = static_cast<std::uint32_t>(out.soup_vertex.size());
            out.soup_vertex.push_back(v);
        }
    }
    SurfaceMesh& mesh = out.mesh;
    mesh.reserve(static_cast<SurfaceMesh::size_type>(out.soup_vertex.size()),
                 static_cast<SurfaceMesh::size_type>(3 * soup.triangles.size() / 2 + 3),
                 static_cast<SurfaceMesh::size_type>(soup.triangles.size()));
    for (const std::uint32_t v : out.soup_vertex) mesh.add_vertex(soup.point(v));
    for (std::size_t t = 0; t < soup.triangles.size(); ++t) {
        const Triangle& tri = soup.triangles[t];
        const auto f = mesh.add_face(SurfaceMesh::Vertex_index(mesh_vertex[tri[0]]),
                                     SurfaceMesh::Vertex_index(mesh_vertex[tri[1]]),
                                     SurfaceMesh::Vertex_index(mesh_vertex[tri[2]]));
        PLUMAGE_CHECK(f != SurfaceMesh::null_face() && f.idx() == t,
                      "Surface_mesh faces must follow the soup's triangle order");
    }
    return out;
}

// 7. Pairs of faces that cross (CGAL's box-intersection filter, exact predicates).
void check_self_intersections(const Soup& soup, const SurfaceMesh& mesh, const Names& names,
                              Reporter& reporter) {
    std::vector<std::pair<SurfaceMesh::Face_index, SurfaceMesh::Face_index>> pairs;
    PMP::self_intersections(mesh, std::back_inserter(pairs));
    // Name each pair of file faces once (a polygon is several triangles).
    std::set<std::pair<std::size_t, std::size_t>> named;
    for (const auto& [fa, fb] : pairs) {
        std::size_t a = fa.idx(), b = fb.idx();
        if (soup.face_ordinal[a] > soup.face_ordinal[b]) std::swap(a, b);
        if (!named.emplace(soup.face_ordinal[a], soup.face_ordinal[b]).second) continue;
        reporter.add(MeshDefectKind::self_intersection, soup.face_ordinal[a], soup.face_ordinal[b],
                     soup.face_line[a], false, [&] {
                         return fmt::format(
                             "self-intersection: {} and {} cross: expected a surface that does "
                             "not pass through itself",
                             soup.face_name(names, a), soup.face_name(names, b));
                     });
    }
}

// 8. Closed meshes: each shell oriented so that the mesh bounds a volume (outer shells
// outward, shells nested inside them inward, and so on), by CGAL's nesting analysis.
void orient_volume(Soup& soup, CgalMesh& cgal, const Topology& topology, const Names& names,
                   bool repair, Reporter& reporter) {
    SurfaceMesh& mesh = cgal.mesh;
    PMP::orient_to_bound_a_volume(mesh);
    std::vector<std::size_t> flipped(topology.components, 0);
    std::vector<std::uint32_t> first(topology.components, kNone);
    std::vector<std::size_t> size(topology.components, 0);
    for (std::size_t t = 0; t < soup.triangles.size(); ++t) {
        const auto h = mesh.halfedge(SurfaceMesh::Face_index(static_cast<std::uint32_t>(t)));
        const std::uint32_t v0 = cgal.soup_vertex[mesh.target(h).idx()];
        const std::uint32_t v1 = cgal.soup_vertex[mesh.target(mesh.next(h)).idx()];
        Triangle& tri = soup.triangles[t];
        const std::size_t at = tri[0] == v0 ? 0 : tri[1] == v0 ? 1 : 2;
        const std::uint32_t c = topology.component[t];
        ++size[c];
        if (first[c] == kNone) first[c] = static_cast<std::uint32_t>(t);
        if (tri[(at + 1) % 3] != v1) {
            std::swap(tri[1], tri[2]);
            ++flipped[c];
        }
    }
    for (std::size_t c = 0; c < topology.components; ++c) {
        if (flipped[c] == 0) continue;
        // A shell is flipped as a whole: its winding was already made consistent.
        PLUMAGE_CHECK(flipped[c] == size[c], "orient_to_bound_a_volume flips whole shells");
        reporter.add(MeshDefectKind::inward_orientation, soup.face_ordinal[first[c]], 0,
                     soup.face_line[first[c]], repair, [&] {
                         return fmt::format(
                             "the closed shell containing {} ({} triangles) is inside-out (its "
                             "faces wind clockwise seen from the side they should face): {}",
                             soup.face_name(names, first[c]), size[c],
                             repair ? "flipped"
                                    : "expected counter-clockwise winding seen from outside "
                                      "(repair is off)");
                     });
    }
}

// 9. A shading normal must lie on the side its faces face, or shading turns black.
void check_shading_normals(Soup& soup, const Names& names, bool repair, Reporter& reporter) {
    if (soup.normals.empty()) return;
    std::vector<Vec3> face_sum(soup.positions.size(), Vec3::Zero());
    for (const Triangle& t : soup.triangles) {
        const Vec3& a = soup.positions[t[0]];
        // Twice the area vector: an area-weighted average direction.
        const Vec3 area = (soup.positions[t[1]] - a).cross(soup.positions[t[2]] - a);
        for (const std::uint32_t v : t) face_sum[v] += area;
    }
    for (std::uint32_t v = 0; v < soup.positions.size(); ++v) {
        if (soup.normals[v].dot(face_sum[v]) >= 0.0) continue;
        reporter.add(MeshDefectKind::shading_normal_flipped, soup.vertex_ordinal[v], 0,
                     soup.vertex_line[v], repair, [&] {
                         return fmt::format(
                             "{}: shading normal {} points against its faces: {}",
                             soup.vertex_name(names, v), format_vec(soup.normals[v]),
                             repair ? "flipped" : "expected it on their side (repair is off)");
                     });
        soup.normals[v] = -soup.normals[v];
    }
}

// Runs checks 1–9 on the soup, repairing it in place where `repair` (and, so that later
// checks can see past them, removing degenerate faces and fixing windings even without;
// callers that do not repair do not use the soup afterwards).
void check_soup(Soup& soup, const Names& names, bool repair, bool require_closed,
                MeshReport& report) {
    Reporter reporter(report);
    report.vertices_read = soup.positions.size();
    report.faces_read = soup.faces_read;
    const std::vector<char> merged = merge_duplicates(soup, names, repair, reporter);
    remove_degenerate(soup, names, repair, reporter);
    if (soup.triangles.empty()) return;
    remove_isolated(soup, names, repair, merged, reporter);
    const std::optional<Topology> topology =
        check_topology(soup, names, repair, require_closed, reporter, report);
    if (!topology) return;
    report.components = topology->components;
    report.closed = topology->closed;
    CgalMesh cgal = to_surface_mesh(soup);
    check_self_intersections(soup, cgal.mesh, names, reporter);
    if (blocking_count(report, true) > 0) return;
    // An open mesh has no inside to point away from: its components keep the winding of
    // their majority.
    if (topology->closed) orient_volume(soup, cgal, *topology, names, repair, reporter);
    check_shading_normals(soup, names, repair, reporter);
    report.triangles_out = soup.triangles.size();
}

[[noreturn]] void reject(const MeshReport& report, const Names& names, bool repair) {
    const std::size_t total = blocking_count(report, repair);
    std::string message =
        fmt::format("{}: mesh rejected, {} defect{} that {} {}:", names.file(), total,
                    total == 1 ? "" : "s", total == 1 ? "is" : "are",
                    repair ? "not safely repairable" : "not repaired (repair is off)");
    std::size_t named = 0;
    for (const MeshDefect& d : report.defects) {
        if (!is_blocking(d.kind, repair)) continue;
        if (named++ == kMaxNamedInMessage) break;
        message += "\n  " + d.message;
    }
    if (total > kMaxNamedInMessage) {
        message += fmt::format("\n  ... and {} more", total - kMaxNamedInMessage);
    }
    throw InputError(message);
}

std::string lower_extension(const std::filesystem::path& path) {
    std::string extension = path.extension().string();
    for (char& c : extension) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return extension;
}

std::string read_bytes(const std::filesystem::path& path) {
    std::error_code error;
    const auto status = std::filesystem::status(path, error);
    if (!std::filesystem::exists(status)) {
        throw InputError(fmt::format("mesh file '{}' does not exist", path.string()));
    }
    if (std::filesystem::is_directory(status)) {
        throw InputError(fmt::format("mesh file '{}' is a directory: expected a PLY or OBJ file",
                                     path.string()));
    }
    std::ifstream in(path, std::ios::binary);
    if (!in) throw IoError(fmt::format("cannot open mesh file '{}'", path.string()));
    in.seekg(0, std::ios::end);
    const std::streamoff size = in.tellg();
    in.seekg(0, std::ios::beg);
    std::string bytes(static_cast<std::size_t>(std::max<std::streamoff>(size, 0)), '\0');
    in.read(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    if (!in) throw IoError(fmt::format("cannot read mesh file '{}'", path.string()));
    return bytes;
}

}  // namespace

void MeshImportOptions::validate() const {
    if (!std::isfinite(scale_to_um) || !(scale_to_um > 0.0)) {
        throw InputError(fmt::format(
            "mesh import: scale_to_um = {}: expected a finite length > 0 (µm per file unit)",
            scale_to_um));
    }
}

const char* to_string(MeshDefectKind kind) {
    switch (kind) {
        case MeshDefectKind::duplicate_vertex:
            return "duplicate vertex";
        case MeshDefectKind::degenerate_face:
            return "degenerate face";
        case MeshDefectKind::isolated_vertex:
            return "isolated vertex";
        case MeshDefectKind::border_edge:
            return "border edge";
        case MeshDefectKind::non_manifold_edge:
            return "non-manifold edge";
        case MeshDefectKind::non_manifold_vertex:
            return "non-manifold vertex";
        case MeshDefectKind::non_orientable:
            return "non-orientable surface";
        case MeshDefectKind::inconsistent_orientation:
            return "inconsistent orientation";
        case MeshDefectKind::self_intersection:
            return "self-intersection";
        case MeshDefectKind::inward_orientation:
            return "inward orientation";
        case MeshDefectKind::shading_normal_flipped:
            return "shading normal flipped";
        case MeshDefectKind::shading_normals_dropped:
            return "shading normals dropped";
    }
    return "?";
}

bool MeshReport::clean() const {
    return std::all_of(counts.begin(), counts.end(), [](std::size_t c) { return c == 0; });
}

std::string MeshReport::summary() const {
    std::string out;
    for (const MeshDefect& d : defects) {
        out += fmt::format("{}{}: {}\n", d.repaired ? "[repaired] " : "", to_string(d.kind),
                           d.message);
    }
    for (std::size_t k = 0; k < kMeshDefectKinds; ++k) {
        if (counts[k] > kMaxListedPerKind) {
            out += fmt::format("... {} {} defects in all\n", counts[k],
                               to_string(static_cast<MeshDefectKind>(k)));
        }
    }
    return out;
}

ImportedMesh import_mesh(const std::filesystem::path& path, const MeshImportOptions& options) {
    options.validate();
    const std::string extension = lower_extension(path);
    const Source source = extension == ".ply"   ? Source::ply
                          : extension == ".obj" ? Source::obj
                                                : Source::memory;
    if (source == Source::memory) {
        throw InputError(
            fmt::format("mesh file '{}': unknown format '{}': expected a .ply or "
                        ".obj file",
                        path.string(), extension));
    }
    const Names names(source, fmt::format("'{}'", path.string()));
    const std::string bytes = read_bytes(path);
    if (bytes.empty()) {
        throw InputError(fmt::format("{}: the file is empty: expected a {} mesh", names.file(),
                                     source == Source::ply ? "PLY" : "OBJ"));
    }
    ImportedMesh imported;
    Reporter reporter(imported.report);
    Soup soup;
    if (source == Source::ply) {
        soup = parse_ply(bytes, options.scale_to_um, names);
    } else {
        ObjNormals normals;
        soup = parse_obj(bytes, options.scale_to_um, names, normals);
        if (normals.dropped_because) drop_normals(soup, reporter, *normals.dropped_because);
    }
    check_soup(soup, names, options.repair, options.require_closed, imported.report);
    if (soup.triangles.empty()) {
        throw InputError(
            fmt::format("{}: every face is degenerate (zero area; {} read): expected a surface",
                        names.file(), soup.faces_read));
    }
    if (blocking_count(imported.report, options.repair) > 0) {
        reject(imported.report, names, options.repair);
    }
    imported.mesh.positions = std::move(soup.positions);
    imported.mesh.shading_normals = std::move(soup.normals);
    imported.mesh.triangles = std::move(soup.triangles);
    return imported;
}

TriangleMesh read_mesh(const std::filesystem::path& path, const MeshImportOptions& options) {
    return import_mesh(path, options).mesh;
}

MeshReport check_mesh(const TriangleMesh& mesh, bool require_closed) {
    const Names names(Source::memory, "in-memory mesh");
    if (!mesh.shading_normals.empty() && mesh.shading_normals.size() != mesh.positions.size()) {
        throw InputError(
            fmt::format("{}: {} shading normals for {} vertices: expected none or "
                        "one per vertex",
                        names.file(), mesh.shading_normals.size(), mesh.positions.size()));
    }
    if (mesh.positions.size() > kMaxVertices) {
        throw InputError(fmt::format("{}: {} vertices: expected at most {}", names.file(),
                                     mesh.positions.size(), kMaxVertices));
    }
    Soup soup;
    soup.positions = mesh.positions;
    soup.normals = mesh.shading_normals;
    for (std::size_t v = 0; v < mesh.positions.size(); ++v) {
        checked_position(mesh.positions[v], 1.0, names, v, 0);
        soup.vertex_ordinal.push_back(v);
        soup.vertex_line.push_back(0);
    }
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
        for (const std::uint32_t v : mesh.triangles[t]) {
            if (v >= mesh.positions.size()) {
                throw InputError(fmt::format(
                    "{}: triangle {}: vertex index {} is out of range: "
                    "expected 0..{}",
                    names.file(), t, v, static_cast<long long>(mesh.positions.size()) - 1));
            }
        }
        soup.add_triangle(mesh.triangles[t][0], mesh.triangles[t][1], mesh.triangles[t][2], t, 0);
    }
    soup.faces_read = mesh.triangles.size();
    MeshReport report;
    if (soup.triangles.empty()) return report;
    check_soup(soup, names, /*repair=*/false, require_closed, report);
    return report;
}

}  // namespace plumage::geometry
