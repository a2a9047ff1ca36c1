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

namespace {

// One OBJ file's statements, line by line (parse_obj): the soup, the normals and the counts that
// later lines' indices refer to.
class ObjParser {
public:
    ObjParser(double scale, const Names& names, ObjNormals& normals)
        : scale_(scale), names_(names), normals_(normals) {}

    void statement(std::string_view line, std::size_t n) {
        n_ = n;
        if (const std::size_t hash = line.find('#'); hash != std::string_view::npos) {
            line = line.substr(0, hash);
        }
        split_words(line, words_);
        if (words_.empty()) return;
        const std::string_view keyword = words_[0];
        if (keyword == "v") {
            vertex();
        } else if (keyword == "vn") {
            normal();
        } else if (keyword == "vt") {
            ++texture_coordinates_;
        } else if (keyword == "f") {
            face();
        } else if (keyword == "vp" || keyword == "usemtl" || keyword == "mtllib" ||
                   keyword == "o" || keyword == "g" || keyword == "s") {
            // Parameter-space vertices, materials, object/group names and smoothing groups
            // do not change the surface.
        } else {
            throw InputError(fmt::format(
                "{}: line {}: unsupported OBJ statement '{}': expected v, vn or f (vt, vp, "
                "usemtl, mtllib, o, g and s are ignored)",
                names_.file(), n_, printable(keyword)));
        }
    }

    Soup finish() {
        if (soup_.positions.empty()) {
            throw InputError(
                fmt::format("{}: no vertices ('v' lines): expected an OBJ mesh", names_.file()));
        }
        if (faces_ == 0) {
            throw InputError(
                fmt::format("{}: no faces ('f' lines): expected a surface mesh, not a point cloud",
                            names_.file()));
        }
        if (normals_.corner_with && !normals_.dropped_because) gather_vertex_normals();
        return std::move(soup_);
    }

private:
    // words_[first …] as numbers (the first three kept).
    Vec3 numbers(std::size_t first, std::size_t count, const char* expected) const {
        Vec3 v = Vec3::Zero();
        for (std::size_t i = 0; i < count; ++i) {
            const auto value = parse_double(words_[first + i]);
            if (!value) {
                throw InputError(fmt::format("{}: line {}: '{}' is not a number: expected {}",
                                             names_.file(), n_, printable(words_[first + i]),
                                             expected));
            }
            if (i < 3) v[static_cast<Eigen::Index>(i)] = *value;
        }
        return v;
    }

    void vertex() {
        // x y z, optionally a weight w (for rational curves; meaningless on a
        // polygon) or r g b (a vertex colour): both ignored.
        const std::size_t count = words_.size() - 1;
        if (count != 3 && count != 4 && count != 6) {
            throw InputError(fmt::format(
                "{}: line {}: 'v' with {} values: expected x y z (then optionally w, or r g b)",
                names_.file(), n_, count));
        }
        const Vec3 raw = numbers(1, count, "vertex coordinates 'v x y z'");
        const std::size_t ordinal = soup_.positions.size();
        if (ordinal >= kMaxVertices) {
            throw InputError(fmt::format("{}: line {}: more than {} vertices: expected fewer",
                                         names_.file(), n_, kMaxVertices));
        }
        soup_.positions.push_back(checked_position(raw, scale_, names_, ordinal, n_));
        soup_.vertex_ordinal.push_back(ordinal);
        soup_.vertex_line.push_back(n_);
    }

    void normal() {
        if (words_.size() != 4) {
            throw InputError(fmt::format("{}: line {}: 'vn' with {} values: expected nx ny nz",
                                         names_.file(), n_, words_.size() - 1));
        }
        const Vec3 raw = numbers(1, 3, "a normal 'vn nx ny nz'");
        if (!raw.allFinite()) {
            throw InputError(fmt::format("{}: line {}: normal {}: expected finite numbers",
                                         names_.file(), n_, format_vec(raw)));
        }
        normals_.values.push_back(raw);
        normals_.lines.push_back(n_);
    }

    void face() {
        if (words_.size() < 4) {
            throw InputError(fmt::format("{}: face on line {} has {} vertices: expected at least 3",
                                         names_.file(), n_, words_.size() - 1));
        }
        polygon_.clear();
        corner_normals_.clear();
        for (std::size_t c = 1; c < words_.size(); ++c) corner(words_[c]);
        assign_corner_normals();
        add_polygon(soup_, polygon_, faces_, n_, names_);
        ++faces_;
    }

