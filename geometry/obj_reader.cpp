// OBJ statements → polygon soup (mesh_import.h describes the subset read).
//
// Kept, not replaced by CGAL::IO::read_OBJ (CGAL 5.5), because its errors are clearer: measured
// on the malformed-mesh corpus by tests/geometry/mesh_reader_errors_test.cpp (issue 18; run it
// to print the full table with both readers' messages). CGAL never names the file or a line;
// ours names the file always and the line wherever there is one, and says what was expected.
//
//   file             ours                               CGAL read_OBJ (verbose)
//   empty / only #   rejects: "the file is empty" /     rejects: "warning: empty file?"
//                    "no vertices ('v' lines)"
//   points only      rejects: "no faces ('f' lines)"    rejects: "warning: empty file?"
//   PNG bytes        rejects: "binary data (starts      rejects: "error: unrecognized line: …"
//                    with ...)"
//   'hello' line 2   rejects: "line 2: unsupported      rejects: "error: unrecognized line: hello"
//                    OBJ statement 'hello' ..."
//   v 1.0abc / v 0 0 rejects: "line 2: '1.0abc' is     rejects: "error while reading OBJ vertex."
//   / v nan          not a number ..." etc.
//   f 2 3 9, f -9 …  rejects: "face on line 9: vertex   rejects: "error: invalid face index"
//                    index 9 is out of range: 1..4"
//   f 0 1 2          rejects (index 0, line 9)          ACCEPTS (stores an invalid index)
//   f 1/1 … (no vt)  rejects (texture index, line 9)    accepts (ignores texture indices)
//   f 1 2            rejects ("has 2 vertices")         ACCEPTS a 2-corner polygon
//
// 13 files: ours rejects 13 and names file 13/13, line 10/10 where one applies; CGAL rejects 10,
// names the file 0 times, a line 0 times. (tinyobjloader is not a Debian 12 package: not tried.)
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <fmt/format.h>

#include "common/error.h"
#include "geometry/mesh_import_detail.h"

namespace plumage::geometry::mesh_import_detail {

// ---------------------------------------------------------------------------------------
// OBJ.

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

}  // namespace plumage::geometry::mesh_import_detail