    // One corner: v, v/vt, v//vn or v/vt/vn.
    void corner(std::string_view word) {
        std::string_view parts[3];
        std::size_t part_count = 0;
        bool too_many_parts = false;
        for (std::string_view rest = word;;) {
            if (part_count == 3) {
                too_many_parts = true;
                break;
            }
            const std::size_t slash = rest.find('/');
            parts[part_count++] = rest.substr(0, slash);
            if (slash == std::string_view::npos) break;
            rest.remove_prefix(slash + 1);
        }
        if (too_many_parts || parts[0].empty()) {
            throw InputError(
                fmt::format("{}: face on line {}: '{}': expected v, v/vt, v//vn or v/vt/vn",
                            names_.file(), n_, printable(word)));
        }
        polygon_.push_back(
            static_cast<std::uint32_t>(index(word, parts[0], soup_.positions.size(), "vertex")));
        // Texture coordinates are not used, but a dangling one means a corrupt file.
        if (part_count >= 2 && !parts[1].empty()) {
            index(word, parts[1], texture_coordinates_, "texture coordinate");
        }
        corner_normals_.push_back(part_count == 3 && !parts[2].empty()
                                      ? index(word, parts[2], normals_.values.size(), "normal")
                                      : -1);
    }

    // A corner's index among the `available` defined before this line, 0-based.
    std::int64_t index(std::string_view word, std::string_view token, std::size_t available,
                       const char* what) const {
        const auto value = parse_integer(token);
        if (!value) {
            throw InputError(
                fmt::format("{}: face on line {}: '{}' is not an index: expected v, v/vt, v//vn "
                            "or v/vt/vn with integer indices",
                            names_.file(), n_, printable(word)));
        }
        const auto count = static_cast<long long>(available);
        // Negative indices count back from the last one read before this line.
        const long long resolved = *value > 0 ? *value - 1 : count + *value;
        if (count == 0) {
            throw InputError(
                fmt::format("{}: face on line {}: {} index {} is out of range: none is defined "
                            "before this line",
                            names_.file(), n_, what, *value));
        }
        if (*value == 0 || resolved < 0 || resolved >= count) {
            throw InputError(
                fmt::format("{}: face on line {}: {} index {} is out of range: expected 1..{} or "
                            "-{}..-1 ({} defined before this line)",
                            names_.file(), n_, what, *value, count, count, count));
        }
        return resolved;
    }

    // The face's corner normals onto its vertices, or the reason per-vertex normals cannot hold
    // them (some corners without, or a crease).
    void assign_corner_normals() {
        normals_.vertex_normal.resize(soup_.positions.size(), -1);
        for (std::size_t c = 0; c < polygon_.size() && !normals_.dropped_because; ++c) {
            const std::uint32_t v = polygon_[c];
            const std::int64_t vn = corner_normals_[c];
            (vn >= 0 ? normals_.corner_with : normals_.corner_without) = true;
            if (normals_.corner_with && normals_.corner_without) {
                normals_.dropped_because = fmt::format(
                    "some face corners have normals and others not (face on line {})", n_);
                break;
            }
            if (vn < 0) continue;
            std::int64_t& assigned = normals_.vertex_normal[v];
            const Vec3& value = normals_.values[static_cast<std::size_t>(vn)];
            if (assigned >= 0 && assigned != vn &&
                (normals_.values[static_cast<std::size_t>(assigned)] - value).norm() >
                    1e-6 * value.norm()) {
                normals_.dropped_because = fmt::format(
                    "{} has different normals on different faces (line {}): a crease, "
                    "which per-vertex shading normals cannot hold",
                    names_.vertex(v, soup_.vertex_line[v]), n_);
                break;
            }
            assigned = vn;
        }
    }

    void gather_vertex_normals() {
        soup_.normals.assign(soup_.positions.size(), Vec3::UnitZ());
        normals_.vertex_normal.resize(soup_.positions.size(), -1);
        for (std::size_t v = 0; v < soup_.positions.size(); ++v) {
            // Vertices in no face get none; they are isolated and removed (or, with repair
            // off, keep +z: no triangle interpolates it).
            const std::int64_t vn = normals_.vertex_normal[v];
            if (vn < 0) continue;
            const auto i = static_cast<std::size_t>(vn);
            soup_.normals[v] = checked_normal(
                normals_.values[i], names_,
                fmt::format("{} (normal on line {})", names_.vertex(v, soup_.vertex_line[v]),
                            normals_.lines[i]));
        }
    }

    double scale_;
    const Names& names_;
    ObjNormals& normals_;
    Soup soup_;
    std::size_t texture_coordinates_ = 0, faces_ = 0, n_ = 0;
    std::vector<std::string_view> words_;
    std::vector<std::uint32_t> polygon_;
    std::vector<std::int64_t> corner_normals_;
};

}  // namespace

Soup parse_obj(std::string_view text, double scale, const Names& names, ObjNormals& normals) {
    // OBJ has no magic number: binary bytes early on mean it is some other file.
    const std::string_view head = text.substr(0, 4096);
    if (head.find('\0') != std::string_view::npos) {
        throw InputError(
            fmt::format("{}: binary data (starts with \"{}\"): expected a text OBJ "
                        "file",
                        names.file(), printable(text.substr(0, 16))));
    }
    ObjParser parser(scale, names, normals);
    LineReader lines(text);
    std::string_view line;
    while (lines.next(line)) parser.statement(line, lines.number());
    return parser.finish();
}

}  // namespace plumage::geometry::mesh_import_detail
